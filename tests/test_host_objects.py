"""The C host API's quadric and reflection entry points and its @IF specialiser against the
Python host, bit for bit (host/tests/host_objects.c; the build of host/ is the session
fixture of tests/test_host_api.py).

* ``oclshade_specialize`` against :func:`oclshade.specialize.specialize`: reflect.cl for
  every condition vector the materials (and the background) can produce, random nested
  sources, and malformed ones (the same line in the message).
* ``oclshade_quadric_tables`` + cast, merge, object normals and shadows against
  :class:`oclshade.quadrics.QuadricCaster` (every kind, perspective and orthographic, suns
  above, at and below the horizon); the C program also checks pitched fields at offsets.
* a point light's terrain and quadric shadows against ``terrain_point_shadow`` and
  ``QuadricCaster.point_shadow`` (lights over, inside, under and off the map; no terrain).
* ``oclshade_reflect_tables`` + weights, apply, finish against
  :class:`oclshade.envmap.reflect.Reflections` (every material kind, two stacked maps, ssaa);
  the reflection calls also under valgrind's memcheck.
"""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest

from oclshade.camera import Camera
from oclshade.envmap.cube import CubeMap, stack_cubes
from oclshade.envmap.materials import Material
from oclshade.envmap.reflect import Reflections
from oclshade.gbuffer import CHANNELS
from oclshade.heightmap import Heightmap
from oclshade.quadrics import Quadric
from oclshade.quadrics.caster import ObjectIds, QuadricCaster
from oclshade.runtime import get_runtime, kernel_source
from oclshade.specialize import SpecializeError, specialize
from oclshade.terrain import DeviceGBuffer

from test_host_api import host, run_program  # noqa: F401  (the session build of host/)

NAMES = ("REFLECT", "FRESNEL", "ROUGH", "BACKGROUND")
#: every vector the materials and the background produce (Material.conditions), and all subsets
VECTORS = [" ".join(sorted(c)) for r in range(len(NAMES) + 1) for c in itertools.combinations(NAMES, r)]
GB_NAMES = ("position", "normal", "uv", "uv_grad", "depth", "albedo", "object")


def _random_source(rng: np.random.Generator, depth: int = 0) -> list[str]:
    """Lines of a random well-formed @IF source over NAMES (blank-indented, nested, negations)."""
    lines: list[str] = []
    for _ in range(rng.integers(1, 5)):
        if depth < 4 and rng.random() < 0.4:
            conds = [("!" if rng.random() < 0.3 else "") + str(rng.choice(NAMES)) for _ in range(rng.integers(1, 3))]
            pad = " " * int(rng.integers(0, 3))
            lines.append(f"{pad}@IF {' '.join(conds)};\n")
            lines += _random_source(rng, depth + 1)
            if rng.random() < 0.5:
                lines.append(f"{pad}@ELSE ;\n")
                lines += _random_source(rng, depth + 1)
            lines.append(f"{pad}@ENDIF;\n")
        else:
            lines.append(f"    line {rng.integers(1000)} @ in text;\n")
    return lines


MALFORMED = ["a\n@IF REFLECT\nb\n@ENDIF;\n", "@IF REFLECT;\n@ELSE;\n@ELSE;\n@ENDIF;\n", "x\n@ENDIF;\n",
             "@IF REFLECT;\nx\n", "@IF;\n@ENDIF;\n", "@IF 1A;\n@ENDIF;\n", "@WHILE X;\n", "@IF A; junk\n@ENDIF;\n",
             "@ELSE X;\n", "@;\n"]


