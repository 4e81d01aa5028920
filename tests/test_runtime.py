"""Host layer: device choice, program builds and their cache, resource checks."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from oclshade import runtime
from oclshade.runtime import (AllocationError, DeviceNotFoundError, ProgramBuildError, get_runtime,
                              list_devices, select_device)


def test_default_device_is_pocl_cpu(monkeypatch):
    monkeypatch.delenv(runtime.DEVICE_ENV, raising=False)
    dev = select_device()
    assert "portable computing language" in dev.platform.name.lower() or len(list_devices()) >= 1


def test_select_by_index_substring_and_env(monkeypatch):
    first = list_devices()[0]
    assert select_device(0).name == first.name
    assert select_device("0").name == first.name
    assert select_device(first.name[:6].lower()).name == first.name
    monkeypatch.setenv(runtime.DEVICE_ENV, "0")
    assert select_device().name == first.name


@pytest.mark.parametrize("spec", ["999", "no-such-device-xyz"])
def test_bad_device_spec_names_itself(spec):
    with pytest.raises(DeviceNotFoundError, match=spec):
        select_device(spec)


def test_list_devices_reports_versions():
    info = list_devices()[0]
    assert info.opencl_version.startswith("OpenCL") and info.driver_version and info.max_alloc_bytes > 0


def test_program_cache_hits_and_misses():
    rt = get_runtime()
    rt.program("pyramid.cl")
    hits = rt.build_hits
    assert rt.program("pyramid.cl") is rt.program("pyramid.cl")
    assert rt.build_hits == hits + 2
    misses = rt.build_misses
    rt.program("pyramid.cl", {"OCLS_UNUSED_TEST_FLAG": 1})
    assert rt.build_misses == misses + 1


def test_build_failure_carries_log_and_options():
    rt = get_runtime()
    with pytest.raises(ProgramBuildError) as info:
        rt.program("shadow.cl", {"OCLS_METHOD": "1+"})
    err = info.value
    assert "-DOCLS_METHOD=1+" in err.options
    assert "error" in err.log.lower() and "shadow.cl" in str(err)


def test_kernel_sources_expand_includes_and_disable_contraction():
    src = runtime.kernel_source("shadow.cl")
    assert "#include" not in src and "#pragma OPENCL FP_CONTRACT OFF" in src


def test_kernel_sources_use_no_variadic_macros():
    """OpenCL C 1.2 has no variadic macros: PoCL's clang lets them pass, NVIDIA's compiler refuses
    the program (ssao.cl did, found on an H200)."""
    import re
    variadic = re.compile(r"^\s*#\s*define\s+\w+\([^)]*\.\.\.\s*\)", re.MULTILINE)
    for path in sorted(runtime._kernel_root().iterdir()):
        if path.name.endswith((".cl", ".h")):
            assert not variadic.search(path.read_text()), f"{path.name} defines a variadic macro"
            assert "__VA_ARGS__" not in path.read_text(), path.name


class _FpDevice:
    def __init__(self, config: int):
        self.single_fp_config = config


def test_builds_ask_for_correctly_rounded_divide_and_sqrt_where_offered():
    exact = int(runtime.cl.device_fp_config.CORRECTLY_ROUNDED_DIVIDE_SQRT)
    assert runtime.rounding_options(_FpDevice(exact | 1)) == (runtime.CORRECT_ROUNDING_OPTION,)
    assert runtime.rounding_options(_FpDevice(exact ^ 0xFF)) == ()
    rt = get_runtime()
    prog = rt.program("pyramid.cl")
    options = prog.get_build_info(rt.device, runtime.cl.program_build_info.OPTIONS)
    assert (runtime.CORRECT_ROUNDING_OPTION in options) == bool(runtime.rounding_options(rt.device))


def test_allocation_limit_is_checked():
    rt = get_runtime()
    with pytest.raises(AllocationError, match="MiB"):
        rt.check_alloc(rt.device.max_mem_alloc_size + 1, "test buffer")


def test_work_group_size_respects_device_limits():
    rt = get_runtime()
    k = rt.kernel("pyramid.cl", "mip_reduce")
    ls = rt.local_size(k, 1 << 20)
    assert 1 <= ls <= rt.device.max_work_group_size and ls & (ls - 1) == 0
    np.testing.assert_equal(ls, min(ls, rt.device.max_work_item_sizes[0]))


def test_share_reads_read_only_arrays_in_place_when_asked_and_copies_otherwise():
    import pyopencl as cl

    rt = get_runtime()
    frozen = np.arange(64, dtype=np.float32)
    frozen.setflags(write=False)
    writable = np.arange(64, dtype=np.float32)
    shared, copied = rt.share(frozen, "frozen", in_place=True), rt.share(writable, "writable", in_place=True)
    assert shared.hostbuf is not None               # USE_HOST_PTR keeps the array
    assert copied.hostbuf is None                    # a writable array is copied
    assert rt.share(frozen, "frozen", in_place=False).hostbuf is None
    writable[:] = -1.0                               # the copy does not see later changes
    for buf, expected in ((shared, frozen), (copied, np.arange(64, dtype=np.float32))):
        out = np.empty(64, np.float32)
        cl.enqueue_copy(rt.queue, out, buf)
        np.testing.assert_array_equal(out, expected)


_EXIT_WITH_KERNELS_RUNNING = """
from oclshade.heightmap import Heightmap
from oclshade.horizon import HorizonCaster
from oclshade.synthetic import canyon_crater
caster = HorizonCaster(Heightmap.from_array(canyon_crater(2048, 2048, seed=0, relief=1500.0), 30.0))
caster.horizons(1)
for azimuth in (37.0, 200.0):
    list(caster.angles_on_device([azimuth]))     # queued, not waited for, buffers dropped
