"""Render a Mitsuba reference: per-pixel mean and per-sample variance.

``render_reference`` loads one of the scene XML files both renderers share,
sets the film size and the integrator options the tracer's loader reads from
the same file (:func:`reference_settings`: literal values, ``$params``,
``<default>``s and overrides alike), and renders it with the Mitsuba estimator
matching one of ours. Per-pixel mean and per-sample variance come from single
samples (:mod:`mitsuba_refs.reference.batch`: ``k`` copies of the camera side by side,
one sample per pixel each, no Python per sample) in ``scalar_rgb``; in JIT
variants the ``rgb_moments`` wrapper (:mod:`mitsuba_refs.reference.moments`), which
runs there once per wavefront (:func:`default_method`). A tent or gaussian film's
samples are weighted by Mitsuba's film in JIT variants, and in ``scalar_rgb``, whose
film tabulates the weights, by NumPy at their recomputed positions
(:mod:`mitsuba_refs.reference.filtered`; :func:`choose_method`).

Integrator mapping (ours -> Mitsuba):

==============  =====================================================
``path``        ``path`` (MIS of BSDF and emitter sampling)
``path_bsdf``   ``lecture_path_bsdf`` (:mod:`.integrators.path_bsdf`)
``path_nee``    ``lecture_path_nee`` (:mod:`.integrators.path_nee`)
``direct``      ``direct`` with the file's ``emitter_samples`` and ``bsdf_samples``
                where its ``<integrator>`` is ``direct``, else 1 each
``light``       ``ptracer`` (particle tracer), rendered as independent
                replicas (:func:`_render_replicas`)
``recursive``,  ``path``: same expectation, a different estimator, so
``smallpt``     only the mean of such a reference is meaningful
``volpath``     ``volpath`` (media: free flight, shadow rays through null
                boundaries, MIS)
``volpath_phase`` ``volpath``: same expectation, mean only
``volpathmis``  ``volpathmis``: spectral MIS weighted per path there, per flight
                here (:mod:`pathtracer.integrators.volpathmis`): mean only
==============  =====================================================

A particle tracer's samples do not belong to pixels, so its per-pixel variance
comes from ``config.REF_REPLICAS`` independent renders with different seeds, as
the tracer's own light renders do (:func:`pathtracer.render.splats.render_splats`).
"""

import dataclasses
import hashlib
import json
import math
import time
from pathlib import Path

import numpy as np

from pathtracer.core.names import suggestion
from pathtracer.core.progress import Progress
from pathtracer.integrators import make_integrator
from pathtracer.render.driver import transport_options
from pathtracer.render.moments import combine_power_means
from pathtracer.render.splats import replica_count
from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import scene_file
from pathtracer.scene.settings import scene_settings
from pathtracer.scene.xml_files import read_elements, scene_tree, walk

from . import config, moments
from .batch import render_moments
from .filtered import integrator_with_blocks, render_filtered_moments
from .rfilter import check_variant, film_filter, filter_metadata, per_sample_variance
from .seeds import pass_seeds
from .split import current_split
from .variant import set_variant

#: our integrator name -> Mitsuba integrator type
INTEGRATOR_MAP = {
    "path": "path",
    "path_bsdf": "lecture_path_bsdf",
    "path_nee": "lecture_path_nee",
    "direct": "direct",
    "recursive": "path",
    "smallpt": "path",
    "light": "ptracer",
    "volpath": "volpath",
    "volpath_phase": "volpath",
    "volpathmis": "volpathmis",
}

#: Mitsuba integrator types written in Python (:mod:`mitsuba_refs.reference.integrators`): one
#: Python call per sample in scalar variants.
PYTHON_TYPES = ("lecture_path_bsdf", "lecture_path_nee")

#: integrators whose reference variance is *not* that of our estimator
MEAN_ONLY = ("recursive", "smallpt", "volpath_phase", "volpathmis")

#: parameters that belong to the integrator, not to the XML defaults
INTEGRATOR_PARAMS = ("max_depth", "rr_depth", "hide_emitters")


