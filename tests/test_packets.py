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


#: runs of 16 cells, so small maps have several runs per row and a partial last one
SHORT_RUN = 16
LANES = (4, 8, 16)


def assert_same_outputs(hm: Heightmap, sun: Sun, lanes: int, certificates: bool = True,
                        own_builtins: int = 0, gather: int = 0) -> None:
    packed = ShadowCaster(hm, cache=False, analyse=False, certificates=certificates,
                          knobs={"lanes": lanes, "run": SHORT_RUN, "own_builtins": own_builtins, "gather": gather})
    single = ShadowCaster(hm, cache=False, analyse=False, certificates=certificates, knobs={"lanes": 0})
    for method in shadows.PACKET_METHODS:
        a = packed.cast(sun, method, "all")
        b = single.cast(sun, method, "all")
        assert np.array_equal(a.mask, b.mask), (method, sun, lanes, hm.shape, int((a.mask != b.mask).sum()))
        assert np.array_equal(a.self_shadow, b.self_shadow)
        assert np.array_equal(a.coefficient, b.coefficient, equal_nan=True)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(h=terrains(), az=azimuths, alt=elevations, cell=cell_sizes, certificates=st.booleans(),
       lanes=st.sampled_from(LANES), own_builtins=st.sampled_from((0, 1)), gather=st.sampled_from((0, 1)))
def test_packets_equal_single_rays_on_random_maps(h, az, alt, cell, certificates, lanes, own_builtins, gather):
    assert_same_outputs(Heightmap.from_array(h, cell), Sun(az, alt), lanes, certificates, own_builtins, gather)


@pytest.mark.parametrize("lanes,own_builtins,gather", [(4, 0, 0), (8, 1, 1), (16, 0, 1), (16, 1, 1), (0, 1, 0)])
def test_packets_equal_single_rays_on_a_real_dem_with_holes(lanes, own_builtins, gather):
    from matplotlib import cbook

    data = cbook.get_sample_data("jacksboro_fault_dem.npz")
    elev = (data if hasattr(data, "files") else np.load(data))["elevation"].astype(np.float64)
    elev[100:130, 40:95] = np.nan
    elev[np.random.default_rng(7).random(elev.shape) < 0.01] = np.nan   # scattered holes too
    hm = Heightmap.from_array(elev, (90.0, 90.0))
    for az, alt in [(37.0, 20.0), (135.0, 5.0), (45.0, 10.0), (90.0, 3.0), (250.0, 1.0), (315.0, 60.0)]:
        assert_same_outputs(hm, Sun(az, alt), lanes, own_builtins=own_builtins, gather=gather)


def test_the_lanes_knob_picks_the_kernel():
    assert shadows.ShadowFeatures("exact", lanes=8).cells_kernel == "shadow_cells_packet"
    assert shadows.ShadowFeatures("exact", lanes=0).cells_kernel == "shadow_cells"
    # methods without a packet kernel, and profiling builds, trace one ray per work-item
    assert shadows.ShadowFeatures("dda", lanes=8).cells_kernel == "shadow_cells"
    assert shadows.ShadowFeatures("exact", stats=True, lanes=8).cells_kernel == "shadow_cells"


def test_gathers_are_asked_for_only_in_packet_builds():
    assert shadows.ShadowFeatures("exact", lanes=16, gather=True).defines()["OCLS_HW_GATHER"]
    assert not shadows.ShadowFeatures("exact", lanes=0, gather=True).defines()["OCLS_HW_GATHER"]
    assert not shadows.ShadowFeatures("dda", lanes=16, gather=True).defines()["OCLS_HW_GATHER"]


KNOB_SETS = ([{"run": r, "group": g} for r in shadows.TUNING.param("run").values
              for g in shadows.TUNING.param("group").values]
             + [{"cert_tile": c, "run": 64} for c in shadows.TUNING.param("cert_tile").values])


@pytest.mark.parametrize("knobs", KNOB_SETS, ids=lambda k: "-".join(f"{n}{v}" for n, v in k.items()))
def test_run_group_and_certificate_tile_knobs_do_not_change_masks(knobs):
    h = np.random.default_rng(len(str(knobs))).normal(0.0, 3.0, (37, 1100)).cumsum(axis=1)
    hm = Heightmap.from_array(h, 1.0)
    ref = ShadowCaster(hm, cache=False, knobs={"lanes": 0, "cert_tile": 16}).cast((100.0, 8.0)).mask
    got = ShadowCaster(hm, cache=False, knobs={"lanes": 8, **knobs}).cast((100.0, 8.0)).mask
    assert np.array_equal(got, ref)
    assert 0.05 < ref.mean() < 0.95     # a map with shadows and lit cells both


def test_illegal_knobs_name_the_knob():
    hm = Heightmap.from_array(np.zeros((3, 3)), 1.0)
    with pytest.raises(ValueError, match="shadow.lanes"):
        ShadowCaster(hm, knobs={"lanes": 5})
    with pytest.raises(ValueError, match="no parameter 'width'"):
        ShadowCaster(hm, knobs={"width": 8})
