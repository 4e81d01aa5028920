"""Roofline probes: a device's measured global-memory bandwidth and arithmetic rate.

In the manner of clpeak (host side: many launches of tiny kernels, the best
batch counts; no code of it is used): ``roofline_copy`` streams a float4
buffer into another (bytes = 16 read + 16 written per element, the STREAM
"copy" convention) and ``roofline_mad`` runs eight independent multiply-add
chains per work-item on vectors of several widths, with ``mad()`` and as a
separate multiply and add (2 flops either way); the fastest variant is the
device's arithmetic roof.  Kernels and their ABI: ``kernels/roofline.cl``.

The roofline model then bounds a case that must move ``bytes`` and compute
``flops`` from below by ``max(bytes / bandwidth, flops / peak)`` seconds
(:func:`roofline_seconds`); the fraction of the roofline a case reaches is
that bound over its measured time, the same as its achieved flop rate over
``min(bandwidth * intensity, peak)``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import pyopencl as cl

from ..runtime import Runtime

MAD_WIDTHS = (4, 8, 16)           # RL_WIDTH values tried (8 chains of 4+ lanes: ILP enough for CPUs and GPUs)
MAD_CHAINS = 8                    # independent chains per work-item (kernels/roofline.cl)
MAD_ITEMS_PER_CU = 2048           # work-items per compute unit of a roofline_mad launch


@dataclass(frozen=True)
class Roofline:
    """A device's measured roofs and what each probe variant reached."""

    bandwidth_gbs: float                      # best float4 copy rate, GB/s (1e9 bytes/s)
    gflops: float                             # best multiply-add rate, GFLOP/s
    probes: dict[str, float] = field(default_factory=dict)   # variant -> GB/s or GFLOP/s
    buffer_bytes: int = 0                     # size of each copy buffer

    def as_dict(self) -> dict[str, object]:
        return {"bandwidth_gbs": self.bandwidth_gbs, "gflops": self.gflops,
                "copy_buffer_bytes": self.buffer_bytes, "probes": dict(self.probes)}


def roofline_seconds(nbytes: float, flops: float, roof: Roofline) -> float:
    """The roofline's lower bound on the time to move ``nbytes`` and compute ``flops``."""
    return max(nbytes / (roof.bandwidth_gbs * 1e9), flops / (roof.gflops * 1e9))


def _best_rate(launch: Callable[[], None], finish: Callable[[], None], work: float, target_s: float,
               batches: int = 3) -> float:
    """Best work/second over ``batches`` batches of launches, each batch grown (doubling)
    until it lasts at least ``target_s`` / ``batches``; the first launch (a warm-up: PoCL
    compiles at the first enqueue) is not timed."""
    launch()
    finish()
    count, best = 1, 0.0
    while True:
        t0 = time.perf_counter()
        for _ in range(count):
            launch()
        finish()
        dt = time.perf_counter() - t0
        best = max(best, count * work / dt)
        if dt >= target_s / batches:
            break
        count *= 2
    for _ in range(batches - 1):
        t0 = time.perf_counter()
        for _ in range(count):
            launch()
        finish()
        best = max(best, count * work / (time.perf_counter() - t0))
    return best


def measure_bandwidth(rt: Runtime, buffer_bytes: int, target_s: float) -> float:
    """GB/s of ``roofline_copy`` between two buffers of ``buffer_bytes`` each."""
    if buffer_bytes < 16:
        raise ValueError(f"buffer_bytes must be at least 16 (one float4), got {buffer_bytes}")
    n = buffer_bytes // 16
    src, dst = rt.empty(16 * n, "roofline source"), rt.empty(16 * n, "roofline destination")
    cl.enqueue_fill_buffer(rt.queue, src, np.float32(1.0), 0, 16 * n)
    kernel = rt.kernel("roofline.cl", "roofline_copy")
    kernel.set_args(src, dst, np.int32(n))
    local = rt.local_size(kernel, 256)
    size = -(-n // local) * local
    rate = _best_rate(lambda: cl.enqueue_nd_range_kernel(rt.queue, kernel, (size,), (local,)),
                      rt.queue.finish, 32.0 * n, target_s)
    return rate / 1e9


def measure_gflops(rt: Runtime, width: int, split: bool, target_s: float) -> float:
    """GFLOP/s of ``roofline_mad`` with RL_WIDTH = ``width`` (and RL_SPLIT when ``split``)."""
    if width not in MAD_WIDTHS:
        raise ValueError(f"width must be one of {MAD_WIDTHS}, got {width!r}")
    kernel = rt.kernel("roofline.cl", "roofline_mad", {"RL_WIDTH": width, "RL_SPLIT": split})
    local = rt.local_size(kernel, 64)
    items = -(-max(rt.device.max_compute_units, 1) * MAD_ITEMS_PER_CU // local) * local
    out = rt.empty(4 * items, "roofline sums")
    iterations = 256
    kernel.set_args(out, np.float32(0.999), np.float32(0.001), np.int32(iterations))
    cl.enqueue_nd_range_kernel(rt.queue, kernel, (items,), (local,))   # compile before sizing
    rt.queue.finish()
    while iterations < 1 << 20:   # one launch of at least target_s / 10
        t0 = time.perf_counter()
        cl.enqueue_nd_range_kernel(rt.queue, kernel, (items,), (local,))
        rt.queue.finish()
        if time.perf_counter() - t0 >= target_s / 10:
            break
        iterations *= 2
        kernel.set_arg(3, np.int32(iterations))
    flops = 2.0 * MAD_CHAINS * width * iterations * items
    return _best_rate(lambda: cl.enqueue_nd_range_kernel(rt.queue, kernel, (items,), (local,)),
                      rt.queue.finish, flops, target_s) / 1e9


def measure_roofline(rt: Runtime, buffer_bytes: int, target_s: float) -> Roofline:
    """Both roofs of a device: the copy bandwidth over ``buffer_bytes`` buffers (make them
    larger than the last-level cache) and the best multiply-add rate over the variants;
    each probe runs for about ``target_s`` seconds after its warm-up."""
    if not target_s > 0:
        raise ValueError(f"target_s must be positive, got {target_s!r}")
    probes = {"copy_float4_gbs": measure_bandwidth(rt, buffer_bytes, target_s)}
    for width in MAD_WIDTHS:
        for split in (False, True):
            name = f"{'mul_add' if split else 'mad'}_float{width}_gflops"
            probes[name] = measure_gflops(rt, width, split, target_s)
    gflops = max(v for k, v in probes.items() if k.endswith("_gflops"))
    return Roofline(probes["copy_float4_gbs"], gflops, probes, buffer_bytes)