@dataclasses.dataclass
class Reference:
    """A rendered (or cached) reference image.

    Attributes
    ----------
    mean : ndarray (H, W, 3) float64
        Per-pixel mean radiance over ``n`` samples.
    var : ndarray (H, W, 3) float64
        Unbiased per-sample variance (``var / n`` is the variance of ``mean``).
    n : int
        Samples per pixel.
    metadata : dict
        Scene, params, integrator, seeds, variant, Mitsuba version, hashes...
    """

    mean: np.ndarray
    var: np.ndarray
    n: int
    metadata: dict


def resolve_scene(scene):
    """Return the file of ``scene``: a file path, or a built-in name
    (``cornell-box`` -> ``pathtracer/data/scenes/cornell-box.xml``), by the tracer's rule
    (:func:`pathtracer.scene.scene_file`); ``FileNotFoundError`` with its message otherwise."""
    try:
        return Path(scene_file(scene)).resolve()
    except SceneError as error:
        raise FileNotFoundError(str(error)) from None


def scene_name(scene):
    """Short name of a scene (file stem)."""
    return resolve_scene(scene).stem


def xml_defaults(path):
    """Names and values of the ``<default>`` declarations of a scene file (not of the files it
    includes)."""
    return {d.attrs.get("name"): d.attrs.get("value")
            for d in walk(read_elements(str(path), str(path))) if d.tag == "default"}


def _elements(path, tag):
    """The ``tag`` elements of the scene file ``path`` and of the files it ``<include>``s,
    spliced in where the include stands, as the tracer's loader reads them
    (:func:`pathtracer.scene.xml_files.scene_tree`)."""
    return [el for el in walk(scene_tree(str(path))) if el.tag == tag]


def _children(el, tag):
    return [child for child in el.children if child.tag == tag]


def check_box_filter(path):
    """Raise ``ValueError`` unless every film of the scene file uses
    ``<rfilter type="box"/>`` (Mitsuba's default is a gaussian, which makes
    pixels correlated weighted ratios)."""
    films = _elements(path, "film")
    if not films:
        raise ValueError(f"{path}: no <film> (nor in its <include>d files); Mitsuba's "
                         f"default film has a gaussian filter; add <film type=\"hdrfilm\"> "
                         f"with <rfilter type=\"box\"/>")
    for film in films:
        rfilters = _children(film, "rfilter")
        if len(rfilters) != 1 or rfilters[0].attrs.get("type") != "box":
            kind = rfilters[0].attrs.get("type") if rfilters else "gaussian (default)"
            raise ValueError(f"{path}: film reconstruction filter is {kind}; "
                             f"references need <rfilter type=\"box\"/>")


def sensor_has_medium(path):
    """True when a sensor of the scene file holds a ``<medium>`` (nested or by ``<ref>``).

    Mitsuba's ``batch`` sensor (the batch method's camera copies) does not pass its
    copies' medium on, so camera rays would start in vacuum: such scenes use the
    ``moments`` method.
    """
    return any(child.tag in ("medium", "ref") for sensor in _elements(path, "sensor")
               for child in sensor.children)


#: Film reconstruction filters both renderers implement (mitsuba_refs.reference.rfilter).
SUPPORTED_FILTERS = ("box", "tent", "gaussian")


def check_film_filter(path):
    """Raise ``ValueError`` when a film of the scene file (or its ``<include>``d files) uses
    a reconstruction filter other than box, tent or gaussian (the tracer's), naming it.

    A film without ``<rfilter>`` gets Mitsuba's default gaussian; a ``$param`` type is
    checked once Mitsuba has loaded the film (:func:`render_reference`).
    """
    for film in _elements(path, "film"):
        for rfilter in _children(film, "rfilter"):
            kind = rfilter.attrs.get("type") or ""
            if "$" not in kind and kind not in SUPPORTED_FILTERS:
                raise ValueError(f"{path}: film reconstruction filter is {kind}; references "
                                 f"support {', '.join(SUPPORTED_FILTERS)}")


