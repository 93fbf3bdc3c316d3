"""The cost of a new plugin: one module, registered beside its class, and nothing else.

Each test writes a plugin module of its own (a BSDF, a shape, an emitter, an integrator),
imports it in a fresh interpreter (so this process's registries stay the tracer's), loads a
scene file that names the new plugin, and renders it: no loader, table or command line is
edited. Where the new plugin is an existing one in other words, the image must be the
existing plugin's bit for bit.
"""
from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

ROOM = """<scene version="3.0.0">
    <integrator type="{integrator}"><integer name="max_depth" value="3"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm"><integer name="width" value="12"/><integer name="height" value="10"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><scale value="2"/></transform>
        {bsdf}
    </shape>
    {extra}
    {light}
</scene>
"""
AREA = """<shape type="rectangle">
        <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="180"/>
            <translate z="2"/></transform>
        <emitter type="area"><rgb name="radiance" value="4, 4, 4"/></emitter>
    </shape>"""


def _render(tmp_path: Path, plugin: str, scenes: dict, integrator: str | None = None) -> dict:
    """Import ``plugin`` (module source) in a fresh interpreter, then render each scene;
    the SHA-1 of each image, and the names the registries list."""
    (tmp_path / "my_plugin.py").write_text(textwrap.dedent(plugin))
    files = {}
    for label, text in scenes.items():
        files[label] = tmp_path / f"{label}.xml"
        files[label].write_text(text)
    script = textwrap.dedent(f"""
        import hashlib, json, sys
        import numpy as np
        import my_plugin  # noqa: F401  (registers itself)
        from pathtracer import load_scene, render
        from pathtracer.integrators import registered_integrators
        from pathtracer.scene.registry import KINDS, names
        out = {{"names": {{kind: list(names(kind)) for kind in KINDS}},
               "integrators": list(registered_integrators())}}
        for label, file in {json.dumps({k: str(v) for k, v in files.items()})}.items():
            scene = load_scene(file)
            image = render(scene, {integrator!r}, spp=4, seed=3, processes=1).mean
            assert np.isfinite(image).all() and image.max() > 0, label
            out[label] = hashlib.sha1(image.tobytes()).hexdigest()
        print(json.dumps(out))
    """)
    env = {"PYTHONPATH": f"{tmp_path}:{ROOT}", "PATH": "/usr/bin:/bin", "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env,
                          cwd=tmp_path, timeout=300)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


def test_a_new_bsdf_is_one_module(tmp_path):
    plugin = """
        import numpy as np
        from pathtracer.bsdfs.diffuse import Diffuse
        from pathtracer.scene.registry import register

        @register("bsdf", "grey")
        def create(props):
            # A diffuse BSDF given by one albedo.
            albedo = props.float("albedo", 0.5)
            if not 0.0 <= albedo <= 1.0:
                raise props.plugin.error("albedo must lie in [0, 1]", props.line("albedo"))
            return Diffuse(np.full(3, albedo))
    """
    scenes = {"new": ROOM.format(integrator="path", extra="", light=AREA,
                                 bsdf='<bsdf type="grey"><float name="albedo" value="0.3"/></bsdf>'),
              "old": ROOM.format(integrator="path", extra="", light=AREA,
                                 bsdf='<bsdf type="diffuse"><rgb name="reflectance" value="0.3"/></bsdf>')}
    out = _render(tmp_path, plugin, scenes)
    assert "grey" in out["names"]["bsdf"]
    assert out["new"] == out["old"]


