"""Wall-clock timing of one benchmark case: a warm-up, then repetitions."""
from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import Callable


@dataclass(frozen=True)
class Timing:
    """Seconds of each timed repetition (the warm-up, which builds the programs, is not among them)."""

    seconds: tuple[float, ...]
    warm_up_s: float

    @property
    def min_s(self) -> float:
        return min(self.seconds)

    @property
    def median_s(self) -> float:
        return statistics.median(self.seconds)


def time_case(run: Callable[[], None], reps: int, max_seconds: float) -> Timing:
    """Run ``run`` (which must wait for the device) once untimed, then ``reps`` times timed;
    stop repeating early once the timed runs add up to ``max_seconds`` (at least one runs),
    so that a very slow case on a slow device does not stall the whole benchmark."""
    if reps < 1:
        raise ValueError(f"reps must be at least 1, got {reps}")
    t0 = time.perf_counter()
    run()
    warm = time.perf_counter() - t0
    samples: list[float] = []
    while len(samples) < reps and (not samples or sum(samples) < max_seconds):
        t0 = time.perf_counter()
        run()
        samples.append(time.perf_counter() - t0)
    return Timing(tuple(samples), warm)
