"""Far-field tile certificates (kernels/shadow.cl shadow_certify): sound bounds, same masks, less work."""
from __future__ import annotations

import numpy as np
import pytest

from oclshade import ShadowCaster, Sun
from oclshade import reference as ref
from oclshade.heightmap import Heightmap
from oclshade.shadows import CERT_K

D0 = 2  # OCLS_CERT_D0: threshold k is at 2^k * D0 major-axis cells


def bilinear(h: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """float64 bilinear surface at points inside the map (NaN in hole patches)."""
    rows, cols = h.shape
    c = np.clip(np.floor(x).astype(int), 0, cols - 2)
    r = np.clip(np.floor(y).astype(int), 0, rows - 2)
    fx, fy = x - c, y - r
    top = h[r, c] * (1 - fx) + h[r, c + 1] * fx
    bottom = h[r + 1, c] * (1 - fx) + h[r + 1, c + 1] * fx
    return top * (1 - fy) + bottom * fy


def sampled_bounds(hm: Heightmap, sun: Sun, tile_size: int, step: float = 0.2) -> np.ndarray:
    """Lower estimates of what each certificate must bound: max of S - w t sampled every
    ``step`` major-axis cells along the rays of the tile's cells, per threshold."""
    h = hm.relative32.astype(np.float64)
    rows, cols = h.shape
    ux, uy, w = sun.ray(hm.dx, hm.dy)
    major = max(abs(ux), abs(uy))
    dist = np.arange(D0, rows + cols + 2, step)              # major-axis cells
    t = dist / major
    out = np.full((-(-rows // tile_size), -(-cols // tile_size), CERT_K), -np.inf)
    for i in range(rows):
        for j in range(cols):
            x, y = j + ux * t, i + uy * t
            inside = (x >= 0) & (x <= cols - 1) & (y >= 0) & (y <= rows - 1)
            v = bilinear(h, x[inside], y[inside]) - w * t[inside]
            d = dist[inside]
            for k in range(CERT_K):
                sel = v[d >= D0 * 2 ** k]
                sel = sel[np.isfinite(sel)]
                if sel.size:
                    tile = out[i // tile_size, j // tile_size]
                    tile[k] = max(tile[k], sel.max())
    return out


@pytest.mark.parametrize("az,alt,cell,tile_size", [(37.0, 20.0, (30.0, 30.0), 16), (200.0, 8.0, (2.0, 0.5), 32),
                                                   (90.0, 35.0, (1.0, 1.0), 64), (315.0, 3.0, (25.0, 40.0), 16)])
def test_certificates_bound_the_surface(az: float, alt: float, cell: tuple[float, float], tile_size: int) -> None:
    rng = np.random.default_rng(int(az))
    y, x = np.mgrid[0:41, 0:53]
    h = 300.0 * np.sin(x / 6.0) * np.cos(y / 9.0) + 40.0 * rng.random(x.shape)
    h[rng.random(h.shape) < 0.02] = np.nan
    hm = Heightmap.from_array(h, cell)
    sun = Sun(az, alt)
    cert = ShadowCaster(hm, cache=False, knobs={"cert_tile": tile_size}).tile_certificates(sun)
    need = sampled_bounds(hm, sun, tile_size)
    assert np.all(cert[..., 1:] <= cert[..., :-1]), "suffix maxima must not grow with the threshold"
    assert np.all(cert >= need), f"certificate below the sampled surface by {np.max(need - cert)}"
    # and they certify something: some cells clear the first bound
    hr = hm.relative32
    tiles = cert[np.arange(h.shape[0])[:, None] // tile_size, np.arange(h.shape[1])[None, :] // tile_size]
    assert np.any(hr > tiles[..., -1])


def test_same_masks_fewer_steps_on_real_and_synthetic_terrain() -> None:
    from matplotlib import cbook
    from oclshade.synthetic import canyon_crater

    data = cbook.get_sample_data("jacksboro_fault_dem.npz")
    elev = (data if hasattr(data, "files") else np.load(data))["elevation"].astype(np.float64)
    for hm in (Heightmap.from_array(elev, (90.0, 90.0)),
               Heightmap.from_array(canyon_crater(192, 192, seed=1, relief=1500.0), (10.0, 10.0))):
        with_c = ShadowCaster(hm, cache=False, analyse=False)
        without = ShadowCaster(hm, cache=False, analyse=False, certificates=False)
        for az, alt in [(37.0, 20.0), (135.0, 5.0), (270.0, 45.0)]:
            sun = Sun(az, alt)
            for method in ("exact", "maxmip"):
                got = with_c.cast(sun, method).mask
                assert np.array_equal(got, without.cast(sun, method).mask), (hm.shape, sun, method)
            expected = ref.cast_shadows(hm, sun)
            ties = expected.ties(ref.tie_tolerance(hm, sun))
            assert not np.any((got != expected.mask) & ~ties)
            assert with_c.step_counts(sun).sum() < without.step_counts(sun).sum()
