"""The rule: knob values from a device's properties, for a device with no measured entry.

Measured on three CPUs and two PoCL drivers (docs/tuning.md): ray packets and
the multi-texel pyramid base pay when their lane count is the device's
native float vector width (AVX2: 8, AVX-512: 16); wider lanes than the
hardware's are split in two by the compiler and ran 2.6-3.2x slower than one
ray per work-item on an AVX2 Zen 2.  So on a CPU the lane knobs follow
CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT (below 4: no packets).  On other
devices (GPUs) the hardware runs work-items in lockstep already: the scalar
kernels.  A probe (oclshade.tuning.probe) still checks the rule's choice
builds and runs before it is used.
"""
from __future__ import annotations

import pyopencl as cl

from .params import Family, Values


def _lanes(width: int, legal: tuple[int, ...]) -> int:
    """The widest legal lane count (4 or more) within ``width``, else the narrowest legal value
    (0 or 1: no lanes)."""
    fitting = [v for v in legal if 4 <= v <= width]
    return max(fitting) if fitting else min(legal)


def rule_values(family: Family, device: cl.Device) -> Values:
    """The rule's values for every knob of ``family`` (the safe value where it says nothing)."""
    values = family.safe()
    is_cpu = bool(device.type & cl.device_type.CPU)
    width = int(device.native_vector_width_float or 1)
    for p in family.params:
        if p.vector and is_cpu:
            values[p.name] = _lanes(width, p.values)
        elif p.name == "in_place":
            values[p.name] = int(is_cpu and bool(device.host_unified_memory))
    return family.check(values)
