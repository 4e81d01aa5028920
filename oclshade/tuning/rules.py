"""The rule: knob values from a device's properties, for a device with no measured entry.

Measured on three CPUs and two PoCL drivers (docs/tuning.md): ray packets and
the multi-texel pyramid base pay when their lane count is the float vector
width of the code the compiler generates (AVX2: 8, AVX-512: 16); wider lanes
than the target's are split by the compiler and ran 2.6-3.2x slower than
one ray per work-item on an AVX2 Zen 2 (16 lanes on znver2), 5-7x slower on
a Zen 3 (16 lanes on znver3).  So on a CPU the ray-packet and
pyramid lane knobs follow :func:`float_lanes` (below 4: no packets).  The
SSAO kernel's lanes follow it only upwards (rule="wider": 16 on AVX-512
targets, else its safe 8): 4 lanes were 11 % slower than 8 on an SSE4.1
target, 16 were 40 % slower on AVX2 (Zen 3) and 13-26 % faster on the
AVX-512 targets of two Xeons (bench/results/tuning_variants_*.md).  Inline
built-ins (kernels/common.h) are on where the driver leaves the built-ins as
library calls, PoCL 3.0 (the PyPI wheel: its kernel target and its built-in
library's differ, and LLVM does not inline across them), for the families
whose knob says rule="library_calls": the tuner chose them there on all
three CPUs measured (pyramid, terrain and per-pixel shadows 11-22 % faster,
horizons 1.45x on a Zen 1), and the ray packets gained 1.30-1.34x on a
Rocket Lake Xeon once common.h's lane loads and stores were vector accesses
instead of per-lane loops; SSAO keeps them off (even, or slower).  On other
devices (GPUs) the hardware runs work-items in lockstep already: the scalar
kernels.  A probe (oclshade.tuning.probe) still checks the rule's choice
builds and runs before it is used.
"""
from __future__ import annotations

import pyopencl as cl

from .params import Family, Values

#: float lanes of the widest vector registers an LLVM CPU target has (AVX-512 16, AVX/AVX2 8,
#: SSE 4), for PoCL devices whose device version names the target they compile for
#: ("HSTR: pthread-x86_64-...-haswell").  PoCL reports the host's vector width even when it
#: compiles for an older target (Debian's 3.1 with POCL_KERNELLIB_NAME=sse41 targets penryn
#: on an AVX2 host and still says 8), and the PyPI wheel targets znver3 on an AVX-512 Zen 4.
TARGET_FLOAT_LANES = (
    (16, ("avx512", "cascadelake", "cooperlake", "cannonlake", "icelake", "tigerlake", "rocketlake",
          "sapphirerapids", "graniterapids", "emeraldrapids", "znver4", "znver5", "x86-64-v4")),
    (8, ("haswell", "broadwell", "skylake", "alderlake", "raptorlake", "meteorlake", "arrowlake", "lunarlake",
         "sandybridge", "ivybridge", "znver1", "znver2", "znver3", "bdver", "btver2", "x86-64-v3")),
    (4, ("penryn", "nehalem", "westmere", "core2", "bonnell", "silvermont", "goldmont", "tremont", "athlon",
         "amdfam10", "btver1", "x86-64")),
)   # host/src/oclshade.c has the same table (target_float_lanes); the first row that matches wins


def float_lanes(device: cl.Device) -> int:
    """The float vector width the device's compiler targets: from PoCL's target name when the
    device version carries one (``HSTR: ...``; a substring of the table above), else
    CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT."""
    version = device.version
    if "HSTR:" in version:
        target = version.split("HSTR:", 1)[1]
        for lanes, names in TARGET_FLOAT_LANES:
            if any(name in target for name in names):
                return lanes
    return int(device.native_vector_width_float or 1)


def _lanes(width: int, legal: tuple[int, ...]) -> int:
    """The widest legal lane count (4 or more) within ``width``, else the narrowest legal value
    (0 or 1: no lanes)."""
    fitting = [v for v in legal if 4 <= v <= width]
    return max(fitting) if fitting else min(legal)


def _crossings(width: int, legal: tuple[int, ...]) -> int:
    """The largest legal value up to 16 x ``width``, at least the smallest non-zero one (rule
    "crossings": the horizon sweep, measured faster than the walk up to about 9-11 crossings per
    lane on rough ground and always on smooth ground; docs/solar.md, "The sweep and the walk")."""
    nonzero = sorted(v for v in legal if v > 0)
    return max([v for v in nonzero if v <= 16 * width] or nonzero[:1])


def builtins_are_calls(device: cl.Device) -> bool:
    """True for a driver that leaves the OpenCL built-ins as calls into its library: PoCL 3.0's
    CPU devices (driver version 3.0, e.g. "3.0-rc2" of the PyPI wheel; measured, docs/tuning.md
    "Inline built-ins").  On Debian's PoCL 3.1 two full tunes chose them for one family only
    (per-pixel shadows, SSE4.1 target on a Zen 1), so the rule leaves other drivers to the tuner."""
    return (bool(device.type & cl.device_type.CPU) and "PoCL" in device.version
            and device.driver_version.startswith("3.0"))


def rule_values(family: Family, device: cl.Device) -> Values:
    """The rule's values for every knob of ``family`` (the safe value where it says nothing)."""
    values = family.safe()
    is_cpu = bool(device.type & cl.device_type.CPU)
    width = float_lanes(device)
    for p in family.params:
        if p.rule == "width" and is_cpu:
            values[p.name] = _lanes(width, p.values)
        elif p.rule == "wider" and is_cpu:
            values[p.name] = max(p.safe, _lanes(width, p.values))
        elif p.rule == "crossings" and is_cpu:
            values[p.name] = _crossings(width, p.values)
        elif p.rule == "host_memory":
            values[p.name] = int(is_cpu and bool(device.host_unified_memory))
        elif p.rule == "library_calls":
            values[p.name] = int(builtins_are_calls(device))
        elif p.rule == "gpu" and not is_cpu:
            values[p.name] = max(p.values)
    return family.check(values)
