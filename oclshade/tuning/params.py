"""Tuning parameters: the performance knobs of each kernel family, declared once.

A knob changes how a kernel is built or launched (a ``-D`` option, a work
size), never what it computes: the tests compare every legal value bit for
bit.  Each family module (shadows, pyramid, terrain, ssao, ...) declares its
knobs with :func:`register` next to the code that launches them, with

* ``smoke``: builds and runs a tiny case with given values (what a probe runs
  in a child process, :mod:`oclshade.tuning.probe`), and
* ``workload``: a representative case for the tuner (:mod:`oclshade.tuning.tuner`).

Which values a device gets is :func:`oclshade.tuning.settings`'s answer (user
entry -> shipped database -> rule -> safe default); nothing else in the code
asks what kind of device it is.
"""
from __future__ import annotations

import functools
import importlib
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Mapping

Values = dict[str, int]

#: the modules that register a family, imported on demand by :func:`families`
FAMILY_MODULES = ("oclshade.pyramid", "oclshade.shadows", "oclshade.terrain", "oclshade.screen_shadows",
                  "oclshade.ssao", "oclshade.horizon.caster")


#: the rules a knob can follow (Param.rule; oclshade/tuning/rules.py applies them)
RULES = ("safe", "width", "wider", "crossings", "host_memory", "library_calls", "gpu")


@dataclass(frozen=True)
class Param:
    """One knob: its legal values, the value that works on every device, and what it becomes."""

    name: str
    values: tuple[int, ...]
    safe: int
    doc: str
    #: True for a knob whose non-safe values drive the compiler's vector code generation (lane
    #: counts, inline built-ins): a value that fails a probe falls back to the next smaller one
    vector: bool = False
    #: what the rule from device properties sets it to (oclshade/tuning/rules.py): "safe" (its
    #: safe value), "width" (a lane count: the compiler target's float vector width on CPUs),
    #: "wider" (the same where it is wider than the safe value, else the safe value),
    #: "crossings" (on CPUs the largest legal value up to 16 x that width, at least the smallest
    #: non-zero one: the horizon sweep's reach, whose cost per crossing falls with the lanes),
    #: "host_memory" (1 on CPU devices that share the host's memory) or "library_calls" (1 on
    #: drivers that leave the built-ins as library calls: PoCL 3.0's CPU devices) or "gpu" (the
    #: largest legal value on devices that are not CPUs, else the safe value)
    rule: str = "safe"
    #: False for a knob whose best value depends on the input, not only on the device, and that
    #: chooses at run time (horizon sweep_far's pilot): the tuner leaves it at its rule's value,
    #: since one workload's answer would be every map's
    tuned: bool = True

    def __post_init__(self) -> None:
        if self.safe not in self.values:
            raise ValueError(f"Param {self.name}: safe value {self.safe} is not among {self.values}")
        if self.rule not in RULES:
            raise ValueError(f"Param {self.name}: rule must be one of {', '.join(RULES)}, got {self.rule!r}")

    def check(self, value: object, family: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value not in self.values:
            raise ValueError(f"tuning {family}.{self.name} must be one of {self.values}; got {value!r}")
        return int(value)

    def narrower(self, value: int) -> list[int]:
        """The legal values to try after ``value`` failed: smaller ones, largest first."""
        return sorted((v for v in self.values if v < value), reverse=True)


#: the knob every family has: inline definitions of the built-ins its hot loops call
#: (-D OCLS_OWN_BUILTINS, kernels/common.h): PoCL 3.0 from PyPI leaves them as library calls
#: when the kernel's CPU target differs from its library's (AMD CPUs)
OWN_BUILTINS = Param("own_builtins", (0, 1), 0, "inline built-ins (-D OCLS_OWN_BUILTINS, kernels/common.h)",
                     vector=True)
#: the same knob for the families whose kernels gained from it on every CPU measured with PoCL 3.0
#: (pyramid, terrain, screen_shadows, horizon: the tuner chose it on a Zen 1, a Zen 3 and an
#: AVX-512 Xeon; the ray packets 1.30-1.34x faster on a Rocket Lake Xeon once common.h's lane loads
#: and stores became vector accesses, docs/tuning.md "The rule"); the rule turns it on there.
#: SSAO (lost or even on four CPUs) keeps OWN_BUILTINS.
OWN_BUILTINS_WHERE_CALLED = replace(OWN_BUILTINS, rule="library_calls")


@dataclass(frozen=True)
class Family:
    """A kernel family's knobs, with its probe case and its tuning workload."""

    name: str
    params: tuple[Param, ...]
    kernel_files: tuple[str, ...]
    #: smoke(runtime, values): build and run a tiny case with these values (raises on failure)
    smoke: Callable[[Any, Values], None]
    #: workload(runtime, values, quick) -> a callable that enqueues one representative case (the
    #: tuner times it up to the queue's end; the first call includes the build)
    workload: Callable[[Any, Values, bool], Callable[[], None]]
    doc: str = ""
    _by_name: dict[str, Param] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_by_name", {p.name: p for p in self.params})

    def param(self, name: str) -> Param:
        try:
            return self._by_name[name]
        except KeyError:
            raise ValueError(f"tuning family {self.name!r} has no parameter {name!r}; "
                             f"it has {', '.join(self._by_name)}") from None

    def safe(self) -> Values:
        return {p.name: p.safe for p in self.params}

    def check(self, values: Mapping[str, object], *, partial: bool = False) -> Values:
        """Validated values (every knob present unless ``partial``)."""
        out = {name: self.param(name).check(v, self.name) for name, v in values.items()}
        missing = [p.name for p in self.params if p.name not in out]
        if missing and not partial:
            raise ValueError(f"tuning {self.name}: missing {', '.join(missing)}")
        return out

    def fallbacks(self, values: Values) -> list[Values]:
        """``values``, then the same with each vector knob narrowed step by step, then the safe
        values: the order in which a failing choice is replaced."""
        safe = self.safe()
        out = [dict(values)]
        for p in self.params:
            if p.vector:
                for v in p.narrower(values[p.name]):
                    out.append({**out[-1], p.name: v})
        if safe in out:
            return out[:out.index(safe) + 1]   # the safe values end the chain
        return out + [safe]


@functools.lru_cache(maxsize=4)
def standard_heightmap(size: int):
    """The smoke and tuning input: the generated canyon (``size`` x ``size``, 30 m cells), made
    once per process (its arrays are read-only, so families and candidates share it)."""
    from ..heightmap import Heightmap
    from ..synthetic import canyon_crater
    return Heightmap.from_array(canyon_crater(size), cellsize=30.0)


_REGISTRY: dict[str, Family] = {}


def register(family: Family) -> Family:
    """Declare a family's knobs (once, at the import of the module that launches its kernels)."""
    _REGISTRY[family.name] = family
    return family


def families() -> dict[str, Family]:
    """Every registered family, by name (imports the family modules)."""
    for module in FAMILY_MODULES:
        importlib.import_module(module)
    return dict(_REGISTRY)


def family(name: str) -> Family:
    fams = families()
    if name not in fams:
        raise ValueError(f"unknown kernel family {name!r}; expected one of {', '.join(fams)}")
    return fams[name]
