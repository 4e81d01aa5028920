"""kernels/common.h's inline built-ins (-D OCLS_OWN_BUILTINS) give the library's results.

Each family's knob tests compare whole kernels with the knob on and off; this one checks the
definitions themselves on the inputs where they could differ: clz of 0, of negatives and
around 2^24 (the vector clz reads a float conversion's exponent), popcount, any on each lane's
sign bit, fmax / fmin with NaN, and lane loads and stores at unaligned offsets.
"""
from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest

from oclshade.runtime import get_runtime, kernel_source

SOURCE = kernel_source("common.h") + r"""
__kernel void probe(__global const int *xi, __global const float *xf, __global int *out_i,
                    __global float *out_f)
{
    const int g = get_global_id(0);                    /* one work-item per 16 inputs */
    const int16 v = vload16(g, xi);
    vstore16(clz(v), g, out_i);                        /* vector clz */
    int s[16];
    for (int k = 0; k < 16; ++k) s[k] = clz(xi[16 * g + k]) + 100 * popcount(xi[16 * g + k]);
    for (int k = 0; k < 16; ++k) out_i[16 * (get_global_size(0) + g) + k] = s[k];
    out_i[32 * get_global_size(0) + g] = any(v) + 2 * any(v.lo) + 4 * any(v.s0123) + 8 * any(v.s0);
    float a[20];
    for (int k = 0; k < 20; ++k) a[k] = xf[16 * g + k];
    const float16 f = vload16(0, a + 3), w = vload16(0, xf + 16 * g + 1);   /* unaligned */
    const float16 m = select(fmax(f, w), fmin(f, w), as_int16(f) < as_int16(w));
    vstore16(m, 0, a + 1);
    for (int k = 0; k < 16; ++k) out_f[16 * g + k] = a[k + 1];
}
"""


def _run(own: bool, xi: np.ndarray, xf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    rt = get_runtime()
    options = ["-cl-std=CL1.2"] + (["-DOCLS_OWN_BUILTINS"] if own else [])
    program = cl.Program(rt.context, SOURCE).build(options=options)
    groups = xi.size // 16
    bi = cl.Buffer(rt.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=xi)
    bf = cl.Buffer(rt.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=xf)
    out_i = np.zeros(32 * groups + groups, np.int32)
    out_f = np.zeros(16 * groups, np.float32)
    oi = cl.Buffer(rt.context, cl.mem_flags.WRITE_ONLY, out_i.nbytes)
    of = cl.Buffer(rt.context, cl.mem_flags.WRITE_ONLY, out_f.nbytes)
    program.probe(rt.queue, (groups,), None, bi, bf, oi, of)
    cl.enqueue_copy(rt.queue, out_i, oi)
    cl.enqueue_copy(rt.queue, out_f, of)
    return out_i, out_f


def _reference_clz(x: np.ndarray) -> np.ndarray:
    u = x.astype(np.int64) & 0xFFFFFFFF
    return np.array([32 - int(v).bit_length() for v in u], np.int32)


def test_inline_builtins_equal_the_library():
    rng = np.random.default_rng(7)
    edges = [0, 1, 2, 3, -1, -2, 2**31 - 1, -2**31, 2**23 - 1, 2**23, 2**24 - 1, 2**24, 2**24 + 1,
             2**25 - 1, 2**30 + 12345, 255, 256, 4095, 4096]
    xi = np.concatenate([np.array(edges, np.int32), rng.integers(-2**31, 2**31, 400, dtype=np.int64).astype(np.int32),
                         (1 << rng.integers(0, 31, 100)).astype(np.int32) - rng.integers(0, 2, 100).astype(np.int32)])
    xi = np.concatenate([xi, np.zeros(-xi.size % 16, np.int32)])
    groups = xi.size // 16
    xf = rng.normal(size=16 * groups + 16).astype(np.float32)
    xf[rng.integers(0, xf.size, 40)] = np.nan
    xf[rng.integers(0, xf.size, 20)] = -0.0
    own_i, own_f = _run(True, xi, xf)
    lib_i, lib_f = _run(False, xi, xf)
    assert np.array_equal(own_i, lib_i)
    assert np.array_equal(own_f.view(np.int32), lib_f.view(np.int32))
    # and both are what the specification says
    n = groups * 16
    assert np.array_equal(own_i[:n], _reference_clz(xi))
    popcounts = np.array([bin(int(v) & 0xFFFFFFFF).count("1") for v in xi], np.int32)
    assert np.array_equal(own_i[n:2 * n], _reference_clz(xi) + 100 * popcounts)
    lanes = xi.reshape(groups, 16) < 0
    anys = lanes.any(1) + 2 * lanes[:, :8].any(1) + 4 * lanes[:, :4].any(1) + 8 * lanes[:, 0]
    assert np.array_equal(own_i[2 * n:], anys.astype(np.int32))


@pytest.mark.parametrize("own", [True, False])
def test_unaligned_lane_loads_and_stores_move_the_right_floats(own):
    xi = np.arange(16, dtype=np.int32)
    xf = np.arange(32, dtype=np.float32)
    _, out = _run(own, xi, xf)
    f, w = xf[3:19], xf[1:17]   # f > w lane by lane: select picks fmin where f's bits are below w's
    assert np.array_equal(out, np.where(f.view(np.int32) < w.view(np.int32), np.fmin(f, w), np.fmax(f, w)))
