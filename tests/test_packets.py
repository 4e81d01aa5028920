"""Ray packets (kernels/shadow.cl shadow_cells_packet): the one-ray-per-work-item kernel's
outputs, bit for bit, on every map, sun, method and output set."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from oclshade import ShadowCaster, Sun
from oclshade import shadows
from oclshade.heightmap import Heightmap
from test_shadows import azimuths, cell_sizes, elevations, terrains


@pytest.fixture
def short_runs(monkeypatch):
    """Runs of 16 cells, so small maps have several runs per row and a partial last one
    (the kernel is built with the host's run length, OCLS_PACKET)."""
    monkeypatch.setattr(shadows, "PACKET_RUN", 16)


def assert_same_outputs(hm: Heightmap, sun: Sun, certificates: bool = True) -> None:
    packed = ShadowCaster(hm, cache=False, analyse=False, certificates=certificates, packets=True)
    single = ShadowCaster(hm, cache=False, analyse=False, certificates=certificates, packets=False)
    for method in shadows.PACKET_METHODS:
        a = packed.cast(sun, method, "all")
        b = single.cast(sun, method, "all")
        assert np.array_equal(a.mask, b.mask), (method, sun, hm.shape, int((a.mask != b.mask).sum()))
        assert np.array_equal(a.self_shadow, b.self_shadow)
        assert np.array_equal(a.coefficient, b.coefficient, equal_nan=True)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(h=terrains(), az=azimuths, alt=elevations, cell=cell_sizes, certificates=st.booleans())
def test_packets_equal_single_rays_on_random_maps(short_runs, h, az, alt, cell, certificates):
    assert_same_outputs(Heightmap.from_array(h, cell), Sun(az, alt), certificates)


def test_packets_equal_single_rays_on_a_real_dem_with_holes(short_runs):
    from matplotlib import cbook

    data = cbook.get_sample_data("jacksboro_fault_dem.npz")
    elev = (data if hasattr(data, "files") else np.load(data))["elevation"].astype(np.float64)
    elev[100:130, 40:95] = np.nan
    elev[np.random.default_rng(7).random(elev.shape) < 0.01] = np.nan   # scattered holes too
    hm = Heightmap.from_array(elev, (90.0, 90.0))
    for az, alt in [(37.0, 20.0), (135.0, 5.0), (45.0, 10.0), (90.0, 3.0), (250.0, 1.0), (315.0, 60.0)]:
        assert_same_outputs(hm, Sun(az, alt))


def test_packets_are_the_default_on_cpu_devices_only():
    hm = Heightmap.from_array(np.zeros((3, 3)), 1.0)
    caster = ShadowCaster(hm, cache=False)
    is_cpu = bool(caster.runtime.device.type & shadows.cl.device_type.CPU)
    assert caster.packets == is_cpu
    kernel = shadows.ShadowFeatures("exact", packets=caster.packets).cells_kernel
    assert kernel == ("shadow_cells_packet" if is_cpu else "shadow_cells")
    # methods without a packet kernel, and profiling builds, trace one ray per work-item
    assert shadows.ShadowFeatures("dda", packets=True).cells_kernel == "shadow_cells"
    assert shadows.ShadowFeatures("exact", stats=True, packets=True).cells_kernel == "shadow_cells"
