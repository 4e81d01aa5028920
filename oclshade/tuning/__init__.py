"""Per-device tuning: which knob values (:mod:`.params`) a device gets, and why.

Lookup, per kernel family, first that answers:

1. the user entry for this device and these kernels (``oclshade tune``);
2. the database shipped with the package (``devices.json``: devices we measured);
3. the rule from device properties (:mod:`.rules`);
4. the safe values (the scalar kernels, which build and run everywhere).

A choice other than the safe values is then probed once per device and
kernel version in a child process (:mod:`.probe`): if it fails to build or
run (crash, hang, error) the next narrower variant is tried, down to the
safe values, and the outcome is remembered.  Results never depend on the
knobs; only speed does.

>>> from oclshade.tuning import settings
>>> settings(runtime, "shadow").values      # {'lanes': 8, 'run': 1024}
"""
from __future__ import annotations

import os
import sys
import threading
from dataclasses import dataclass, field

from ..runtime import Runtime, get_runtime
from .device import DeviceKey
from .params import (OWN_BUILTINS, OWN_BUILTINS_WHERE_CALLED, Family, Param, Values, families, family, register,
                     standard_heightmap)
from .probe import CHILD_ENV, UNCHECKED, run_probe
from .rules import rule_values
from . import store

__all__ = ["OWN_BUILTINS", "OWN_BUILTINS_WHERE_CALLED", "Decision", "DeviceKey", "Family", "Param", "Values", "families",
           "family", "register", "settings", "decide", "clear", "standard_heightmap"]

NO_PROBE_ENV = "OCLSHADE_NO_PROBE"


@dataclass(frozen=True)
class Decision:
    family: str
    values: Values
    source: str                     # "user", "shipped", "rule" or "safe"
    notes: tuple[str, ...] = field(default=())   # probes that failed, stale entries, ...

    def describe(self) -> str:
        vals = ", ".join(f"{k}={v}" for k, v in self.values.items())
        extra = f" ({'; '.join(self.notes)})" if self.notes else ""
        return f"{self.family}: {vals} [{self.source}]{extra}"


_decisions: dict[tuple[int, str], Decision] = {}
_lock = threading.Lock()


def _candidates(fam: Family, runtime: Runtime, key: DeviceKey) -> tuple[Values, str, list[str]]:
    notes: list[str] = []
    rule = rule_values(fam, runtime.device)   # also for knobs an entry does not have
    user = store.user_values(key, fam)
    if user is not None:
        return {**rule, **user}, "user", notes
    if store.read_user(key).get("families", {}).get(fam.name):
        notes.append("user entry is for older kernels: re-run 'oclshade tune'")
    shipped = store.shipped_values(key, fam)
    if shipped is not None:
        values, digest = shipped
        if digest != store.kernel_digest(fam):
            notes.append(f"measured with kernels {digest}")
        return {**rule, **values}, "shipped", notes
    return rule, "rule", notes


def probed(fam: Family, runtime: Runtime, key: DeviceKey, values: Values, notes: list[str]) -> bool:
    """Whether ``values`` build and run on the device (probing them if not known yet)."""
    if values == fam.safe() or os.environ.get(CHILD_ENV) or os.environ.get(NO_PROBE_ENV) == "1":
        return True
    outcome = store.probe_record(key, fam, values)
    if outcome is None:
        runtime.first_build_notice()
        outcome = run_probe(runtime, fam.name, values)
        if outcome.startswith(UNCHECKED):     # not a verdict: this run falls back, the next probes again
            print(f"oclshade: {fam.name} variant {store.values_id(values)} could not be checked on "
                  f"{runtime.label} ({outcome}); falling back for this run", file=sys.stderr)
        else:
            store.save_probe(key, fam, values, outcome)
            if outcome != "ok":
                print(f"oclshade: {fam.name} variant {store.values_id(values)} does not work on "
                      f"{runtime.label}, falling back ({outcome})", file=sys.stderr)
    if outcome != "ok":
        notes.append(f"{store.values_id(values)} {outcome}")
    return outcome == "ok"


def decide(runtime: Runtime, fam: Family) -> Decision:
    """The values of ``fam`` on ``runtime``'s device, probed (uncached; see :func:`settings`)."""
    key = DeviceKey.of(runtime.device)
    values, source, notes = _candidates(fam, runtime, key)
    # the chain ends with the safe values, which need no probe
    chosen = next(c for c in fam.fallbacks(values) if probed(fam, runtime, key, c, notes))
    if chosen != values:
        source = "safe" if chosen == fam.safe() else source + ", narrowed"
    return Decision(fam.name, chosen, source, tuple(notes))


def settings(device: Runtime | str | int | None, family_name: str) -> Decision:
    """The tuning decision for a family on a device (decided once per process and device)."""
    runtime = get_runtime(device)
    k = (runtime.device.int_ptr, family_name)
    with _lock:
        hit = _decisions.get(k)
    if hit is not None:
        return hit
    decision = decide(runtime, family(family_name))
    with _lock:
        return _decisions.setdefault(k, decision)


def clear() -> None:
    """Forget this process's decisions (after ``oclshade tune`` wrote a new entry, in tests)."""
    with _lock:
        _decisions.clear()