def test_a_new_shape_is_one_module(tmp_path):
    plugin = """
        import numpy as np
        from pathtracer.scene import transform
        from pathtracer.scene.registry import register
        from pathtracer.shapes.normals import flip_winding

        @register("shape", "square")
        def create(props):
            # The rectangle's square [-1, 1]^2, given by its half side instead of a scale.
            shape = props.shape
            half = props.float("half_side", 1.0)
            corners = half * np.array([[[-1, -1, 0], [1, -1, 0], [1, 1, 0]],
                                       [[-1, -1, 0], [1, 1, 0], [-1, 1, 0]]], dtype=float)
            p = transform.apply_points(shape.to_world, corners.reshape(-1, 3)).reshape(-1, 3, 3)
            n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
            n = np.repeat((n / np.linalg.norm(n, axis=1, keepdims=True))[:, None], 3, axis=1)
            uv = 0.5 * (corners[:, :, :2] / half + 1.0)
            if shape.flip:
                p, n, uv = flip_winding(p, n, uv)
            shape.geometry.add_mesh(props.shape_id, p, n, uv)
    """
    extra = """<shape type="square"><float name="half_side" value="0.25"/>
        <transform name="to_world"><translate x="1.2" z="0.5"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.2, 0.2"/></bsdf></shape>"""
    same = """<shape type="rectangle">
        <transform name="to_world"><scale value="0.25"/><translate x="1.2" z="0.5"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.2, 0.2"/></bsdf></shape>"""
    bsdf = '<bsdf type="diffuse"/>'
    scenes = {"new": ROOM.format(integrator="path", extra=extra, light=AREA, bsdf=bsdf),
              "old": ROOM.format(integrator="path", extra=same, light=AREA, bsdf=bsdf),
              "without": ROOM.format(integrator="path", extra="", light=AREA, bsdf=bsdf)}
    out = _render(tmp_path, plugin, scenes)
    assert "square" in out["names"]["shape"]
    assert out["new"] != out["without"]          # the square is there: it shades the floor
    assert out["new"] == out["old"]


def test_a_new_emitter_is_one_module(tmp_path):
    plugin = """
        import numpy as np
        from pathtracer.emitters.point import PointEmitter
        from pathtracer.scene.properties import children
        from pathtracer.scene.registry import register

        @register("emitter", "bulb")
        def create(props):
            # A point light given by its power [W] instead of its intensity [W/sr].
            children(props.plugin, {})
            power = props.color("power", 4.0 * np.pi)
            return PointEmitter(position=props.point("position", np.zeros(3)),
                                intensity=power / (4.0 * np.pi))
    """
    import numpy as np
    intensity = repr(float(20.0 / (4.0 * np.pi)))
    new = '<emitter type="bulb"><point name="position" x="0" y="0.5" z="1"/><rgb name="power" value="20"/></emitter>'
    old = (f'<emitter type="point"><point name="position" x="0" y="0.5" z="1"/>'
           f'<rgb name="intensity" value="{intensity}"/></emitter>')
    bsdf = '<bsdf type="diffuse"/>'
    out = _render(tmp_path, plugin, {"new": ROOM.format(integrator="path", extra="", light=new, bsdf=bsdf),
                                     "old": ROOM.format(integrator="path", extra="", light=old, bsdf=bsdf)})
    assert "bulb" in out["names"]["emitter"]
    assert out["new"] == out["old"]


def test_a_new_integrator_is_one_module(tmp_path):
    plugin = """
        from pathtracer.bsdfs.shading import sample_bsdf
        from pathtracer.integrators.base import CameraIntegrator
        from pathtracer.scene.registry import register

        @register("integrator", "bsdf_paths")
        class BSDFPaths(CameraIntegrator):
            # The lecture's BSDF-sampling path tracer, written again outside the package.
            name = "bsdf_paths"

            def radiance(self, scene, rays, rng):
                paths = self.camera_paths(scene, rays, rng)
                while paths:
                    paths.add_radiance(paths.beta * self.emission(scene, paths.hit, paths.wi, paths.depth))
                    paths.keep(paths.hit.valid & (paths.depth + 1 < self.depth_limit))
                    if not paths:
                        break
                    bs = sample_bsdf(scene, paths.hit, paths.wi, paths.rng.next_1d(), paths.rng.next_2d(),
                                     self.hemisphere)
                    paths.scatter(bs.wo, bs.weight, bs.eta)
                    self.russian_roulette(paths)
                    paths.next_hit(scene)
                return paths.L
    """
    bsdf = '<bsdf type="diffuse"/>'
    scenes = {"new": ROOM.format(integrator="bsdf_paths", extra="", light=AREA, bsdf=bsdf),
              "old": ROOM.format(integrator="path_bsdf", extra="", light=AREA, bsdf=bsdf)}
    out = _render(tmp_path, plugin, scenes, integrator=None)   # each file's own integrator
    assert "bsdf_paths" in out["integrators"] and "bsdf_paths" in out["names"]["integrator"]
    assert out["new"] == out["old"]
