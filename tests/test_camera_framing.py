"""Automatic framing (camera.frame_heightmap): the whole map with crop 0, a fuller frame with
the default crop, at most that fraction of the map left out, the camera clear of the terrain."""
from __future__ import annotations

import numpy as np
import pytest

from oclshade.camera import DEFAULT_CROP, frame_heightmap
from oclshade.heightmap import Heightmap
from oclshade.synthetic import canyon_crater
from oclshade.terrain import Heightfield, TerrainRenderer

VIEWS = [(200.0, 30.0), (0.0, 30.0), (45.0, 50.0), (135.0, 45.0), (300.0, 70.0), (30.0, 89.0), (90.0, 15.0)]


@pytest.fixture(scope="module")
def terrain():
    hm = Heightmap.from_array(canyon_crater(96, 128, seed=5), (30.0, 25.0))
    return hm, TerrainRenderer(Heightfield(hm))


def in_frame(cam, hm) -> np.ndarray:
    """Per finite sample: inside the frame (in front of a pinhole), from the camera's matrices."""
    rows, cols = hm.shape
    i, j = np.mgrid[0:rows, 0:cols]
    z = hm.heights
    ok = np.isfinite(z)
    world = np.stack([j[ok] * hm.dx, -i[ok] * hm.dy, z[ok], np.ones(ok.sum())], -1)
    clip = world @ (cam.projection_matrix @ cam.view).T
    ndc = clip[:, :3] / clip[:, 3:]
    front = clip[:, 3] > 0
    return front & (np.abs(ndc[:, :2]) <= 1.0 + 1e-9).all(1) & (np.abs(ndc[:, 2]) <= 1.0)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
@pytest.mark.parametrize("az,el", VIEWS)
def test_crop_zero_shows_the_whole_map_tightly(terrain, projection, az, el):
    hm, _ = terrain
    cam = frame_heightmap(hm, 64, 36, az, el, projection=projection, crop=0.0)
    assert in_frame(cam, hm).all()                          # every sample between near and far, in the frame
    rows, cols = hm.shape
    i, j = np.mgrid[0:rows, 0:cols]
    world = np.stack([j.ravel() * hm.dx, -i.ravel() * hm.dy, hm.heights.ravel(), np.ones(i.size)], -1)
    clip = world @ (cam.projection_matrix @ cam.view).T
    ndc = clip[:, :2] / clip[:, 3:]
    assert np.abs(ndc).max() > 0.9                           # tight: the map reaches an edge of the frame


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
@pytest.mark.parametrize("az,el", VIEWS)
def test_default_crop_fills_more_and_keeps_most_of_the_map(terrain, projection, az, el):
    hm, renderer = terrain
    whole = frame_heightmap(hm, 64, 36, az, el, projection=projection, crop=0.0)
    cam = frame_heightmap(hm, 64, 36, az, el, projection=projection)
    kept = in_frame(cam, hm).mean()
    assert kept >= 1.0 - DEFAULT_CROP - 0.02                 # the crop is checked on a lattice of samples
    covered, before = renderer.render(cam).hit.mean(), renderer.render(whole).hit.mean()
    assert covered >= before - 0.01
    rows, cols = hm.shape
    x, y, z = cam.position
    over_map = 0.0 <= x <= (cols - 1) * hm.dx and -(rows - 1) * hm.dy <= y <= 0.0
    if projection == "perspective":                          # clear of the terrain where it flies over it
        assert not over_map or z >= np.nanmax(hm.heights)


def test_the_default_view_fills_most_of_the_frame(terrain):
    hm, renderer = terrain
    for az, el in [(200.0, 30.0), (45.0, 50.0), (135.0, 45.0)]:
        whole = renderer.render(frame_heightmap(hm, 96, 54, az, el, crop=0.0)).hit.mean()
        full = renderer.render(frame_heightmap(hm, 96, 54, az, el)).hit.mean()
        assert full > 0.6 and full > 1.5 * whole, (az, el, whole, full)


def test_maps_with_holes_and_degenerate_maps():
    h = canyon_crater(40, 40, seed=1, relief=60.0).astype(float)
    h[:, :25] = np.nan                                        # the west part is a hole
    hm = Heightmap.from_array(h, 10.0)
    cam = frame_heightmap(hm, 48, 27, 180.0, 40.0)
    r = TerrainRenderer(Heightfield(hm))
    assert r.render(cam).hit.mean() > 0.3                   # framed on the finite part
    for heights in (np.full((5, 5), np.nan), np.zeros((1, 1)), np.zeros((1, 7))):
        cam = frame_heightmap(Heightmap.from_array(heights, 1.0), 16, 9)
        assert np.all(np.isfinite(cam.position)) and cam.near < cam.far


def test_bad_arguments_are_named(terrain):
    hm, _ = terrain
    with pytest.raises(ValueError, match=r"crop must be in \[0, 1\)"):
        frame_heightmap(hm, crop=1.0)
    with pytest.raises(ValueError, match="elevation"):
        frame_heightmap(hm, elevation=91.0)
    with pytest.raises(ValueError, match="projection"):
        frame_heightmap(hm, projection="fisheye")
