"""The shadow family's ``images`` knob (oclshade/pyramid_images.py, -D OCLS_IMAGES): heights
and extrema pyramid read from OpenCL images give the buffers' outputs bit for bit, the atlas
holds the pyramid's texels, and a device that cannot hold the images falls back to buffers."""
from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from oclshade import ShadowCaster, Sun, pyramid_images, shadows
from oclshade.heightmap import Heightmap
from oclshade.horizon import Curvature
from test_shadows import azimuths, cell_sizes, elevations, terrains

METHODS = ("exact", "maxmip", "dda", "paper")


def casters(hm: Heightmap, **kw) -> tuple[ShadowCaster, ShadowCaster]:
    """(buffers, images) casters over the same map, one ray per work-item."""
    return tuple(ShadowCaster(hm, cache=False, analyse=False, knobs={"lanes": 0, "images": images}, **kw)
                 for images in (0, 1))


def assert_same_outputs(buffers: ShadowCaster, images: ShadowCaster, sun: Sun, methods=METHODS) -> None:
    assert images._features("exact", ("mask",)).imaged, "the device should hold these images"
    for method in methods:
        a, b = buffers.cast(sun, method, "all"), images.cast(sun, method, "all")
        assert np.array_equal(a.mask, b.mask), (method, sun, int((a.mask != b.mask).sum()))
        assert np.array_equal(a.self_shadow, b.self_shadow), (method, sun)
        assert np.array_equal(a.coefficient.view(np.uint32), b.coefficient.view(np.uint32)), (method, sun)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(h=terrains(), az=azimuths, alt=elevations, cell=cell_sizes, certificates=st.booleans(),
       curved=st.booleans())
def test_images_equal_buffers_on_random_maps(h, az, alt, cell, certificates, curved):
    hm = Heightmap.from_array(h, cell)
    buffers, images = casters(hm, certificates=certificates, curvature=Curvature() if curved else None)
    assert_same_outputs(buffers, images, Sun(az, alt))


def test_images_equal_buffers_on_a_real_dem_with_holes():
    from matplotlib import cbook

    data = cbook.get_sample_data("jacksboro_fault_dem.npz")
    elev = (data if hasattr(data, "files") else np.load(data))["elevation"].astype(np.float64)
    elev[100:130, 40:95] = np.nan
    elev[np.random.default_rng(7).random(elev.shape) < 0.01] = np.nan
    buffers, images = casters(Heightmap.from_array(elev, (90.0, 90.0)))
    shadowed = 0
    for az, alt in [(37.0, 20.0), (135.0, 5.0), (45.0, 10.0), (90.0, 3.0), (250.0, 1.0), (315.0, 60.0)]:
        assert_same_outputs(buffers, images, Sun(az, alt))
        shadowed += int((buffers.cast((az, alt)).mask == 1).sum())
    assert shadowed > 1000     # the suns cast shadows: the comparison is not of empty masks


def test_images_equal_buffers_in_a_window_of_a_larger_map():
    h = np.random.default_rng(3).normal(0.0, 4.0, (90, 140)).cumsum(axis=0)
    window = Heightmap.from_array(h[20:70, 30:120], 25.0)
    buffers, images = casters(window, origin=(20, 30))
    assert_same_outputs(buffers, images, Sun(200.0, 6.0), methods=("exact",))


def test_the_atlas_holds_the_pyramid_texels():
    h = np.random.default_rng(5).normal(size=(45, 77)).cumsum(axis=1)
    h[3:9, 10:14] = np.nan
    caster = ShadowCaster(Heightmap.from_array(h, 1.0), cache=False)
    pyr = caster.pyramid
    imgs = pyr.images()
    rows = pyramid_images.atlas_rows(pyr.shapes)
    atlas = np.empty((int(rows[-1]), pyr.shapes[0][1], imgs.channels), np.float32)
    cl.enqueue_copy(caster.runtime.queue, atlas, imgs.extrema, origin=(0, 0), region=atlas.shape[1::-1])
    for level, texels in enumerate(pyr.to_numpy(), start=1):
        r, c = texels.shape[:2]
        got = atlas[rows[level]:rows[level] + r, :c, :2]
        assert np.array_equal(got.view(np.uint32), texels.view(np.uint32)), level
    heights = np.empty(h.shape, np.float32)
    cl.enqueue_copy(caster.runtime.queue, heights, imgs.heights, origin=(0, 0), region=(h.shape[1], h.shape[0]))
    assert np.array_equal(heights.view(np.uint32), caster.heightmap.relative32.view(np.uint32))


def test_atlas_rows_stack_the_levels():
    assert pyramid_images.atlas_rows([(5, 8), (3, 4), (2, 2), (1, 1)]).tolist() == [-1, 0, 5, 8, 10, 11]


def test_what_a_device_cannot_hold_is_named():
    rt = ShadowCaster(Heightmap.from_array(np.zeros((4, 4)), 1.0), cache=False).runtime
    shapes = [(2, 2), (1, 1)]
    full = {cl.channel_order.R, cl.channel_order.RGBA}
    assert pyramid_images.images_unavailable(rt, (3, 3), shapes, full) is None
    assert "CL_R " in pyramid_images.images_unavailable(rt, (3, 3), shapes, {cl.channel_order.RGBA})
    assert "CL_RG or CL_RGBA" in pyramid_images.images_unavailable(rt, (3, 3), shapes, {cl.channel_order.R})
    wide = rt.device.image2d_max_width + 1
    reason = pyramid_images.images_unavailable(rt, (3, wide), [(2, wide // 2 + 1), (1, 1)], full)
    assert reason is not None and "heights" in reason and str(wide) in reason


def test_a_device_without_images_falls_back_to_buffers(monkeypatch):
    h = np.random.default_rng(9).normal(size=(40, 60)).cumsum(axis=1) * 3.0
    hm = Heightmap.from_array(h, 10.0)
    want = ShadowCaster(hm, cache=False, knobs={"lanes": 0, "images": 0}).cast((300.0, 4.0), outputs="all")
    monkeypatch.setattr(pyramid_images, "images_unavailable", lambda *a, **k: "no images here")
    caster = ShadowCaster(hm, cache=False, knobs={"lanes": 0, "images": 1})
    assert caster.pyramid.images() is None
    assert not caster._features("exact", ("mask",)).imaged
    got = caster.cast((300.0, 4.0), outputs="all")
    assert np.array_equal(got.mask, want.mask) and 0.05 < (want.mask == 1).mean() < 0.95
    assert np.array_equal(got.coefficient, want.coefficient)


def test_packets_read_buffers_whatever_the_images_knob():
    packed = shadows.ShadowFeatures("exact", lanes=8, images=True)
    assert not packed.imaged and not packed.defines()["OCLS_IMAGES"]
    assert shadows.ShadowFeatures("exact", lanes=0, images=True).defines()["OCLS_IMAGES"]
    assert shadows.ShadowFeatures("dda", lanes=8, images=True).imaged   # no packet kernel for dda


def test_the_kernel_refuses_images_with_packets():
    rt = ShadowCaster(Heightmap.from_array(np.zeros((4, 4)), 1.0), cache=False).runtime
    with pytest.raises(Exception, match="OCLS_IMAGES"):
        rt.kernel("shadow.cl", "shadow_cells_packet", {"OCLS_PACKET": 64, "OCLS_LANES": 8, "OCLS_IMAGES": True})