def reference_settings(path, params, options=None, resolution=None):
    """What the reference of a file renders, read by the tracer's own loader.

    Parameters
    ----------
    path : Path
        Scene file.
    params : dict
        ``-D`` values; each must be declared by the file (``<default>`` or
        ``$name``), else :class:`pathtracer.SceneError` (as for the tracer).
    options : dict, optional
        Integrator option overrides (``max_depth``, ``rr_depth``,
        ``hide_emitters``), as given to the tracer's ``render``.
    resolution : (int, int), optional
        Film size replacing the file's.

    Returns
    -------
    (scene_kw, transport, settings)
        ``scene_kw``: the parameters for Mitsuba's parser (strings);
        ``transport``: the effective ``max_depth``/``rr_depth``/``hide_emitters``
        (:func:`pathtracer.render.transport_options`), whatever set them;
        ``settings``: :class:`pathtracer.scene.settings.SceneSettings`.
    """
    scene_kw = {str(k): str(v) for k, v in (params or {}).items()}
    settings = scene_settings(path, resolution=resolution, **scene_kw)
    transport = transport_options(settings.integrator, **(options or {}))
    return scene_kw, transport, settings


def bounce_reference(reference_name: str) -> str:
    """The Mitsuba estimator of the per-bounce references: ``path``, but ``volpath`` where the
    comparison's reference is a volumetric one (``path`` ignores media)."""
    return "volpath" if reference_name in ("volpath", "volpathmis") else "path"


def split_params(path, params, options=None):
    """``(scene_kw, integrator options)`` of :func:`reference_settings`."""
    scene_kw, transport, _ = reference_settings(path, params, options)
    return scene_kw, transport


def direct_samples(file_integrator) -> dict:
    """``emitter_samples`` and ``bsdf_samples`` of a ``direct`` reference: the file's own
    when its ``<integrator>`` is ``direct`` (the tracer's ``direct`` then renders with all
    the file's parameters, :func:`pathtracer.render.driver.integrator_for`), else 1 each,
    the tracer's defaults (and Mitsuba's). The counts come from the tracer's ``direct``
    itself, so that its rules (``shading_samples`` sets both) live in one place."""
    params = file_integrator.params if file_integrator is not None and \
        file_integrator.name == "direct" else {}
    options = make_integrator("direct", **params).options()
    return {key: options[key] for key in ("emitter_samples", "bsdf_samples")}


def integrator_dict(integrator, integ_kw, file_integrator=None):
    """Mitsuba integrator dictionary for our integrator name (``file_integrator``: the
    file's ``<integrator>``, an IntegratorSpec, whose sample counts a ``direct`` keeps)."""
    try:
        mitsuba_type = INTEGRATOR_MAP[integrator]
    except KeyError:
        raise ValueError(f"unknown integrator {integrator!r}; {suggestion(integrator, INTEGRATOR_MAP)}"
                         f"known: {sorted(INTEGRATOR_MAP)}") from None
    d = {"type": mitsuba_type}
    if mitsuba_type == "direct":
        d.update(direct_samples(file_integrator))
        if "hide_emitters" in integ_kw:
            d["hide_emitters"] = _as_bool(integ_kw["hide_emitters"])
        return d
    for key in ("max_depth", "rr_depth"):
        if key in integ_kw:
            d[key] = int(integ_kw[key])
    if "hide_emitters" in integ_kw:
        d["hide_emitters"] = _as_bool(integ_kw["hide_emitters"])
    return d


def _as_bool(value):
    if isinstance(value, str):
        return value.strip().lower() in ("1", "true", "yes", "on")
    return bool(value)


def stream_id(integrator, params, options=None, resolution=None):
    """A 20-bit number identifying (estimator, parameters, overrides), mixed into the
    seeds so that references of different integrators or parameters made
    with the same ``seed`` are independent (equal seeds would make e.g.
    ``path`` and ``lecture_path_nee`` nearly identical, sample by sample,
    and a two-sample test between them meaningless)."""
    parts = [INTEGRATOR_MAP.get(integrator, integrator),
             {str(k): str(v) for k, v in sorted((params or {}).items())}]
    if options or resolution is not None:   # (absent: the committed references' streams)
        parts += [{str(k): str(v) for k, v in sorted((options or {}).items())},
                  list(resolution) if resolution is not None else None]
    text = json.dumps(parts)
    return int(hashlib.sha256(text.encode()).hexdigest()[:5], 16)


