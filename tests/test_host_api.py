"""The C host API (host/) against the Python host and the float64 reference.

host/ is built with CMake into a temporary folder (once per session, as a shared
library: the fixture ``host`` is shared with tests/test_host_frames.py and
tests/test_host_packaging.py); its C test programs run on PoCL through the system
ICD loader (libOpenCL), pointed by OCL_ICD_VENDORS at the PoCL driver that pyopencl
ships.  Outputs must be bit-identical to the Python host's on the same driver.
Skips (with the reason) without host/ (installed package only), cmake, a C compiler,
the OpenCL headers and loader, or pyopencl's PoCL.
"""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest

from oclshade import ShadowCaster, Sun
from oclshade import reference as ref
from oclshade.heightmap import Heightmap
from oclshade.pyramid import level_offsets
from oclshade.runtime import _kernel_root, define_options, get_runtime, kernel_source
from oclshade.shadows import METHODS, TUNING, ShadowFeatures
from oclshade.tuning import family
from oclshade.tuning.rules import rule_values
from tile_cases import FLIP_OFFSET, FLIP_SUN, flipped_map

HOST = Path(__file__).resolve().parents[1] / "host"
OUTPUT_BITS = {1: ("mask",), 2: ("self",), 4: ("coefficient",)}
K_DARK, K_BRIGHT = 0.2, 0.7   # as host/tests/host_shadows.c passes them


def _pocl_driver() -> Path | None:
    """PoCL's ICD driver as pyopencl's wheels ship it (pyopencl/.libs or pyopencl.libs)."""
    pkg = Path(cl.__file__).resolve().parent
    for folder in (pkg / ".libs", pkg.parent / "pyopencl.libs"):
        found = sorted(folder.glob("libpocl*.so*"))
        if found:
            return found[0]
    return None


def _run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, capture_output=True, text=True, timeout=240, **kw)


PROGRAMS = ("pyramid.cl", "shadow.cl", "terrain.cl", "ssao.cl", "compose.cl", "sunshine.cl", "horizon.cl", "envmap.cl",
            "quadric.cl", "reflect.cl", "mesh.cl", "shadow_volume.cl")


def build_env(tmp_path_factory) -> dict:
    """The environment the C programs run in: the system ICD loader pointed at pyopencl's PoCL
    (POCL_CACHE_DIR as the Python host set it, so both share compiled kernels)."""
    driver = _pocl_driver()
    if driver is None:
        pytest.skip("pyopencl's PoCL driver (libpocl*.so) not found: no device for the C programs")
    icd = tmp_path_factory.mktemp("icd")
    (icd / "pocl.icd").write_text(f"{driver}\n")
    env = dict(os.environ, OCL_ICD_VENDORS=str(icd))
    env.pop("OCL_ICD_FILENAMES", None)
    return env