def test_c_specialize_equals_python(host: dict, tmp_path: Path) -> None:
    """reflect.cl (as the library holds it) for all 16 condition vectors, 40 random nested
    sources and the malformed ones: the C text equals specialize()'s byte for byte, and a
    malformed source fails on the same line."""
    rng = np.random.default_rng(21)
    sources = ["-"]
    texts = [kernel_source("reflect.cl")]
    for i in range(40):
        text = "".join(_random_source(rng)) + ("tail without newline" if i % 3 == 0 else "")
        texts.append(text)
    texts += MALFORMED
    for i, text in enumerate(texts[1:], 1):
        path = tmp_path / f"src_{i}.txt"
        path.write_bytes(text.encode())
        sources.append(path)
    out = tmp_path / "out"
    out.mkdir()
    run_program(host, "host_objects", "specialize", out, len(VECTORS), *[v or " " for v in VECTORS], *sources)
    for s, text in enumerate(texts):
        for v, vector in enumerate(VECTORS):
            try:
                want = specialize(text, vector)
            except SpecializeError as exc:
                err = out / f"spec_{s}_{v}.err"
                assert err.is_file(), (s, vector, str(exc))
                assert err.read_text().startswith(f"line {exc.line}:"), (err.read_text(), str(exc))
                continue
            assert (out / f"spec_{s}_{v}.cl").read_bytes() == want.encode(), (s, vector)
    assert all(specialize(texts[0], v) for v in VECTORS)   # reflect.cl itself is well-formed


def _write_gbuffer(folder: Path, prefix: str, arrays: dict[str, np.ndarray]) -> None:
    for name in GB_NAMES:
        arrays[name].tofile(folder / f"{prefix}_{name}.bin")


def _camera_line(cam: Camera) -> str:
    ortho = cam.projection == "orthographic"
    return " ".join(map(repr, [cam.width, cam.height, int(ortho), float(cam.fov), float(cam.ortho_height),
                               float(cam.near), float(cam.far), *map(float, cam.position), *map(float, cam.look_at)]))


QUADRICS = [
    Quadric.sphere((140.0, -100.0, 30.0), 18.0, Material("mirror")),
    Quadric.ellipsoid((90.0, -60.0, 25.0), (20.0, 9.0, 6.0), axis=(0.3, 0.2, 1.0), material=Material("glossy")),
    Quadric.cylinder((60.0, -140.0, 20.0), radius=7.0, height=30.0, axis=(1.0, 0.0, 0.2)),
    Quadric.paraboloid((170.0, -40.0, 10.0), radius=15.0, height=12.0, axis=(0.0, 0.5, 1.0),
                       material=Material("diffuse", (0.2, 0.5, 0.7))),
]
KIND = {"sphere": 0, "ellipsoid": 1, "cylinder": 2, "paraboloid": 3}


def _quadric_case(folder: Path, projection: str, sun: tuple[float, float]):
    """Writes the inputs of host_objects quadrics to folder; returns the Python side's."""
    rng = np.random.default_rng(4)
    rows, cols, dx, dy = 33, 41, 6.0, 5.0
    h = np.cumsum(rng.normal(size=(rows, cols)), axis=1) * 1.5 + 5.0
    h[rng.random(h.shape) < 0.03] = np.nan
    hm = Heightmap.from_array(h, (dx, dy))
    w, hh = 48, 36
    cam = Camera(np.array([-60.0, -260.0, 420.0]), np.array([115.0, -90.0, 20.0]), w, hh, fov=40.0, near=1.0,
                 far=5000.0, projection=projection, ortho_height=200.0)
    n = w * hh
    dst = {"position": np.concatenate([rng.normal(size=(n, 3)) * 50 + [0, 0, -300], np.ones((n, 1))], 1),
           "normal": rng.normal(size=(n, 4)), "uv": rng.random((n, 2)) * 30, "uv_grad": rng.normal(size=(n, 4)),
           "depth": rng.random(n) * 600.0, "albedo": rng.random((n, 4))}
    dst = {k: np.ascontiguousarray(v, np.float32) for k, v in dst.items()}
    dst["position"][rng.random(n) < 0.1, 3] = 0.0
    dst["object"] = np.zeros(n, np.int32)
    shading = rng.normal(size=(n, 4)).astype(np.float32)
    coef = rng.random(n).astype(np.float32)
    k_dark, k_bright = 0.15, 0.6
    lines = [_camera_line(cam), f"{rows} {cols} {dx!r} {dy!r}", f"{sun[0]!r} {sun[1]!r} {k_dark!r} {k_bright!r}",
             str(len(QUADRICS))]
    for q in QUADRICS:
        lines.append(" ".join(map(repr, [KIND[q.kind], *map(float, q.centre), *map(float, q.radii),
                                         *map(float, q.axis), *map(float, q.material.colour)])))
    (folder / "scene.txt").write_text("\n".join(lines) + "\n")
    hm.heights.astype(np.float64).tofile(folder / "heights.f64")
    _write_gbuffer(folder, "dst", dst)
    shading.tofile(folder / "shading.f32")
    coef.tofile(folder / "coef.f32")
    return hm, cam, dst, shading, coef, (k_dark, k_bright)