def load_mitsuba_scene(path, scene_kw, resolution=None):
    """Load ``path`` with Mitsuba's parser, the film size replaced by ``resolution``.

    The film's ``width``/``height`` are edited in the parsed description before
    the objects are made, so Mitsuba's sensor converts ``fov``/``fov_axis`` at the
    new aspect itself (not a copy of the tracer's conversion).
    """
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders
    config = mi.parser.ParserConfig(mi.variant())
    state = mi.parser.parse_file(config, str(path), **scene_kw)
    if resolution is not None:
        films = [node for node in state.nodes if node.type == mi.ObjectType.Film]
        if len(films) != 1:
            raise ValueError(f"{path}: --resolution needs exactly one <film>, found {len(films)}")
        films[0].props["width"], films[0].props["height"] = (int(v) for v in resolution)
    independent_samplers(state)
    mi.parser.transform_all(config, state)
    resolver = mi.file_resolver()
    saved = [resolver[i] for i in range(len(resolver))]
    resolver.prepend(str(Path(path).resolve().parent))   # relative mesh/texture names
    try:
        return mi.parser.instantiate(config, state)
    finally:
        resolver.clear()
        for folder in saved:
            resolver.append(folder)


def independent_samplers(state):
    """Make every ``<sampler>`` of a parsed scene ``independent`` (its ``sample_count`` and
    ``seed`` kept): the tracer samples independently whatever the file says, and the
    statistics assume i.i.d. samples, which stratified, multijitter, orthogonal and
    ldsampler patterns are not (their per-pixel variance is lower)."""
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders
    for node in state.nodes:
        if node.type != mi.ObjectType.Sampler or node.props.plugin_name() == "independent":
            continue
        node.props.set_plugin_name("independent")
        for name in list(node.props.keys()):
            if name not in ("sample_count", "seed"):
                del node.props[name]


def check_framing(path, mi_scene, settings):
    """Raise ``ValueError`` unless Mitsuba's sensor has the tracer's film size and fov."""
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders
    sensor = mi_scene.sensors()[0]
    size = tuple(int(v) for v in sensor.film().crop_size())
    if size != settings.resolution:
        raise ValueError(f"{path}: Mitsuba's film is {size[0]}x{size[1]}, the tracer's "
                         f"{settings.resolution[0]}x{settings.resolution[1]}")
    params = mi.traverse(sensor)
    if "x_fov" not in params:   # an orthographic sensor has no field of view
        return
    x_fov = float(np.ravel(np.array(params["x_fov"]))[0])
    if abs(x_fov - settings.camera.x_fov) > 1e-3:
        raise ValueError(f"{path}: Mitsuba's horizontal field of view is {x_fov:.4f} degrees, "
                         f"the tracer's {settings.camera.x_fov:.4f}")


def default_method(variant):
    """``batch`` in scalar variants, where the wrapper would call Python per sample;
    ``moments`` in JIT variants, where it runs once per wavefront and measured as fast
    or faster (docs/references.md)."""
    return "batch" if variant.startswith("scalar") else "moments"


def choose_method(variant, rfilter, mitsuba_integrator, camera_in_medium, requested=None):
    """How a reference is rendered: ``batch``, ``moments`` or ``replicas``.

    ``replicas`` for the particle tracer (box films only); the wrapper (``moments``) where
    the camera sits in a medium (the batch sensor drops it); otherwise ``requested`` or
    :func:`default_method`. A tent or gaussian film takes ``moments`` in JIT variants (their
    film weighs exactly) and ``batch`` in scalar ones (:mod:`mitsuba_refs.reference.filtered`: the
    scalar film's weights are tabulated, :func:`mitsuba_refs.reference.rfilter.check_variant`).
    ``ValueError`` for a combination that has no exact route.
    """
    scalar = variant.startswith("scalar")
    if mitsuba_integrator == "ptracer":
        if not rfilter.is_box:
            raise ValueError(f"the light tracer's references need a box filter, the film "
                             f"has {rfilter.describe()}")
        return "replicas"
    if camera_in_medium:
        if requested == "batch":
            raise ValueError("the batch method cannot render a camera inside a medium "
                             "(Mitsuba's batch sensor drops the medium)")
        check_variant(variant, rfilter, "a camera inside a medium")
        return "moments"
    if not rfilter.is_box:
        if scalar and requested == "moments":
            check_variant(variant, rfilter, "the rgb_moments method")
        if scalar and rfilter.sample_border:
            # The batch route's positions are the image's pixels; Mitsuba's bordered film
            # also samples a border around them.
            check_variant(variant, rfilter, "a film with sample_border")
        if not scalar and requested == "batch":
            raise ValueError(f"the batch method with a {rfilter.describe()} film needs "
                             f"scalar_rgb (it recomputes scalar Mitsuba's sample positions); "
                             f"{variant} filters exactly with the moments method")
        return requested or ("batch" if scalar else "moments")
    return requested or default_method(variant)


