"""``oclshade tune``: measure each family's knobs on this device and write the user entry.

Per family, a coordinate search from the current decision (rule or entry):
each knob in turn takes each legal value with the others fixed (the safe
values timed alongside), the candidates timed in rotation (minimum of 3-5
rounds after a warm-up that includes the builds), and the fastest is kept;
``--quick`` makes one pass on small workloads, the full tuner up to two
passes on larger ones.  Every
variant other than the safe one is probed in a child process before it runs
here (:mod:`.probe`), so a variant that crashes the compiler is skipped, not
fatal.  The safe values are measured too: the entry records how much the
chosen values gain over them.
"""
from __future__ import annotations

import time
from typing import Callable

from ..runtime import Runtime
from . import clear, probed, settings, store
from .device import DeviceKey
from .params import Family, Values

Report = Callable[[str], None]


def time_in_rotation(runtime: Runtime, fam: Family, candidates: list[Values], quick: bool,
                     reps: int) -> list[float]:
    """Minimum wall time (ms) of the family's workload per candidate, the candidates timed in
    rotation (``reps`` rounds after a warm-up that includes the builds), so that a machine
    slowing down or speeding up during the search hits them all alike."""
    runs = [fam.workload(runtime, values, quick) for values in candidates]
    for run in runs:
        run()
        runtime.queue.finish()
    best = [float("inf")] * len(runs)
    for _ in range(reps):
        for i, run in enumerate(runs):
            t0 = time.perf_counter()
            run()
            runtime.queue.finish()
            best[i] = min(best[i], 1e3 * (time.perf_counter() - t0))
    return best


def tune_family(runtime: Runtime, fam: Family, start: Values, *, quick: bool, report: Report) -> tuple[Values, dict]:
    """The fastest values found from ``start``, and what was measured."""
    key = DeviceKey.of(runtime.device)
    reps = 3 if quick else 5
    trials: dict[str, float | str] = {}

    def usable(values: Values) -> bool:
        notes: list[str] = []
        if probed(fam, runtime, key, values, notes):
            return True
        trials[store.values_id(values)] = notes[-1] if notes else "failed"
        report(f"  {fam.name} {store.values_id(values)}: skipped ({trials[store.values_id(values)]})")
        return False

    best = dict(start)
    for _ in range(1 if quick else 2):
        changed = False
        for p in (p for p in fam.params if p.tuned):
            cands = [c for c in ({**best, p.name: v} for v in p.values) if usable(c)]
            if fam.safe() not in cands:
                cands.append(fam.safe())
            times = time_in_rotation(runtime, fam, cands, quick, reps)
            for c, ms in zip(cands, times):
                trials[store.values_id(c)] = min(ms, trials.get(store.values_id(c), float("inf")))
                report(f"  {fam.name} {store.values_id(c)}: {ms:.1f} ms")
            winner = cands[times.index(min(times))]
            changed |= winner != best
            best = winner
        if not changed:
            break
    best_ms, safe_ms = trials[store.values_id(best)], trials[store.values_id(fam.safe())]
    measured = {"best_ms": round(best_ms, 3), "safe_ms": round(safe_ms, 3), "quick": quick, "reps": reps,
                "trials_ms": {k: (round(v, 3) if isinstance(v, float) else v) for k, v in trials.items()}}
    return best, measured


def tune(runtime: Runtime, families: list[Family], *, quick: bool, report: Report) -> dict[str, tuple[Values, dict]]:
    """Tune each family and write the user entry; returns {family: (values, measured)}."""
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