@pytest.mark.parametrize("projection,sun", [("perspective", (135.0, 25.0)), ("orthographic", (300.0, 8.0)),
                                            ("perspective", (40.0, -3.0)), ("perspective", (10.0, 90.0))])
def test_c_quadrics_equal_python(host: dict, tmp_path: Path, projection: str, sun: tuple[float, float]) -> None:
    """Tables, cast, merge into a G-buffer, object normals and shadows from the C entry points
    equal QuadricCaster's device buffers bit for bit."""
    hm, cam, dst, shading, coef, (k_dark, k_bright) = _quadric_case(tmp_path, projection, sun)
    w, hh = cam.width, cam.height
    n = w * hh
    out = tmp_path / "out"
    out.mkdir()
    run_program(host, "host_objects", "quadrics", out, tmp_path)

    # the Python host on the same inputs
    caster = QuadricCaster(QUADRICS, hm)
    rt = caster.runtime
    qf, qi = caster.tables(cam)
    assert np.fromfile(out / "qf.f32", np.float32).tobytes() == qf.tobytes()
    assert np.fromfile(out / "qi.i32", np.int32).tolist() == qi.reshape(-1).tolist()
    objects = caster.cast(cam)
    host_objects = {k: _read(rt, objects[0].buffers[k], 4 * CHANNELS[k] * n) for k in CHANNELS}
    host_objects["object"] = objects[1].to_host(rt).tobytes()
    for name in GB_NAMES:
        assert (out / f"obj_{name}.bin").read_bytes() == host_objects[name], name
    assert (host_objects["object"] != bytes(4 * n)), "the scene must show quadrics"
    into = DeviceGBuffer(rt, (hh, w), {k: rt.to_device(dst[k], k) for k in CHANNELS})
    ids = caster.merge(objects, into, ObjectIds(rt.to_device(dst["object"], "ids"), (hh, w)))
    shading_d = rt.to_device(shading, "shading")
    caster.object_normals(into, ids, shading_d)
    coef_d = rt.to_device(coef, "coef")
    caster.shadow(cam, into, ids, sun, coef_d, k_dark, k_bright)
    for name in GB_NAMES:
        want = ids.to_host(rt).tobytes() if name == "object" else _read(rt, into.buffers[name], 4 * CHANNELS[name] * n)
        assert (out / f"mrg_{name}.bin").read_bytes() == want, name
    assert (out / "shading.out").read_bytes() == _read(rt, shading_d, 16 * n)
    got = (out / "coef.out").read_bytes()
    assert got == _read(rt, coef_d, 4 * n)
    assert got != coef.tobytes(), "the shadow pass must change some coefficients"


def _light(hm: Heightmap, where: str) -> np.ndarray:
    """A point light's world position relative to the map's bounding box (x 0..240 m, y
    -160..0 m) and heights."""
    lo, hi = float(np.nanmin(hm.heights)), float(np.nanmax(hm.heights))
    return {"above": np.array([120.0, -80.0, hi + 150.0]), "inside": np.array([100.0, -60.0, 0.5 * (lo + hi)]),
            "below": np.array([150.0, -100.0, lo - 20.0]), "off": np.array([-80.0, 60.0, hi + 10.0])}[where]


@pytest.mark.parametrize("projection,where,terrain", [("perspective", "above", True), ("orthographic", "above", True),
                                                      ("perspective", "inside", True), ("perspective", "below", True),
                                                      ("perspective", "off", True), ("perspective", "above", False)])