def render_reference(scene_path_or_name, params, integrator, spp, seed,
                     variant=None, log=None, *, options=None, resolution=None, method=None):
    """Render a reference with Mitsuba.

    Parameters
    ----------
    scene_path_or_name : str or Path
        Scene XML file or built-in scene name.
    params : dict
        Values for names the scene declares (``<default>`` or ``$name``);
        anything else is an error, as for the tracer.
    integrator : str
        One of :data:`INTEGRATOR_MAP` (our names).
    spp, seed : int
        Total samples per pixel (the file's sample count is not used); base
        seed (see :func:`pass_seeds`).
    variant : str, optional
        Mitsuba variant; default chosen by :func:`mitsuba_refs.reference.variant.choose_variant`.
    log : callable, optional
        Called with progress strings.
    options : dict, optional
        Overrides of ``max_depth``, ``rr_depth``, ``hide_emitters`` (as the
        tracer's render options); the file's ``<integrator>`` gives the rest.
    resolution : (int, int), optional
        Film size replacing the file's.
    method : {"batch", "moments"}, optional
        ``batch``: single samples from a batch of camera copies (no Python per
        sample); ``moments``: the ``rgb_moments`` wrapper (one Python call per
        sample in ``scalar_rgb``, per wavefront in JIT variants; passes of
        :data:`~mitsuba_refs.reference.config.PASS_SPP` samples). Same
        statistics. Default and the combinations allowed: :func:`choose_method`.
        Inside :func:`mitsuba_refs.reference.split.calls_split_by` the ``batch`` method's
        render calls are rendered elsewhere (a cluster); other methods render here.

    Returns
    -------
    Reference
    """
    path = resolve_scene(scene_path_or_name)
    check_film_filter(path)
    scene_kw, transport, settings = reference_settings(path, params, options, resolution)
    chosen, reason = set_variant(variant)
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders

    scene = load_mitsuba_scene(path, scene_kw, resolution)
    film = scene.sensors()[0].film()
    # The film's filter (box, tent, gaussian) also shapes the statistics (.rfilter).
    try:
        rfilter = film_filter(film)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    check_framing(path, scene, settings)
    width, height = settings.resolution
    nested = integrator_dict(integrator, transport, settings.integrator)
    stream = stream_id(integrator, params, options, resolution)
    try:
        method = choose_method(chosen, rfilter, nested["type"], sensor_has_medium(path), method)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    t0 = time.time()
    progress = None
    if log:     # the cache said which reference renders; this says how far it is
        progress = Progress(spp, f"reference {path.stem} {integrator}", "spp",
                            estimate_after=ESTIMATE_AFTER,
                            faster=faster_route(chosen, method, nested["type"]))
    if method == "batch" and not rfilter.is_box:
        m1, m2, n, calls, per_call, seeds = render_filtered_moments(
            scene, mi.load_dict(integrator_with_blocks(nested)), spp, seed, stream, rfilter,
            progress=progress)
        var = per_sample_variance(m1, m2, n, rfilter)
    elif method == "batch":
        m1, var, n, calls, per_call, seeds = render_moments(
            scene, mi.load_dict(nested), spp, seed, stream, progress=progress,
            split=current_split())
    elif method == "replicas":
        m1, var, n, per_call, seeds = _render_replicas(scene, nested, spp, seed, stream, progress)
    elif method == "moments":
        m1, m2, n, per_call, seeds = _render_with_wrapper(
            scene, nested, spp, seed, stream, config.PASS_SPP, progress)
        var = per_sample_variance(m1, m2, n, rfilter)
    else:
        raise ValueError(f"unknown method {method!r} (batch or moments)")
    if progress is not None:
        progress.close()
    elapsed = time.time() - t0
    metadata = {
        "scene": path.stem,
        "scene_file": str(path),
        "params": {k: str(v) for k, v in sorted((params or {}).items())},
        "integrator": integrator,
        "mitsuba_integrator": nested,
        "light_transport": dict(transport),
        "variance_is_of_our_estimator": integrator not in MEAN_ONLY,
        "spp": int(n),
        "seed": int(seed),
        "pass_seeds": seeds,
        "pass_spp": per_call,
        "method": method,
        "width": width,
        "height": height,
        "rfilter": filter_metadata(rfilter),
        "variant": chosen,
        "variant_reason": reason,
        "mitsuba_version": mi.__version__,
        "render_seconds": round(elapsed, 3),
    }
    if method == "replicas":
        metadata["replicas"] = len(seeds)
    if options:
        metadata["options"] = {k: str(v) for k, v in sorted(options.items())}
    if resolution is not None:
        metadata["resolution"] = [width, height]
    return Reference(mean=m1, var=var, n=int(n), metadata=metadata)


