"""Exact halos: how far beyond a tile, toward the sun, terrain can still shade the tile's cells.

The ray of a cell of height z0 rises as z0 + w t (w = tan elevation, t the
horizontal distance); the surface under it never exceeds the largest height
ahead.  So once z0 + w t is above every height the ray can still pass over, the
rest of the ray is lit: a shadow reaches at most (max height ahead - min height
of the tile) / w from its caster.  :func:`reach` makes that bound tight with the
coarse :class:`~oclshade.tiles.relief.ReliefGrid`: it marches the box swept by
all the tile's rays one block at a time along the sun's major axis and keeps
the last segment [ta, tb] where the blocks under the box rise above the lowest
ray there (tile min + w ta); beyond it no ray of the tile can be shaded.
The halo on each axis is then |u| tb cells (u the ray's cells per metre on that
axis), plus 2 cells (the patch beyond the last point and the float32 rounding of
the kernel's ray positions), on the sun's side, and 1 cell on the other sides
(the self-shadow output's central differences).  Heights are compared with a
margin of 1e-4 x the map's relief + 1 mm, far above the kernel's float32
rounding of heights relative to the map's midpoint.

A sun at or just above the horizon (w rounded to 0, or relief / w beyond the map)
gets the whole map in its direction: the halo is capped by the map's edge.
Suns at or below the horizon, or at the zenith, trace nothing: a 1-cell ring.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..sun import Sun
from .relief import ReliefGrid

HEIGHT_MARGIN_RELATIVE = 1e-4   # of the map's relief
HEIGHT_MARGIN_ABSOLUTE = 1e-3   # metres (or the heights' unit)
RAY_CELLS_MARGIN = 2            # cells beyond the last reachable point


@dataclass(frozen=True)
class Window:
    """Rows [r0, r1) and columns [c0, c1) of a map."""

    r0: int
    r1: int
    c0: int
    c1: int

    @property
    def shape(self) -> tuple[int, int]:
        return self.r1 - self.r0, self.c1 - self.c0

    @property
    def cells(self) -> int:
        return (self.r1 - self.r0) * (self.c1 - self.c0)

    def union(self, other: "Window") -> "Window":
        return Window(min(self.r0, other.r0), max(self.r1, other.r1), min(self.c0, other.c0), max(self.c1, other.c1))

    def inside(self, other: "Window") -> tuple[slice, slice]:
        """Where this window lies in ``other`` (which must contain it)."""
        return slice(self.r0 - other.r0, self.r1 - other.r0), slice(self.c0 - other.c0, self.c1 - other.c0)


def reach_distance(relief: ReliefGrid, tile: Window, sun: Sun, dx: float, dy: float) -> float:
    """The horizontal distance (metres) beyond which no ray of the tile's cells can be shaded:
    the end of the last marched segment that may still occlude (0: none; inf: to the map's edge
    for a sun whose ray does not rise in float32)."""
    if sun.below_horizon or sun.at_zenith:
        return 0.0
    zmin, _ = relief.region(tile.r0, tile.r1, tile.c0, tile.c1)
    lo, hi = relief.extrema
    if not math.isfinite(zmin):          # the tile has no data: nothing to shade
        return 0.0
    ux, uy, w = sun.ray(dx, dy)
    if w <= 0.0:
        return math.inf
    margin = HEIGHT_MARGIN_RELATIVE * (hi - lo) + HEIGHT_MARGIN_ABSOLUTE
    rows, cols = relief.shape
    step = relief.block / max(abs(ux), abs(uy))
    need = 0.0
    for k in range(1 << 30):
        ta, tb = k * step, (k + 1) * step
        if zmin + w * ta >= hi + margin:                  # above every height of the map
            break
        x_lo, x_hi = tile.c0 + min(ux * ta, ux * tb), tile.c1 - 1 + max(ux * ta, ux * tb)
        y_lo, y_hi = tile.r0 + min(uy * ta, uy * tb), tile.r1 - 1 + max(uy * ta, uy * tb)
        if x_hi < 0 or y_hi < 0 or x_lo > cols - 1 or y_lo > rows - 1:   # the rays have left the map
            break
        _, zmax = relief.region(math.floor(y_lo), math.floor(y_hi) + 2, math.floor(x_lo), math.floor(x_hi) + 2)
        if zmax + margin > zmin + w * ta:
            need = tb
    return need


def halo_window(relief: ReliefGrid, tile: Window, sun: Sun, dx: float, dy: float) -> Window:
    """The tile grown by its halo for ``sun`` (see the module docstring), clipped to the map."""
    rows, cols = relief.shape
    t = reach_distance(relief, tile, sun, dx, dy)
    ux, uy, _ = sun.ray(dx, dy) if t > 0.0 else (0.0, 0.0, 0.0)

    def ahead(u: float) -> int:
        if u == 0.0:
            return 1
        cells = abs(u) * t
        return rows + cols if not math.isfinite(cells) else math.ceil(cells) + RAY_CELLS_MARGIN

    west, east = (ahead(ux), 1) if ux < 0 else (1, ahead(ux))
    north, south = (ahead(uy), 1) if uy < 0 else (1, ahead(uy))
    return Window(max(tile.r0 - north, 0), min(tile.r1 + south, rows),
                  max(tile.c0 - west, 0), min(tile.c1 + east, cols))
