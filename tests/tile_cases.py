"""A map on which a window's own cell coordinates flipped a cell (shared by the tile and C host tests).

Before the kernels took the window's origin (kernels/shadow.cl ``origin``), a window formed its
cells' coordinates from its own first cell; on this map, embedded at row and column offset 3000
of a nodata map and tiled in tiles of 11 for the sun :data:`FLIP_SUN`, one cell differed from the
whole map's single-shot mask (docs/scale.md "Exactness").
"""
from __future__ import annotations

import numpy as np

from oclshade import Sun

FLIP_SUN = Sun(311.09309922483726, 5.0)
FLIP_OFFSET = (3000, 3000)
FLIP_TILE = 11


def flipped_map() -> np.ndarray:
    """The 39th map of the random search that found the flip (numpy default_rng(1); rows and
    columns in [20, 100); heights of every third map round(N(0, 2) * 4) / 4 on 1 m cells):
    36 x 73 quarter-metre heights."""
    rng = np.random.default_rng(1)
    for k in range(39):
        n, m = int(rng.integers(20, 100)), int(rng.integers(20, 100))
        h = [lambda: rng.integers(0, 6, (n, m)).astype(float), lambda: rng.normal(0, 3, (n, m)),
             lambda: np.round(rng.normal(0, 2, (n, m)) * 4) / 4][k % 3]()
        rng.uniform(0, 360), rng.choice([5.0, 20.0, 45.0]), rng.integers(3, 60)   # that map's sun and tile
    return h