def test_c_point_shadows_equal_python(host: dict, tmp_path: Path, projection: str, where: str, terrain: bool) -> None:
    """A point light's terrain and quadric shadows (oclshade_enqueue_terrain_point_shadow,
    oclshade_enqueue_quadric_point_shadow) on the terrain's G-buffer with the quadrics merged
    equal terrain_point_shadow's and QuadricCaster.point_shadow's bit for bit: lights over,
    inside and under the map's bounding box, off the map, and without a terrain."""
    from oclshade.lights import PointLight
    from oclshade.quadrics.caster import terrain_point_shadow
    from oclshade.terrain import Heightfield, TerrainRenderer

    hm, cam, _, _, coef, (k_dark, _) = _quadric_case(tmp_path, projection, (135.0, 25.0))
    w, hh = cam.width, cam.height
    n = w * hh
    gbuf = TerrainRenderer(Heightfield(hm)).render(cam)   # terrain pixels: surface starts
    dst = {k: np.ascontiguousarray(getattr(gbuf, k), np.float32) for k in CHANNELS}
    dst["object"] = np.zeros(n, np.int32)
    _write_gbuffer(tmp_path, "dst", dst)
    light = PointLight(_light(hm, where))
    with open(tmp_path / "scene.txt", "a") as f:
        f.write(" ".join(map(repr, map(float, light.position))) + f" {int(terrain)}\n")
    out = tmp_path / "out"
    out.mkdir()
    run_program(host, "host_objects", "point", out, tmp_path)

    caster = QuadricCaster(QUADRICS, hm if terrain else None)
    rt = caster.runtime
    objects = caster.cast(cam)
    into = DeviceGBuffer(rt, (hh, w), {k: rt.to_device(dst[k], k) for k in CHANNELS})
    ids = caster.merge(objects, into, ObjectIds(rt.to_device(dst["object"], "ids"), (hh, w)))
    coef_d = rt.to_device(coef, "coef")
    terrain_point_shadow(rt, cam, hm if terrain else None, caster.heights, into, ids, light, coef_d, k_dark)
    want = _read(rt, coef_d, 4 * n)
    got = (out / "tps.out").read_bytes()
    assert got == want
    tps = np.frombuffer(got, np.float32)
    assert set(np.unique(tps).tolist()) <= {np.float32(k_dark), 1.0}
    assert np.any(tps == np.float32(k_dark)) == terrain, "the terrain shadows some pixels (none without one)"
    caster.point_shadow(cam, into, ids, light, coef_d, k_dark)
    got = (out / "pps.out").read_bytes()
    assert got == _read(rt, coef_d, 4 * n)
    if where == "above":
        assert np.count_nonzero(np.frombuffer(got, np.float32) != tps), "the quadrics shadow some pixels"


def _read(rt, buf: cl.Buffer, nbytes: int) -> bytes:
    out = np.empty(nbytes, np.uint8)
    cl.enqueue_copy(rt.queue, out, buf)
    rt.queue.finish()
    return out.tobytes()


MATERIALS = [Material("mirror"), Material("glossy", (0.7, 0.2, 0.1), fresnel=0.3), Material("diffuse"),
             Material("mirror", (0.9, 0.8, 0.5), roughness=0.4), Material("glossy", roughness=0.2, fresnel=0.05),
             Material("glossy", (0.1, 0.9, 0.3), fresnel=0.5)]
MKIND = {"diffuse": 0, "mirror": 1, "glossy": 2}


