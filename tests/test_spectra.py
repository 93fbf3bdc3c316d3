"""``<spectrum>`` -> RGB as Mitsuba 3.9.1's RGB variants convert it."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from pathtracer.scene import cie, spectra
from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import load_scene

CASES = ["0.5", "2.0", "400:0.1, 500:0.5, 600:0.9", "400:0.78 500:0.78 600:0.78 700:0.78",
         "400:0, 500:8, 600:15.6, 700:18.4", "360:0.2, 830:0.2", "450:0.3, 451:0.9, 452:0.3"]
# The measured spectra of the Cornell box (Cornell University Program of Computer
# Graphics' published data, as used by Mitsuba's spectral Cornell box scene).
CBOX_SPECTRA = {
    "white": (
        "400:0.343, 404:0.445, 408:0.551, 412:0.624, 416:0.665, 420:0.687, 424:0.708, 428:0.723, "
        "432:0.715, 436:0.71, 440:0.745, 444:0.758, 448:0.739, 452:0.767, 456:0.777, 460:0.765, "
        "464:0.751, 468:0.745, 472:0.748, 476:0.729, 480:0.745, 484:0.757, 488:0.753, 492:0.75, "
        "496:0.746, 500:0.747, 504:0.735, 508:0.732, 512:0.739, 516:0.734, 520:0.725, 524:0.721, "
        "528:0.733, 532:0.725, 536:0.732, 540:0.743, 544:0.744, 548:0.748, 552:0.728, 556:0.716, "
        "560:0.733, 564:0.726, 568:0.713, 572:0.74, 576:0.754, 580:0.764, 584:0.752, 588:0.736, "
        "592:0.734, 596:0.741, 600:0.74, 604:0.732, 608:0.745, 612:0.755, 616:0.751, 620:0.744, "
        "624:0.731, 628:0.733, 632:0.744, 636:0.731, 640:0.712, 644:0.708, 648:0.729, 652:0.73, "
        "656:0.727, 660:0.707, 664:0.703, 668:0.729, 672:0.75, 676:0.76, 680:0.751, 684:0.739, "
        "688:0.724, 692:0.73, 696:0.74, 700:0.737"
    ),
    "red": (
        "400:0.04, 404:0.046, 408:0.048, 412:0.053, 416:0.049, 420:0.05, 424:0.053, 428:0.055, "
        "432:0.057, 436:0.056, 440:0.059, 444:0.057, 448:0.061, 452:0.061, 456:0.06, 460:0.062, "
        "464:0.062, 468:0.062, 472:0.061, 476:0.062, 480:0.06, 484:0.059, 488:0.057, 492:0.058, "
        "496:0.058, 500:0.058, 504:0.056, 508:0.055, 512:0.056, 516:0.059, 520:0.057, 524:0.055, "
        "528:0.059, 532:0.059, 536:0.058, 540:0.059, 544:0.061, 548:0.061, 552:0.063, 556:0.063, "
        "560:0.067, 564:0.068, 568:0.072, 572:0.08, 576:0.09, 580:0.099, 584:0.124, 588:0.154, "
        "592:0.192, 596:0.255, 600:0.287, 604:0.349, 608:0.402, 612:0.443, 616:0.487, 620:0.513, "
        "624:0.558, 628:0.584, 632:0.62, 636:0.606, 640:0.609, 644:0.651, 648:0.612, 652:0.61, "
        "656:0.65, 660:0.638, 664:0.627, 668:0.62, 672:0.63, 676:0.628, 680:0.642, 684:0.639, "
        "688:0.657, 692:0.639, 696:0.635, 700:0.642"
    ),
    "green": (
        "400:0.092, 404:0.096, 408:0.098, 412:0.097, 416:0.098, 420:0.095, 424:0.095, 428:0.097, "
        "432:0.095, 436:0.094, 440:0.097, 444:0.098, 448:0.096, 452:0.101, 456:0.103, 460:0.104, "
        "464:0.107, 468:0.109, 472:0.112, 476:0.115, 480:0.125, 484:0.14, 488:0.16, 492:0.187, "
        "496:0.229, 500:0.285, 504:0.343, 508:0.39, 512:0.435, 516:0.464, 520:0.472, 524:0.476, "
        "528:0.481, 532:0.462, 536:0.447, 540:0.441, 544:0.426, 548:0.406, 552:0.373, 556:0.347, "
        "560:0.337, 564:0.314, 568:0.285, 572:0.277, 576:0.266, 580:0.25, 584:0.23, 588:0.207, "
        "592:0.186, 596:0.171, 600:0.16, 604:0.148, 608:0.141, 612:0.136, 616:0.13, 620:0.126, "
        "624:0.123, 628:0.121, 632:0.122, 636:0.119, 640:0.114, 644:0.115, 648:0.117, 652:0.117, "
        "656:0.118, 660:0.12, 664:0.122, 668:0.128, 672:0.132, 676:0.139, 680:0.144, 684:0.146, "
        "688:0.15, 692:0.152, 696:0.157, 700:0.159"
    ),
    "light": (
        "400:0.78, 500:0.78, 600:0.78, 700:0.78"
    ),
    "light_emission": "400:0, 500:8, 600:15.6, 700:18.4",
}
SENSOR = ('<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/>'
          '<integer name="height" value="8"/><rfilter type="box"/></film></sensor>')


def test_cie_tables_are_the_standard():
    # Spot values of CIE 1931 (2 degree) and D65 at 5 nm.
    grid = np.linspace(360, 830, 95)
    at = {w: i for i, w in enumerate(grid)}
    assert cie.CIE_Y[at[555]] == pytest.approx(1.0)
    assert cie.CIE_X[at[600]] == pytest.approx(1.0622)
    assert cie.CIE_Z[at[450]] == pytest.approx(1.7721, abs=2e-4)
    assert cie.D65[at[560]] == pytest.approx(100.0)
    # The luminance normaliser is the 5 nm trapezoid integral of CIE_Y, within 0.1 %.
    y_integral = 5.0 * (cie.CIE_Y.sum() - 0.5 * (cie.CIE_Y[0] + cie.CIE_Y[-1]))
    assert cie.CIE_Y_INTEGRAL == pytest.approx(y_integral, rel=1e-3)


def test_flat_reflectance_is_grey_and_flat_emission_is_the_equal_energy_white():
    flat = spectra.parse_spectrum("360:0.5, 830:0.5")
    # D65 weighting makes a flat reflectance neutral in sRGB (D65 white point).
    np.testing.assert_allclose(spectra.to_rgb(flat, "reflectance"), 0.5, rtol=2e-3)
    # Emission is unweighted: an equal-energy spectrum, M (1, 1, 1) up to the
    # quadrature error of the 1000-point rule.
    white_e = spectra.XYZ_TO_SRGB.sum(axis=1)
    np.testing.assert_allclose(spectra.to_rgb(flat, "emission"), 0.5 * white_e, rtol=2e-3)
    # A uniform value: a grey for reflectances, exactly v M (1, 1, 1) for emitters.
    uniform = spectra.parse_spectrum("0.5")
    np.testing.assert_array_equal(spectra.to_rgb(uniform, "reflectance"), [0.5] * 3)
    np.testing.assert_allclose(spectra.to_rgb(uniform, "emission"), 0.5 * white_e, rtol=1e-15)


def test_conversion_is_linear_and_clamped_as_documented():
    a = spectra.parse_spectrum("400:0.1, 500:0.3, 600:0.2")
    b = spectra.parse_spectrum("400:0.3, 500:0.9, 600:0.6")  # 3 a
    np.testing.assert_allclose(spectra.to_rgb(b, "emission"), 3 * spectra.to_rgb(a, "emission"),
                               rtol=1e-12)
    bright = spectra.parse_spectrum("400:0, 500:8, 600:15.6, 700:18.4")
    with pytest.warns(UserWarning, match="clamping"):
        assert np.all(spectra.to_rgb(bright, "reflectance") == 1.0)
    assert np.all(spectra.to_rgb(bright, "unbounded") > 1.0)
    # Pure 450 nm light is outside the sRGB gamut: red < 0 is clamped to 0.
    with pytest.warns(UserWarning, match="clamping"):
        assert spectra.to_rgb(spectra.parse_spectrum("449:0, 450:1, 451:0"), "emission")[1] == 0


@pytest.mark.parametrize("text, message", [
    ("400:0.1", "at least two"), ("400:0.1, 400:0.2", "increase"), ("400-0.1, 500:2", "wavelength:value"),
    ("abc", "could not parse")])
def test_malformed_spectra(text, message):
    with pytest.raises(ValueError, match=message):
        spectra.parse_spectrum(text)


def test_spectrum_in_a_scene_depends_on_the_plugin(tmp_path):
    path = tmp_path / "s.xml"
    path.write_text(f'''<scene version="3.0.0">{SENSOR}
        <bsdf type="diffuse" id="b"><spectrum name="reflectance" value="400:0.1, 500:0.5, 600:0.9"/></bsdf>
        <shape type="cube"><ref id="b"/><emitter type="area">
            <spectrum name="radiance" wavelengths="400, 500, 600" values="0.1, 0.5, 0.9"/></emitter></shape>
        <emitter type="point"><spectrum name="intensity" value="3"/></emitter></scene>''')
    scene = load_scene(str(path))
    curve = spectra.parse_spectrum("400:0.1, 500:0.5, 600:0.9")
    np.testing.assert_array_equal(scene.bsdfs[0].reflectance, spectra.to_rgb(curve, "reflectance"))
    np.testing.assert_array_equal(scene.emitters[0].radiance, spectra.to_rgb(curve, "emission"))
    np.testing.assert_allclose(scene.emitters[1].intensity, 3 * spectra.XYZ_TO_SRGB.sum(axis=1))


def test_spectrum_file(tmp_path):
    (tmp_path / "curve.spd").write_text("# wavelength value\n400 0.1\n500 0.5\n\n600 0.9\n")
    path = tmp_path / "s.xml"
    path.write_text(f'''<scene version="3.0.0">{SENSOR}
        <shape type="cube"><bsdf type="diffuse"><spectrum name="reflectance" filename="curve.spd"/>
        </bsdf></shape></scene>''')
    expected = spectra.to_rgb(spectra.parse_spectrum("400:0.1, 500:0.5, 600:0.9"), "reflectance")
    np.testing.assert_array_equal(load_scene(str(path)).bsdfs[0].reflectance, expected)
    (tmp_path / "curve.spd").write_text("400 0.1 7\n")
    with pytest.raises(SceneError, match=r"s.xml:2: .*expected \"wavelength value\""):
        load_scene(str(path))


@pytest.mark.mitsuba
@pytest.mark.parametrize("text", CASES)
def test_matches_mitsuba(text, mi):
    bsdf = mi.load_string(f'<bsdf version="3.0.0" type="diffuse">'
                          f'<spectrum name="reflectance" value="{text}"/></bsdf>')
    shape = mi.load_string(f'<shape version="3.0.0" type="sphere"><emitter type="area">'
                           f'<spectrum name="radiance" value="{text}"/></emitter></shape>')
    refl = np.broadcast_to(np.asarray(mi.traverse(bsdf)["reflectance.value"]), (3,))
    emit = np.asarray(mi.traverse(shape)["emitter.radiance.value"])
    spectrum = spectra.parse_spectrum(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the clamping warnings, tested above
        ours_refl = spectra.to_rgb(spectrum, "reflectance")
        ours_emit = spectra.to_rgb(spectrum, "emission")
        ours_unbounded = spectra.to_rgb(spectrum, "unbounded")
    # Mitsuba sums the 1000 terms in float32: agreement to ~1e-5 relative.
    np.testing.assert_allclose(ours_refl, refl, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(ours_emit, emit, rtol=1e-5, atol=1e-7)
    unbounded = np.asarray(mi.spectrum_list_to_srgb(list(spectrum.wavelengths), list(
        spectrum.values), False, True)) if not spectrum.uniform else np.full(3, spectrum.values[0])
    np.testing.assert_allclose(ours_unbounded, unbounded, rtol=1e-5, atol=1e-7)


@pytest.mark.mitsuba
def test_spectral_cornell_box_colours_match_mitsuba(tmp_path, mi):
    """Mitsuba's classic spectral Cornell box (its measured reflectance and light
    spectra), as Mitsuba's RGB variants see it."""
    body = "".join(f'<bsdf type="diffuse" id="{name}"><spectrum name="reflectance" value="{value}"/>'
                   f'</bsdf>' for name, value in CBOX_SPECTRA.items() if name != "light_emission")
    body += ('<shape type="rectangle"><ref id="white"/><emitter type="area"><spectrum name="radiance" '
             f'value="{CBOX_SPECTRA["light_emission"]}"/></emitter></shape>')
    path = tmp_path / "cbox_colours.xml"
    path.write_text(f'<scene version="3.0.0">{SENSOR}{body}</scene>')
    ours = load_scene(str(path))
    params = mi.traverse(mi.load_file(str(path)))
    names = [name for name in CBOX_SPECTRA if name != "light_emission"]
    for name, bsdf in zip(names, ours.bsdfs):
        np.testing.assert_allclose(bsdf.reflectance, np.asarray(params[f"{name}.reflectance.value"]),
                                   rtol=2e-6, err_msg=name)
    radiance = next(k for k in params.keys() if k.endswith("radiance.value"))
    np.testing.assert_allclose(ours.emitters[0].radiance, np.asarray(params[radiance]), rtol=2e-6)
