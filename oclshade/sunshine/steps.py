"""Time steps of a sunshine period: where the sun is sampled and how long each sample counts.

The period [start, end) is cut into steps of ``step`` from ``start`` on, the
last one shorter when ``step`` does not divide the period.  Each step is
represented by the sun at its midpoint (the midpoint rule: its error in the
hours of a cell is of second order in the step, against first order for a
sample at the step's start) and weighs the step's length in whole seconds.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone

import numpy as np

_UNITS = {"s": 1, "sec": 1, "min": 60, "h": 3600, "d": 86400}
_STEP = re.compile(r"\s*(\d+)\s*([a-z]+)\s*")


def parse_step(text: str) -> timedelta:
    """A step such as ``10min``, ``30s``, ``1h`` or ``1d`` (a positive whole number and a unit)."""
    match = _STEP.fullmatch(text.lower())
    if match is None or match.group(2) not in _UNITS or int(match.group(1)) == 0:
        raise ValueError(f"step must be a positive whole number with a unit s, min, h or d (e.g. 10min), "
                         f"got {text!r}")
    return timedelta(seconds=int(match.group(1)) * _UNITS[match.group(2)])


@dataclass(frozen=True)
class TimeSteps:
    """The steps of a period: ``times[k]`` the midpoint of step k (UTC), ``seconds[k]`` its
    length in seconds (int64)."""

    times: list[datetime]
    seconds: np.ndarray


def time_steps(start: datetime, end: datetime, step: timedelta) -> TimeSteps:
    """The steps of [start, end): lengths ``step`` (the last one shorter when the period is not a
    multiple of it), each sampled at its midpoint.  start and end are timezone-aware, end after
    start, and the period and the step whole numbers of seconds.  Durations are elapsed time
    (in UTC): a daylight-saving change inside the period neither adds nor drops a step."""
    for name, value in (("start", start), ("end", end)):
        if not isinstance(value, datetime) or value.utcoffset() is None:
            raise ValueError(f"{name} must be a timezone-aware datetime, got {value!r}")
    if not isinstance(step, timedelta) or step <= timedelta(0) or step % timedelta(seconds=1):
        raise ValueError(f"step must be a positive whole number of seconds, got {step!r}")
    start, end = start.astimezone(timezone.utc), end.astimezone(timezone.utc)   # not wall-clock arithmetic
    period = end - start
    if period <= timedelta(0):
        raise ValueError(f"end must be after start, got start {start.isoformat()} and end {end.isoformat()}")
    if period % timedelta(seconds=1):
        raise ValueError(f"end - start must be a whole number of seconds, got {period}")
    total, size = int(period.total_seconds()), int(step.total_seconds())
    bounds = np.append(np.arange(0, total, size, dtype=np.int64), total)
    seconds = np.diff(bounds)
    times = [start + timedelta(seconds=float(b) + s / 2) for b, s in zip(bounds[:-1], seconds)]
    return TimeSteps(times, seconds)