def configure(source: Path, build: Path, *options: str) -> None:
    """cmake configure; skips when CMake finds no OpenCL or no compiler, fails otherwise."""
    conf = _run(["cmake", "-S", str(source), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release", *options])
    if conf.returncode != 0:
        text = conf.stdout + conf.stderr
        missing = [line.strip() for line in text.splitlines() if "Could NOT find OpenCL" in line]
        if missing:
            pytest.skip(f"OpenCL headers or loader not found ({missing[0]}): install opencl-c-headers "
                        "and ocl-icd-opencl-dev")
        if "CMAKE_C_COMPILER" in text:
            pytest.skip("CMake found no working C compiler")
        pytest.fail(f"cmake configure of {source} failed:\n" + text[-4000:])


def cmake_build(build: Path, *targets: str) -> None:
    made = _run(["cmake", "--build", str(build), "--parallel", "2", *(a for t in targets for a in ("--target", t))])
    assert made.returncode == 0, f"build in {build} failed:\n" + (made.stdout + made.stderr)[-4000:]


#: the session's build of host/: the modules that import the fixture get their own fixture
#: definition from pytest, and must not build again
_BUILT: dict = {}


@pytest.fixture(scope="session")
def host(tmp_path_factory) -> dict:
    """Build host/ once (shared library); returns the build folder and the environment to run its programs in."""
    if "host" not in _BUILT:
        _BUILT["host"] = _build_host(tmp_path_factory)
    return _BUILT["host"]


def _build_host(tmp_path_factory) -> dict:
    if not (HOST / "CMakeLists.txt").is_file():
        pytest.skip("host/ is not in this tree (installed package only)")
    if shutil.which("cmake") is None:
        pytest.skip("cmake not found: the C host API cannot be built")
    if not any(shutil.which(c) for c in (os.environ.get("CC") or "cc", "gcc", "clang")):
        pytest.skip("no C compiler (cc, gcc, clang) found")
    env = build_env(tmp_path_factory)
    build = tmp_path_factory.mktemp("host-build")
    # the built-in kernel copy is taken from where the Python host reads its kernels
    configure(HOST, build, f"-DOCLSHADE_KERNEL_DIR={_kernel_root()}", "-DBUILD_SHARED_LIBS=ON")
    cmake_build(build)
    return {"build": build, "env": env}


def run_program(host: dict, name: str, *args: object) -> str:
    proc = _run([str(host["build"] / name), *map(str, args)], env=host["env"])
    assert proc.returncode == 0, f"{name} failed ({proc.returncode}):\n{proc.stdout[-4000:]}\n{proc.stderr[-4000:]}"
    return proc.stdout


# ------------------------------------------------------------------------------- inputs
def jacksboro() -> Heightmap:
    from matplotlib import cbook
    from oclshade.io import metres_per_degree

    data = cbook.get_sample_data("jacksboro_fault_dem.npz")
    elev = (data if hasattr(data, "files") else np.load(data))["elevation"].astype(np.float64)
    ew, ns = metres_per_degree(36.2)
    return Heightmap.from_array(elev, (ew / 1200.0, ns / 1200.0))


def random_map() -> Heightmap:
    rng = np.random.default_rng(11)
    h = np.cumsum(rng.normal(size=(37, 53)), axis=1) * 4.0 + rng.random((37, 53)) * 3.0 + 1e4
    h[rng.random(h.shape) < 0.04] = np.nan
    h[10, 20] += 60.0
    return Heightmap.from_array(h, (2.0, 0.5))


def flip_window() -> Heightmap:
    """The window of the flipped map that holds the flipped cell (tiles of 11, offset 3000)."""
    return Heightmap.from_array(flipped_map()[0:34, 0:45], 1.0)


# Suns at every special case of sincos_degrees and of the kernel's modes.
TRICKY_SUNS = [(315.0, 5.0), (37.0, 20.0), (135.0, 45.0), (0.0, 10.0), (90.0, 3.0), (180.0, 30.0),
               (270.0, 60.0), (45.0, 45.0), (-45.0, 12.0), (-1e-20, 25.0), (360.0, 8.0), (720.5, 15.0),
               (1e-6, 89.99), (200.0, 0.01), (10.0, 90.0), (10.0, 0.0), (300.0, -5.0)]
CASES = {
    # name: (heightmap, suns, suns checked against the float64 reference, kernels: "-" = built-in,
    #        the map's (row, col) origin in a larger map: oclshade_shadow_params origin_row / _col)
    "random": (random_map, TRICKY_SUNS, TRICKY_SUNS, "package", (0, 0)),
    "random_window": (random_map, TRICKY_SUNS[:6], TRICKY_SUNS[:6], "package", (3000, 70001)),
    # a window on which the origin changes a cell (tests/tile_cases.py): the C host must pass it
    "flip_window": (flip_window, [(FLIP_SUN.azimuth, FLIP_SUN.elevation), (37.0, 20.0)],
                    [(FLIP_SUN.azimuth, FLIP_SUN.elevation)], "package", FLIP_OFFSET),
    "jacksboro": (jacksboro, [(315.0, 5.0), (37.0, 20.0), (135.0, 45.0), (90.0, 10.0)],
                  [(37.0, 20.0), (135.0, 45.0)], "-", (0, 0)),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_c_host_matches_python_host(host: dict, tmp_path: Path, case: str) -> None:
    make, suns, ref_suns, kernels, origin = CASES[case]
    hm = make()
    rows, cols = hm.shape
    src = tmp_path / "heights.f64"
    np.ascontiguousarray(hm.heights, np.float64).tofile(src)
    out = tmp_path / "out"
    out.mkdir()
    kdir = str(_kernel_root()) if kernels == "package" else "-"
    stdout = run_program(host, "host_shadows", kdir, src, rows, cols, repr(hm.dx), repr(hm.dy), out,
                         *([f"--origin={origin[0]},{origin[1]}"] if origin != (0, 0) else []),
                         *[f"{az!r},{alt!r}" for az, alt in suns])
    assert stdout.strip().endswith("ok")

    def load(name: str, dtype) -> np.ndarray:
        return np.fromfile(out / name, dtype)

    # the very program sources (so the two hosts even share PoCL's binary cache)
    for name in PROGRAMS:
        assert (out / name).read_text(encoding="utf-8") == kernel_source(name), name
    # the heights the kernels read, and the pyramid, bit for bit
    assert load("offset.f64", np.float64)[0] == hm.offset
    assert load("relative.f32", np.float32).tobytes() == hm.relative32.tobytes()
    caster = ShadowCaster(hm, origin=origin)
    pyr = caster.pyramid
    expected_pyramid = np.concatenate([level.reshape(-1, 2) for level in pyr.to_numpy()])
    assert load("pyramid.f32", np.float32).tobytes() == expected_pyramid.tobytes()
    assert load("offsets.i32", np.int32).tolist() == [-1] + level_offsets(pyr.shapes).tolist()

    for k, (az, alt) in enumerate(suns):
        sun = Sun(az, alt)
        # the sun as the Python host hands it to the kernel (ShadowCaster._args: ray, vector, mode)
        args = caster._args(sun, K_DARK, K_BRIGHT)
        raw = (out / f"sun{k}.bin").read_bytes()
        assert args[3].tolist() == [origin[1], origin[0]], "the window origin (column, row)"
        assert raw[:16] == args[7].tobytes(), f"ray of sun {sun}"
        assert raw[16:32] == args[8].tobytes(), f"vector of sun {sun}"
        assert np.frombuffer(raw[32:], np.int32)[0] == args[11], f"mode of sun {sun}"
        for method in METHODS:
            py = caster.cast(sun, method, "all", K_DARK, K_BRIGHT)
            for ext, arr in (("mask", py.mask), ("self", py.self_shadow), ("coef", py.coefficient)):
                got = load(f"{method}_{k}.{ext}", arr.dtype)
                assert got.tobytes() == arr.tobytes(), f"{case} {method} {ext} differs at sun {sun}"
        if (az, alt) in ref_suns:
            expected = ref.cast_shadows(hm, sun)
            ties = expected.ties(ref.tie_tolerance(hm, sun))
            got = load(f"exact_{k}.mask", np.uint8).reshape(rows, cols)
            assert np.array_equal((got != expected.mask) & ~ties, np.zeros_like(ties)), f"{case} vs reference at {sun}"
            assert np.array_equal(load(f"exact_{k}.self", np.uint8).reshape(rows, cols), expected.self_shadow)
    if case == "flip_window":     # the origin matters here: without it the mask differs
        local = ShadowCaster(hm, cache=False).cast(FLIP_SUN).mask
        assert (local != caster.cast(FLIP_SUN).mask).sum() == 1


@pytest.mark.parametrize("cuts_c", [[0, 13, 32, 53], [0, 16, 32, 53]])
def test_c_host_traces_a_sun_field_block_by_block(host: dict, tmp_path: Path, cuts_c: list[int]) -> None:
    """oclshade_shadow_params' block window, one enqueue per block with its sun: the Python host's
    ShadowCaster.cast_many([SunField]) bit for bit (every output), under every alternative tuning
    too (packet runs cut to the blocks), and a block outside the map refused; and the same field
    in one launch of the sun-table kernels (field_row_blocks ...): the same bits (host_shadows
    compares them).  Blocks at columns 13 and 32 leave no packets; at 16 and 32, runs of 16."""
    from oclshade.sun import SunBlock, SunField

    hm = random_map()
    rows, cols = hm.shape
    assert cols == cuts_c[-1]
    suns = [(300.0, 12.0), (45.0, 45.0), (181.0, 3.0), (90.0, -3.0), (10.0, 90.0), (250.0, 30.0)]
    cuts_r = [0, 9, rows]
    blocks = [SunBlock(cuts_r[a], cuts_r[a + 1], cuts_c[b], cuts_c[b + 1], Sun(*suns[a * 3 + b]))
              for a in range(2) for b in range(3)]
    field = SunField(hm.shape, tuple(blocks), blocks[0].sun)
    path = tmp_path / "field.bin"
    with open(path, "wb") as f:
        np.array([len(blocks)], np.int32).tofile(f)
        for blk in blocks:
            np.array([blk.row0, blk.row1, blk.col0, blk.col1], np.int32).tofile(f)
            np.array([blk.sun.azimuth, blk.sun.elevation], np.float64).tofile(f)
    src = tmp_path / "heights.f64"
    np.ascontiguousarray(hm.heights, np.float64).tofile(src)
    out = tmp_path / "out"
    out.mkdir()
    stdout = run_program(host, "host_shadows", str(_kernel_root()), src, rows, cols, repr(hm.dx), repr(hm.dy), out,
                         f"--field={path}", "315.0,20.0")
    assert "field of 6 blocks traced" in stdout and stdout.strip().endswith("ok")
    assert "field in one launch (sun table): the same outputs" in stdout
    py = ShadowCaster(hm, cache=False).cast_many([field], "exact", "all", K_DARK, K_BRIGHT)[0]
    for ext, arr in (("mask", py.mask), ("self", py.self_shadow), ("coef", py.coefficient)):
        assert np.fromfile(out / f"field.{ext}", arr.dtype).tobytes() == arr.tobytes(), ext
    assert (py.mask == 1).any() and (py.mask == 0).any()


def test_c_error_paths_and_build_options(host: dict) -> None:
    """host_errors checks status codes and messages itself; its build options must be Python's."""
    proc = _run([str(host["build"] / "host_errors"), str(_kernel_root())], env=host["env"])
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    lines = proc.stdout.splitlines()

    def tuning(prefix: str) -> dict[str, int]:
        (line,) = [line for line in lines if line.startswith(prefix + " ")]
        lanes, run, group = map(int, line.split()[1:])
        return {"lanes": lanes, "run": run, "group": group}

    # a new handle starts with the Python host's rule for a device without a measured entry
    default, tuned = tuning("tuning"), tuning("tuned_tuning")
    (name,) = [line.split(" ", 1)[1] for line in lines if line.startswith("device_name ")]
    device = get_runtime().device
    if device.name != name:   # the C programs run on the first device PoCL lists
        device = next(d for p in cl.get_platforms() for d in p.get_devices() if d.name == name)
    rule = rule_values(TUNING, device)
    assert default == {k: rule[k] for k in default}, (default, device)
    # every knob the C host has starts with the Python host's rule for the device
    knobs = [line.split()[1:] for line in lines if line.startswith("default_knob ")]
    assert len(knobs) == 25
    for fam, name, value in knobs:
        assert int(value) == rule_values(family(fam), device)[name], (fam, name)
    assert tuned == {"lanes": 4, "run": 16, "group": 16}
    # build options: no packets; the handle's (ray packets for exact and maxmip iff lanes > 0);
    # after oclshade_set_tuning(lanes 4, run 16): all the Python host's for the same knobs
    # (the handle's options also inline built-ins where the rule says so: rule_values above)
    inline = {"own_builtins": rule["own_builtins"], "gather": rule["gather"]}
    for prefix, knobs in (("options ", {"lanes": 0, "run": 1024}), ("handle_options ", {**default, **inline}),
                          ("tuned_options ", {**tuned, **inline})):
        options = [line.split(" ", 3) for line in lines if line.startswith(prefix)]
        assert len(options) == 4 * 7
        for _, method_code, bits, text in options:
            method = METHODS[int(method_code) - 1]
            outputs = tuple(o for bit, (o,) in OUTPUT_BITS.items() if int(bits) & bit)
            features = ShadowFeatures(method, outputs, lanes=knobs["lanes"], run=knobs["run"],
                                      own_builtins=bool(knobs.get("own_builtins", 0)),
                                      gather=bool(knobs.get("gather", 0)))
            python = define_options(features.defines()) + ("-cl-std=CL1.2",)
            assert text == " ".join(python), (prefix, method, outputs)


def test_c_example_shadow_mask(host: dict, tmp_path: Path) -> None:
    """host/examples/shadow_mask.c: float32 file in, the Python host's mask out."""
    rng = np.random.default_rng(4)
    h = (rng.random((29, 41)) * 30.0).astype(np.float32)
    h[3, 4] = np.nan
    h.tofile(tmp_path / "in.f32")
    run_program(host, "shadow_mask", tmp_path / "in.f32", 29, 41, 1.5, 250.0, 12.0, tmp_path / "mask.u8")
    expected = ShadowCaster(Heightmap.from_array(h, 1.5)).cast((250.0, 12.0)).mask
    assert np.fromfile(tmp_path / "mask.u8", np.uint8).tobytes() == expected.tobytes()


def test_tiny_negative_azimuth_is_north() -> None:
    """-1e-20 degrees rounds to 360 after fmod + 360: it must stay north (the C twin relies on it)."""
    assert Sun(-1e-20, 25.0).ray(1.0, 1.0) == Sun(0.0, 25.0).ray(1.0, 1.0)
    assert Sun(-1e-20, 25.0).vector() == Sun(0.0, 25.0).vector()
