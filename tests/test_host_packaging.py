"""Packaging and robustness of the C host API (host/): the installed CMake package with its
version file and SOVERSION, an OpenCL 3.0 consumer project through find_package and through
add_subdirectory (which must install nothing of ours), the configure-time error for missing
kernel sources, ThreadSanitizer on one handle shared by threads, and valgrind on a whole frame.

Uses the session build of tests/test_host_api.py (a shared library); skips what a tool it
needs is missing for (valgrind, a compiler with ThreadSanitizer), with the reason.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from oclshade.runtime import _kernel_root

from test_host_api import HOST, _run, build_env, cmake_build, configure, host, run_program  # noqa: F401

CONSUMER = HOST / "tests" / "consumer"


@pytest.fixture(scope="module")
def installed(host: dict, tmp_path_factory) -> Path:
    """The session build installed into a prefix (cmake --install)."""
    prefix = tmp_path_factory.mktemp("prefix")
    done = _run(["cmake", "--install", str(host["build"]), "--prefix", str(prefix)])
    assert done.returncode == 0, done.stdout + done.stderr
    return prefix


def test_installed_package_has_version_file_and_soversion(installed: Path) -> None:
    (config,) = installed.glob("lib*/cmake/oclshade/oclshadeConfigVersion.cmake")
    assert 'set(PACKAGE_VERSION "0.3.0")' in config.read_text()
    (library,) = [p for p in installed.glob("lib*/liboclshade.so.*") if not p.is_symlink()]
    assert library.name == "liboclshade.so.0.3.0"
    soname = subprocess.run(["objdump", "-p", str(library)], capture_output=True, text=True).stdout
    assert re.search(r"SONAME\s+liboclshade\.so\.0\.3\b", soname), soname[-500:]
    assert (installed / "include" / "oclshade.h").is_file()


def test_consumer_with_find_package_and_opencl_3(host: dict, installed: Path, tmp_path: Path) -> None:
    """find_package(oclshade 0.3 REQUIRED) in a project that targets OpenCL 3.0 (the header leaves
    CL_TARGET_OPENCL_VERSION to it): builds and runs; 0.4 and 0.2 requests are refused."""
    build = tmp_path / "consumer"
    configure(CONSUMER, build, f"-DCMAKE_PREFIX_PATH={installed}")
    cmake_build(build)
    out = run_program(host, str(build / "consumer"))   # absolute: not in the host build
    assert out.splitlines()[-1] == "ok" and "oclshade 0.3.0" in out
    for wrong in ("0.4", "0.2"):
        probe = tmp_path / f"probe-{wrong}"
        probe.mkdir()
        (probe / "CMakeLists.txt").write_text(
            f"cmake_minimum_required(VERSION 3.16)\nproject(probe LANGUAGES C)\nfind_package(oclshade {wrong} REQUIRED)\n")
        conf = _run(["cmake", "-S", str(probe), "-B", str(probe / "b"), f"-DCMAKE_PREFIX_PATH={installed}"])
        assert conf.returncode != 0 and "0.3.0" in conf.stdout + conf.stderr, wrong


def test_vendored_with_add_subdirectory_installs_nothing_of_ours(host: dict, tmp_path: Path) -> None:
    build, prefix = tmp_path / "build", tmp_path / "prefix"
    configure(CONSUMER, build, f"-DOCLSHADE_SOURCE_DIR={HOST}", f"-DOCLSHADE_KERNEL_DIR={_kernel_root()}")
    cmake_build(build, "consumer")
    out = run_program(host, str(build / "consumer"))   # absolute: not in the host build
    assert out.splitlines()[-1] == "ok"
    done = _run(["cmake", "--install", str(build), "--prefix", str(prefix)])
    assert done.returncode == 0, done.stdout + done.stderr
    installed = sorted(str(p.relative_to(prefix)) for p in prefix.rglob("*") if p.is_file())
    assert installed == ["bin/consumer"], installed


def test_missing_kernel_source_is_a_configure_error(tmp_path: Path) -> None:
    if shutil.which("cmake") is None:
        pytest.skip("cmake not found")
    kernels = tmp_path / "kernels"
    kernels.mkdir()
    for name in ("common.h", "pyramid.cl", "shadow.cl", "ssao.cl", "compose.cl"):   # no terrain.cl
        shutil.copy(Path(_kernel_root()) / name, kernels / name)
    conf = _run(["cmake", "-S", str(HOST), "-B", str(tmp_path / "b"), f"-DOCLSHADE_KERNEL_DIR={kernels}",
                 "-DOCLSHADE_BUILD_TESTS=OFF", "-DOCLSHADE_BUILD_EXAMPLES=OFF"])
    text = conf.stdout + conf.stderr
    assert conf.returncode != 0
    assert f"kernel source {kernels}/terrain.cl is missing" in " ".join(text.split())


# ------------------------------------------------------------------------ ThreadSanitizer
def _tsan_env(host: dict) -> dict:
    return dict(host["env"], TSAN_OPTIONS=f"suppressions={HOST / 'tests' / 'tsan.supp'} halt_on_error=0 exitcode=66")


def test_shared_handle_is_clean_under_thread_sanitizer(host: dict, tmp_path: Path) -> None:
    """host_threads built with -fsanitize=thread: threads sharing one handle (failing calls,
    builds, knob changes, enqueues) give no ThreadSanitizer report.  A deliberate race
    (host/tests/tsan_control.c) must be reported first, so a clean report means something."""
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    control = tmp_path / "tsan_control"
    made = _run([cc, "-fsanitize=thread", "-g", "-O1", str(HOST / "tests" / "tsan_control.c"), "-o", str(control),
                 "-lpthread"])
    if made.returncode != 0:
        pytest.skip(f"the C compiler cannot build with -fsanitize=thread: {made.stderr.strip()[-300:]}")
    raced = subprocess.run([str(control)], capture_output=True, text=True, env=_tsan_env(host), timeout=120)
    assert "WARNING: ThreadSanitizer: data race" in raced.stderr, "ThreadSanitizer did not report the control race"
    build = tmp_path / "tsan"
    configure(HOST, build, f"-DOCLSHADE_KERNEL_DIR={_kernel_root()}", "-DCMAKE_BUILD_TYPE=RelWithDebInfo",
              "-DCMAKE_C_FLAGS=-fsanitize=thread", "-DCMAKE_EXE_LINKER_FLAGS=-fsanitize=thread",
              "-DOCLSHADE_BUILD_EXAMPLES=OFF")
    cmake_build(build, "host_threads")
    proc = subprocess.run([str(build / "host_threads"), "4"], capture_output=True, text=True, env=_tsan_env(host),
                          timeout=600)
    assert "ThreadSanitizer" not in proc.stderr, proc.stderr[-6000:]
    assert proc.returncode == 0 and proc.stdout.splitlines()[-1] == "ok", proc.stdout + proc.stderr[-3000:]


# ------------------------------------------------------------------------ valgrind
def test_whole_frame_under_valgrind_loses_nothing(host: dict, tmp_path: Path) -> None:
    """render_frame (every family: pyramids, dilated levels, G-buffer, normals, mip + coarse
    grids, per-pixel shadows, SSAO, compose with ssaa) under memcheck: 0 bytes definitely lost
    and no memory error in the library or the example.  A run under valgrind's null tool
    first lets PoCL write the kernel binaries that a run under valgrind asks for (PoCL
    compiles them again the first time; its LLVM leaks are not ours), so memcheck stays short."""
    if shutil.which("valgrind") is None:
        pytest.skip("valgrind not found (apt-get install valgrind)")
    if not (host["build"] / "render_frame").exists():
        pytest.skip("render_frame was not built: CMake found no zlib (zlib1g-dev)")
    rng = np.random.default_rng(8)
    heights = np.cumsum(rng.normal(size=(24, 21)), axis=0) * 5.0 + 300.0
    heights.tofile(tmp_path / "h.f64")
    args = [str(host["build"] / "render_frame"), str(tmp_path / "h.f64"), "24", "21", "30", "30",
            str(tmp_path / "frame.png"), "--camera", "-100,-800,600,300,-350,300", "--size", "14x9", "--ssaa", "2",
            "--ao", "2"]
    for tool in ("none", "memcheck"):
        cmd = ["valgrind", f"--tool={tool}", *(["--leak-check=full"] if tool == "memcheck" else []), *args]
        proc = subprocess.run(cmd, capture_output=True, text=True, env=host["env"], timeout=600)
        assert proc.returncode == 0, proc.stderr[-4000:]
    report = proc.stderr
    lost = re.search(r"definitely lost: ([\d,]+) bytes", report)
    assert (lost is not None and lost.group(1) == "0") or "no leaks are possible" in report, report[-4000:]
    # memory errors (glibc's loader has its own known ones) must not pass through our code
    errors = re.split(r"==\d+== \n", report)
    ours = [e for e in errors if re.search(r"==\d+== (Invalid|Conditional|Use of|Mismatched|Source)", e)
            and re.search(r"liboclshade|/render_frame\)|render_frame\.c", e)]
    assert not ours, "\n".join(ours)[-4000:]