def _reflect_case(folder: Path, ssaa: int, projection: str, background: int, rotation: float):
    """Writes the inputs of host_objects reflect to folder; returns the Python side's."""
    rng = np.random.default_rng(ssaa)
    w, hh, face = 20, 14, 6
    sw, sh = w * ssaa, hh * ssaa
    ns = sw * sh
    cam = Camera(np.array([0.0, -50.0, 20.0]), np.array([0.0, 0.0, 0.0]), sw, sh, fov=40.0, near=0.5, far=500.0,
                 projection=projection, ortho_height=30.0)
    position = np.concatenate([rng.normal(size=(ns, 2)) * 5, -rng.random((ns, 1)) * 40 - 5, np.ones((ns, 1))], 1)
    position = position.astype(np.float32)
    empty = rng.random(ns) < 0.2
    position[empty] = 0.0
    normal = rng.normal(size=(ns, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.concatenate([normal, np.zeros((ns, 1))], 1).astype(np.float32)
    albedo = rng.random((ns, 4)).astype(np.float32)
    obj = np.where(empty, 0, rng.integers(0, len(MATERIALS) + 1, ns)).astype(np.int32)
    maps = [CubeMap((rng.random((6, face, face, 3)) * 2).astype(np.float32)).to_device() for _ in range(2)]
    cube = stack_cubes(maps)
    cube_of = [k % 2 for k in range(len(MATERIALS))]
    frame = rng.integers(0, 256, (hh, w, 4), dtype=np.uint8)
    intensity = 1.3
    lines = [f"{w} {hh} {ssaa}", _camera_line(cam), f"{face} 2 {rotation!r} {intensity!r} {background}",
             str(len(MATERIALS))]
    for m, c in zip(MATERIALS, cube_of):
        lines.append(" ".join(map(repr, [MKIND[m.kind], *m.colour, m.roughness, m.fresnel, c])))
    (folder / "reflect.txt").write_text("\n".join(lines) + "\n")
    for name, a in (("position.f32", position), ("normal.f32", normal), ("albedo.f32", albedo),
                    ("object.i32", obj), ("cube.f32", cube.bordered()), ("frame.u8", frame)):
        a.tofile(folder / name)
    return cam, (position, normal, albedo, obj), cube, cube_of, frame, intensity


@pytest.mark.parametrize("ssaa,projection,background,rotation", [(1, "perspective", 1, 0.0),
                                                                 (2, "orthographic", 0, 37.5)])
def test_c_reflect_equals_python(host: dict, tmp_path: Path, ssaa: int, projection: str, background: int,
                                 rotation: float) -> None:
    """The material table, the weighted albedo, the reflections and the final frame of the C
    entry points equal Reflections' bit for bit (every material group, two stacked maps)."""
    cam, (position, normal, albedo, obj), cube, cube_of, frame, intensity = _reflect_case(
        tmp_path, ssaa, projection, background, rotation)
    hh, w = frame.shape[:2]
    sh, sw = hh * ssaa, w * ssaa
    ns = sw * sh
    out = tmp_path / "out"
    out.mkdir()
    stdout = run_program(host, "host_objects", "reflect", out, tmp_path)

    refl = Reflections(cube, MATERIALS, rotation=rotation, intensity=intensity, background=bool(background),
                       cube_of=cube_of)
    assert [line.split(" ", 1)[1] for line in stdout.splitlines() if line.startswith("group ")] == \
        [" ".join(sorted(g)) for g in refl.groups]
    rt = refl.runtime
    assert np.fromfile(out / "table.f32", np.float32).tobytes() == _read(rt, refl._table, 48 * len(MATERIALS))
    gbuf = DeviceGBuffer(rt, (sh, sw), {"position": rt.to_device(position, "p"), "normal": rt.to_device(normal, "n"),
                                        "albedo": rt.to_device(albedo, "a")})
    ids = ObjectIds(rt.to_device(obj, "ids"), (sh, sw))
    weighted = refl.weights(gbuf, ids, cam)
    assert (out / "weighted.out").read_bytes() == _read(rt, weighted.buffers["albedo"], 16 * ns)
    acc = refl.accumulate(gbuf, ids, cam, ssaa)
    got_acc = (out / "acc.out").read_bytes()
    assert got_acc == _read(rt, acc, 16 * w * hh)
    assert np.frombuffer(got_acc, np.float32).any()
    image = refl.apply(frame, gbuf, ids, cam, ssaa)
    assert (out / "image.out").read_bytes() == image.tobytes()
    assert image.tobytes() != frame.tobytes()


def test_c_objects_under_valgrind_lose_nothing(host: dict, tmp_path: Path) -> None:
    """host_objects reflect (the reflection entry points and the specialised builds, pitched
    fields included) under memcheck: exit 0 and 0 bytes definitely lost.  A run under
    valgrind's null tool first lets PoCL write the kernel binaries a run under valgrind asks
    for, so memcheck does not watch LLVM compile them (LLVM's leaks are not ours).  A plain
    run is not enough: valgrind's CPU hides some of the host's features (AVX-512 on the
    Xeons), PoCL then builds for another target and misses its cache (CI on 2026-11-28:
    16 bytes lost inside pocl_llvm_generate_workgroup_function).  Only ``reflect``: valgrind 3.19
    cannot decode an AVX instruction (vmovq xmm, xmm: C5 79 D6) that PoCL's LLVM emits in
    quadric_cast's binary (SIGILL), so the quadric passes are not run under it."""
    import re
    import shutil
    import subprocess
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind not found (apt-get install valgrind)")
    cases = {"reflect": tmp_path / "r"}
    for folder in cases.values():
        (folder / "out").mkdir(parents=True)
    _reflect_case(cases["reflect"], 2, "perspective", 1, 10.0)
    for command, folder in cases.items():
        args = [str(host["build"] / "host_objects"), command, str(folder / "out"), str(folder)]
        proc = subprocess.run(["valgrind", "--tool=none", *args], capture_output=True, text=True, env=host["env"],
                              timeout=600)
        assert proc.returncode == 0, proc.stderr[-4000:]          # PoCL's binaries for valgrind's CPU, cached
        proc = subprocess.run(["valgrind", "--leak-check=full", *args], capture_output=True, text=True,
                              env=host["env"], timeout=600)
        assert proc.returncode == 0, proc.stderr[-4000:]
        lost = re.search(r"definitely lost: ([\d,]+) bytes", proc.stderr)
        assert (lost is not None and lost.group(1) == "0") or "no leaks are possible" in proc.stderr, \
            proc.stderr[-4000:]


def test_c_objects_argument_and_contract_checks(host: dict, tmp_path: Path) -> None:
    """Every new entry point and host helper refuses bad arguments and buffers with a message
    naming the argument and the expected value (host_objects errors: one line per check)."""
    stdout = run_program(host, "host_objects", "errors", tmp_path)
    lines = stdout.splitlines()
    assert not [line for line in lines if line.startswith("FAIL")], stdout
    assert sum(line.startswith("ok ") for line in lines) >= 35, stdout


def _python_expansion(files: dict[str, str], name: str) -> str:
    """oclshade.runtime.kernel_source's expansion over given texts (its regex, each file once)."""
    from oclshade.runtime import _INCLUDE
    seen: set[str] = set()

    def expand(n: str) -> str:
        if n in seen:
            return ""
        seen.add(n)
        return _INCLUDE.sub(lambda m: expand(m.group(1)), files[n])

    return expand(name)


def test_c_include_expansion_equals_python(host: dict, tmp_path: Path) -> None:
    """The library's #include expansion equals the Python host's on 12 random layouts: blank
    and blank-ish lines before and after directives, indented and spaced directives, nested
    and repeated includes, a directive on the last line with and without a newline."""
    from oclshade.runtime import _kernel_root
    root = Path(str(_kernel_root()))
    others = [p for p in sorted(root.iterdir()) if p.suffix in (".cl", ".h") and p.name != "reflect.cl"]
    rng = np.random.default_rng(7)
    pieces = ["code();\n", "\n", "  \n", "\t\n", "// c\n", '#include "inc_a.h"\n', '  #  include  "inc_b.h"  \n',
              '#include "inc_a.h"\n\n\n', '#include "common.h"\n', "#define X 1\n"]
    for case in range(12):
        folder = tmp_path / str(case)
        (folder / "out").mkdir(parents=True)
        texts = {}
        for name in ("reflect.cl", "inc_a.h", "inc_b.h"):
            parts = [str(rng.choice(pieces)) for _ in range(int(rng.integers(1, 9)))]
            if name == "inc_a.h":
                parts = [p for p in parts if "inc_a" not in p]
            if name == "inc_b.h":
                parts = [p for p in parts if "inc_" not in p]
            text = "".join(parts) + str(rng.choice(["", "end", '#include "inc_b.h"', "\n"]))
            texts[name] = text
            (folder / name).write_bytes(text.encode())
        files = {p.name: p.read_text(encoding="utf-8") for p in others} | texts
        run_program(host, "host_objects", "expand", folder / "out", folder / "reflect.cl", *others,
                    folder / "inc_a.h", folder / "inc_b.h")
        assert (folder / "out" / "expanded.cl").read_bytes() == _python_expansion(files, "reflect.cl").encode(), case