#: Seconds above which a reference build says, once, how long it will take and what is faster.
ESTIMATE_AFTER = 30.0


def faster_route(variant, method, mitsuba_type) -> str:
    """What makes a long reference build faster, for its one-line estimate."""
    routes = []
    if variant.startswith("scalar"):
        slow = "a Python integrator" if method == "moments" or mitsuba_type in PYTHON_TYPES else "it"
        routes.append(f"{slow} in {variant} is slow: the llvm_ad_rgb variant (--variant llvm_ad_rgb "
                      "or MITSUBA_REFS_VARIANT=llvm_ad_rgb) where it works")
    routes.append("a smaller --resolution")
    routes.append("`mitsuba-refs build` on a faster machine, copying the cache files")
    return "; ".join(routes)


def _render_with_wrapper(scene, nested, spp, seed, stream, pass_spp, progress):
    """The ``rgb_moments`` method: passes of at most ``pass_spp`` samples, moments combined
    (first and second moment per pixel, as the film's filter weighted them)."""
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders

    film = scene.sensors()[0].film()
    width, height = (int(v) for v in film.crop_size())
    integ = mi.load_dict(moments.moment_dict(nested))
    pass_spp = int(pass_spp or config.PASS_SPP)
    n_passes = max(1, math.ceil(spp / pass_spp))
    seeds = pass_seeds(seed, n_passes, width, height, stream)
    passes, remaining = [], spp
    for k, s in enumerate(seeds):
        n_k = min(pass_spp, remaining)
        remaining -= n_k
        mi.render(scene, integrator=integ, spp=n_k, seed=s)
        m1, m2 = moments.read_moments(film)
        passes.append((m1, m2, n_k))
        if progress:
            progress.advance(n_k)
    m1, m2, n = combine_power_means(passes)
    return m1, m2, n, pass_spp, seeds


def _render_replicas(scene, nested, spp, seed, stream, progress):
    """The ``replicas`` method (particle tracer): ``K`` independent renders of ``spp / K``.

    ``K`` is the largest divisor of ``spp`` up to ``config.REF_REPLICAS``. Returns the
    mean image, the per-pixel variance across replicas times ``spp / K`` (the variance
    of one light path per pixel: ``var / spp`` is the variance of the mean), ``spp``,
    ``spp / K`` and the replicas' seeds (:func:`pass_seeds`).
    """
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders

    film = scene.sensors()[0].film()
    width, height = (int(v) for v in film.crop_size())
    replicas = replica_count(spp, config.REF_REPLICAS)
    per_replica = spp // replicas
    integ = mi.load_dict(nested)
    seeds = pass_seeds(seed, replicas, width, height, stream)
    images = []
    for k, s in enumerate(seeds):
        image = np.array(mi.render(scene, integrator=integ, spp=per_replica, seed=s),
                         dtype=np.float64)[..., :3]
        images.append(image)
        if progress:
            progress.advance(per_replica)
    images = np.stack(images)
    variance = images.var(axis=0, ddof=1) * per_replica if replicas > 1 else np.zeros_like(images[0])
    return images.mean(axis=0), variance, spp, per_replica, seeds