print("queued", flush=True)
"""


def test_exit_while_kernels_run_is_clean():
    """The process ends with work still queued (angles_on_device does not wait): without the
    runtime's exit handler PoCL ended it with SIGSEGV (rc -11), every time on a 2048^2 map."""
    done = subprocess.run([sys.executable, "-c", _EXIT_WITH_KERNELS_RUNNING], capture_output=True,
                          text=True, timeout=600)
    assert (done.returncode, done.stdout) == (0, "queued\n"), done.stderr[-2000:]


@pytest.mark.parametrize("fast", [True, False])
def test_set_arg_takes_numpy_values_by_either_path(fast, monkeypatch):
    """runtime.set_arg: pyopencl's _set_arg_buf for contiguous numpy values (or set_arg where a
    pyopencl lacks it), set_arg for the rest: the kernel sees the same values either way."""
    import pyopencl as cl

    if not fast:
        monkeypatch.setattr(runtime, "_SET_ARG_BUF", None)
    rt = get_runtime(None)
    prg = cl.Program(rt.context, "__kernel void k(__global float *out, float4 r, int m, __global const float *b)"
                                 "{ out[0] = r.x + 10.0f * r.w + 100.0f * m + 1000.0f * b[0]; }").build()
    kernel = cl.Kernel(prg, "k")
    out = rt.empty(4, "out")
    table = np.arange(16, dtype=np.float32).reshape(4, 4)
    first, second = (rt.to_device(np.array([v], np.float32), "b") for v in (0.0, 3.0))
    kernel.set_args(out, table[0], np.int32(0), first)
    runtime.set_arg(kernel, 1, table[2])                                  # a row of a table
    runtime.set_arg(kernel, 2, np.arange(3, dtype=np.int32)[2])           # a numpy scalar
    runtime.set_arg(kernel, 3, second)                                    # a buffer: set_arg
    cl.enqueue_nd_range_kernel(rt.queue, kernel, (1,), None)
    got = np.empty(1, np.float32)
    cl.enqueue_copy(rt.queue, got, out)
    assert got[0] == 8.0 + 10.0 * 11.0 + 100.0 * 2 + 1000.0 * 3.0
