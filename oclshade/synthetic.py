"""Synthetic "canyon and crater" terrain (numpy only, deterministic per seed).

The terrain exercises what paper 000's min early exit is for: deep, narrow,
meandering canyons with steep walls and crater bowls inside raised rims, on a
rolling fBm base.  Used by the demo data, the tests and the benchmarks.

>>> dem = canyon_crater(512, seed=0)          # float32 (512, 512), 0 .. 1500 m
"""
from __future__ import annotations

import numpy as np


def _smooth_axis(grid: np.ndarray, n: int, axis: int) -> np.ndarray:
    """Resample ``grid`` along ``axis`` to n samples with smoothstep interpolation."""
    g = grid.shape[axis]
    pos = np.linspace(0.0, g - 1.0, n)
    i0 = np.minimum(pos.astype(np.int64), g - 2)
    t = pos - i0
    t = t * t * (3.0 - 2.0 * t)
    a = np.take(grid, i0, axis=axis)
    b = np.take(grid, i0 + 1, axis=axis)
    shape = [1, 1]
    shape[axis] = n
    t = t.reshape(shape)
    return a + (b - a) * t


def _fbm(rng: np.random.Generator, rows: int, cols: int, octaves: int = 7,
         base_cells: int = 3, gain: float = 0.5) -> np.ndarray:
    """Fractal sum of value-noise octaves, each twice the frequency of the last; range about [-1, 1]."""
    out = np.zeros((rows, cols), np.float64)
    amp, total = 1.0, 0.0
    cells = base_cells
    longest = max(rows, cols)
    for _ in range(octaves):
        gr = max(2, round(cells * rows / longest) + 1)
        gc = max(2, round(cells * cols / longest) + 1)
        grid = rng.uniform(-1.0, 1.0, (gr, gc))
        out += amp * _smooth_axis(_smooth_axis(grid, rows, 0), cols, 1)
        total += amp
        amp *= gain
        cells *= 2
        if cells > longest:
            break
    return out / total


def _canyons(rng: np.random.Generator, y: np.ndarray, x: np.ndarray, count: int) -> np.ndarray:
    """Depth (0 .. 1) of ``count`` meandering canyons with flat floors and steep walls."""
    depth = np.zeros(np.broadcast_shapes(y.shape, x.shape), np.float64)
    for k in range(count):
        theta = rng.uniform(0.0, np.pi) if k else rng.uniform(-0.3, 0.3)
        c, s = np.cos(theta), np.sin(theta)
        u = c * x + s * y            # across the canyon
        v = -s * x + c * y           # along the canyon
        centre = rng.uniform(-0.25, 0.25)
        phase = rng.uniform(0.0, 2.0 * np.pi, 3)
        amps = rng.uniform(0.05, 0.12), rng.uniform(0.02, 0.05), rng.uniform(0.005, 0.015)
        freqs = rng.uniform(1.0, 2.0), rng.uniform(3.0, 5.0), rng.uniform(9.0, 14.0)
        path = centre + sum(a * np.sin(2 * np.pi * f * v + p) for a, f, p in zip(amps, freqs, phase))
        slope = sum(a * 2 * np.pi * f * np.cos(2 * np.pi * f * v + p) for a, f, p in zip(amps, freqs, phase))
        dist = np.abs(u - path) / np.sqrt(1.0 + slope * slope)
        floor = rng.uniform(0.006, 0.015)
        wall = rng.uniform(0.012, 0.03)
        q = np.clip((dist - floor) / wall, 0.0, 1.0)
        profile = 1.0 - q * q * (3.0 - 2.0 * q)          # steep smoothstep walls
        profile = np.floor(profile * 4.0 + 0.6 * q) / 4.0 * 0.3 + 0.7 * profile  # terraced benches
        strength = (1.0 if k == 0 else rng.uniform(0.45, 0.8)) * np.clip(1.2 - 0.4 * np.abs(v), 0.5, 1.0)
        depth = np.maximum(depth, strength * profile)
    return depth


def _craters(rng: np.random.Generator, y: np.ndarray, x: np.ndarray, count: int,
             cell: float) -> np.ndarray:
    """Relative height (about -1 .. 0.25) of ``count`` craters: bowls inside raised rims, ejecta outside."""
    out = np.zeros((y.shape[0], x.shape[1]), np.float64)
    for _ in range(count):
        r = rng.uniform(0.03, 0.12)
        cy, cx = rng.uniform(-0.45, 0.45, 2)
        bowl, rim = 0.6 + 0.4 * r / 0.12, 0.25
        reach = 4.0 * r
        rows = np.nonzero(np.abs(y[:, 0] - cy) <= reach)[0]
        cols = np.nonzero(np.abs(x[0, :] - cx) <= reach)[0]
        if rows.size == 0 or cols.size == 0 or r < 2.0 * cell:
            continue
        r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
        d = np.hypot(y[r0:r1] - cy, x[:, c0:c1] - cx) / r
        inside = rim - (bowl + rim) * np.clip(1.0 - d * d, 0.0, 1.0) ** 1.5
        outside = rim * np.minimum(d, 4.0) ** -3 * np.clip(4.0 - d, 0.0, 1.0)
        out[r0:r1, c0:c1] += np.where(d < 1.0, inside, outside)
    return out


def canyon_crater(n_rows: int, n_cols: int | None = None, seed: int = 0,
                  relief: float = 1500.0) -> np.ndarray:
    """A (n_rows, n_cols) float32 terrain with heights in [0, relief] metres.

    Deep meandering canyons with steep, terraced walls, several craters (rims
    and bowls) and fBm hills; the same seed always gives the same array.  The
    features scale with the map, so a 512 and a 4096 map of one seed look alike.
    """
    n_cols = n_rows if n_cols is None else n_cols
    if int(n_rows) < 1 or int(n_cols) < 1:
        raise ValueError(f"terrain size must be at least 1 x 1, got {n_rows} x {n_cols}")
    if not np.isfinite(relief) or relief <= 0:
        raise ValueError(f"relief must be a positive number of metres, got {relief!r}")
    rows, cols = int(n_rows), int(n_cols)
    rng = np.random.default_rng(seed)
    longest = max(rows, cols)
    y = ((np.arange(rows) + 0.5 - rows / 2) / longest)[:, None]
    x = ((np.arange(cols) + 0.5 - cols / 2) / longest)[None, :]
    hills = 0.5 + 0.5 * _fbm(rng, rows, cols)
    detail = _fbm(rng, rows, cols, octaves=5, base_cells=24)
    canyon = _canyons(rng, y, x, count=3)
    crater = _craters(rng, y, x, count=7, cell=1.0 / longest)
    h = 0.55 * hills + 0.03 * detail - 0.55 * canyon + 0.4 * crater
    h -= h.min()
    top = h.max()
    if top > 0:
        h *= relief / top
    return h.astype(np.float32)
