"""The pilot: past the reach of the knob ``sweep_cells``, whether the sweep or the walk is the
faster on this map, timed on bands of its rows (the knob ``sweep_far`` = 1).

Within a search radius the sweep's cost grows linearly with the patch columns and rows a ray
crosses, whatever the ground; the walk's depends on how well the extrema pyramid prunes it: well
on rough ground, badly on smooth ground.  So past the knob's reach the faster of the two depends
on the map as well as on the device (docs/solar.md, "The pilot").  Both give the same angles bit
for bit (kernels/horizon.cl, "The sweep"), so the choice changes the time only.

At the first azimuth past the knob, both run on about a sixteenth of the rows, in bands spread
evenly down the map (one band across the middle misjudged an island: on SRTM N22W160 the walk
there cost half its mean over the map), after a one-work-group-row launch of each, which takes
their builds out of the timing; twice each in turn, the faster of each pair kept.  Every azimuth
past the knob then takes the faster of the two there: the times vary 2-3x across the azimuths
(axis rays are the cheapest for both) but their ratio far less, and it stays on one side of 1
wherever the choice matters (walk / sweep at 0, 22.5 and 45 degrees, Xeon model 207: 0.80-1.12
on SRTM N22W160 within 250 cells, 0.58-0.70 within 500; 1.32-1.95 on S16E166; 1.21-3.86 on the
canyon; docs/solar.md, "The pilot").  A launch's fixed cost adds to both alike, so it cannot
turn the order.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

#: the bands: together about this share of the rows, each whole work-group rows
ROW_SHARE = 16
#: the most bands, evenly spaced
BANDS = 8
#: maps of fewer cells or rows take the walk past the knob without a pilot (seconds at most are
#: at stake; and a band needs whole work-group rows, at most 16)
MIN_CELLS = 1 << 18
MIN_ROWS = 64
#: each kernel's runs on the bands (alternating); the fastest counts
RUNS = 2

#: launch(first_row, rows): enqueue the kernel on that band of rows
Launch = Callable[[int, int], None]


@dataclass(frozen=True)
class Pilot:
    """What the pilot measured: both kernels' seconds on the bands at one azimuth's crossings."""

    crossings: float
    sweep_seconds: float
    walk_seconds: float

    @property
    def sweeps(self) -> bool:
        """Whether the rays past the knob take the sweep: it was no slower than the walk."""
        return self.sweep_seconds <= self.walk_seconds


def bands(rows: int, group_rows: int) -> list[tuple[int, int]]:
    """(first row, rows) of each of the pilot's bands: whole work-group rows, each centred in its
    share of the map (none where it has fewer rows than a work-group)."""
    blocks = rows // group_rows                  # whole work-group rows in the map
    count = min(BANDS, blocks)
    size = max(1, blocks // ROW_SHARE // max(count, 1))
    centres = [(2 * k + 1) * blocks // (2 * count) for k in range(count)]
    return [(max(0, centre - size // 2) * group_rows, size * group_rows) for centre in centres]


def measure(sweep: Launch, walk: Launch, finish: Callable[[], None], spans: list[tuple[int, int]],
            group_rows: int, crossings: float) -> Pilot:
    """Time ``sweep`` and ``walk`` on the bands ``spans`` (``finish`` waits for the queue)."""
    def seconds(launch: Launch) -> float:
        finish()
        start = time.perf_counter()
        for first_row, rows in spans:
            launch(first_row, rows)
        finish()
        return time.perf_counter() - start

    sweep(spans[0][0], group_rows)        # the builds (PoCL compiles per work-group size at the first launch)
    walk(spans[0][0], group_rows)
    best = {sweep: float("inf"), walk: float("inf")}
    for _ in range(RUNS):
        for launch in best:
            best[launch] = min(best[launch], seconds(launch))
    return Pilot(crossings, best[sweep], best[walk])
