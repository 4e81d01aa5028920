"""``oclshade tune``: measure each family's knobs on this device and write the user entry.

Per family, a coordinate search from the current decision (rule or entry):
each knob in turn takes each legal value with the others fixed, and keeps
the fastest (minimum wall time of ``reps`` runs of the family's workload
after a warm-up that includes the build); ``--quick`` makes one pass on
small workloads, the full tuner two passes on headline-sized ones.  Every
variant other than the safe one is probed in a child process before it runs
here (:mod:`.probe`), so a variant that crashes the compiler is skipped, not
fatal.  The safe values are measured too: the entry records how much the
chosen values gain over them.
"""
from __future__ import annotations

import time
from typing import Callable

from ..runtime import Runtime
from . import store
from .device import DeviceKey
from .params import Family, Values

Report = Callable[[str], None]


def time_values(runtime: Runtime, fam: Family, values: Values, quick: bool, reps: int) -> float:
    """Minimum wall time (ms) of the family's workload with these values (first run excluded)."""
    run = fam.workload(runtime, values, quick)
    run()
    runtime.queue.finish()
    best = float("inf")
    for _ in range(reps):
        t0 = time.perf_counter()
        run()
        runtime.queue.finish()
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best


def tune_family(runtime: Runtime, fam: Family, start: Values, *, quick: bool, report: Report) -> tuple[Values, dict]:
    """The fastest values found from ``start``, and what was measured."""
    from . import _probed   # the package's probe-and-remember step

    key = DeviceKey.of(runtime.device)
    reps = 2 if quick else 3
    trials: dict[str, float | str] = {}

    def measure(values: Values) -> float:
        vid = store.values_id(values)
        if vid not in trials:
            notes: list[str] = []
            if not _probed(fam, runtime, key, values, notes):
                trials[vid] = notes[-1] if notes else "failed"
                report(f"  {fam.name} {vid}: skipped ({trials[vid]})")
            else:
                trials[vid] = time_values(runtime, fam, values, quick, reps)
                report(f"  {fam.name} {vid}: {trials[vid]:.1f} ms")
        result = trials[vid]
        return result if isinstance(result, float) else float("inf")

    safe_ms = measure(fam.safe())
    best, best_ms = dict(start), measure(start)
    for _ in range(1 if quick else 2):
        improved = False
        for p in fam.params:
            for v in p.values:
                cand = {**best, p.name: v}
                ms = measure(cand)
                if ms < best_ms:
                    best, best_ms, improved = cand, ms, True
        if not improved:
            break
    if best_ms == float("inf"):
        best, best_ms = fam.safe(), safe_ms
    measured = {"best_ms": round(best_ms, 3), "safe_ms": round(safe_ms, 3), "quick": quick,
                "trials_ms": {k: (round(v, 3) if isinstance(v, float) else v) for k, v in trials.items()}}
    return best, measured


def tune(runtime: Runtime, families: list[Family], *, quick: bool, report: Report) -> dict[str, tuple[Values, dict]]:
    """Tune each family and write the user entry; returns {family: (values, measured)}."""
    from . import clear, settings

    key = DeviceKey.of(runtime.device)
    out = {}
    for fam in families:
        start = settings(runtime, fam.name).values
        report(f"tuning {fam.name} on {runtime.label} (start {store.values_id(start)})")
        values, measured = tune_family(runtime, fam, start, quick=quick, report=report)
        store.save_user_values(key, fam, values, measured)
        out[fam.name] = (values, measured)
    clear()
    return out
