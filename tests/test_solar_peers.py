"""bench/solar.py against GRASS r.horizon, WhiteboxTools and HORAYZON: the comparisons' conventions
(docs/solar.md).

The r.horizon tests skip without GRASS (``apt-get install grass-core``), the WhiteboxTools ones without
whitebox-workflows, the HORAYZON ones without horayzon-extpar (test extras, the latter on x86-64
Linux, where its wheels are); none needs shared/.
Expected values come from geometry (a tower on flat ground) and from a replica of r.horizon's
search written here from its documented method (raster/r.horizon/main.c in GRASS 8.2: steps of
(dx + dy) / 2 from the cell's centre, the nearest cell's height seen at the distance of that
cell's centre, lowered by d^2 / 2R with R = 6371000 m, the first sample starting the maximum),
not from the bench code under test.
"""
from __future__ import annotations

import importlib.util
import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from oclshade.heightmap import Heightmap
from oclshade.horizon import Curvature, HorizonCaster, azimuth_grid
from oclshade.reference import horizon_angles
from oclshade.runtime import get_runtime
from oclshade.synthetic import canyon_crater

ROOT = Path(__file__).resolve().parents[1]
R_GRASS = 6371000.0
needs_grass = pytest.mark.skipif(shutil.which("grass") is None, reason="GRASS (grass-core) not installed")


def load_bench_script(name: str):
    """bench/<name>.py as a module (bench/ is not a package)."""
    spec = importlib.util.spec_from_file_location(f"bench_{name}", ROOT / "bench" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def bench():
    return load_bench_script("solar")


def replica(h: np.ndarray, dx: float, dy: float, row: int, col: int, azimuth: float) -> tuple[float, float, bool]:
    """r.horizon's angle (degrees) for one cell of a map with no terrain past its border (-90: no
    sample), the distance of the cell that sets it, and whether that sample's point lies past the
    outermost cell centres.  Maps under 100 cells a side (no low-resolution skip)."""
    rows, cols = h.shape
    a = math.radians(90.0 - azimuth)
    c, s = math.cos(a), math.sin(a)
    c, s = (0.0 if abs(c) < 1e-7 else c), (0.0 if abs(s) < 1e-7 else s)
    step = 0.5 * (dx + dy)
    z0, zmax = h[row, col], h.max()
    maxlength = (zmax - z0) / 0.008727
    best, where, rim, last = -math.inf, math.inf, False, (row, col)
    m = 0
    while True:
        m += 1
        x, y = col + m * step * c / dx, row - m * step * s / dy         # columns east, rows south
        if not (-0.5 <= x < cols - 0.5 and -0.5 < y <= rows - 0.5):
            break
        cell = (math.ceil(y - 0.5), math.floor(x + 0.5))
        if cell == last:
            continue
        last = cell
        length = math.hypot((cell[1] - col) * dx, (cell[0] - row) * dy)
        drop = length * length / (2.0 * R_GRASS)
        line = z0 + drop + length * best
        if line < h[cell]:
            best = (h[cell] - z0 - drop) / length
            where, rim = length, not (0 <= x <= cols - 1 and 0 <= y <= rows - 1)
        if line >= zmax or length >= maxlength:
            break
    return (math.degrees(math.atan(best)) if best > -math.inf else -90.0), where, rim


def test_fill_voids(bench):
    h = np.arange(30, dtype=np.float32).reshape(5, 6)
    h[2, 2:4] = np.nan
    h[0, 0] = np.nan
    out = bench.fill_voids(h)
    valid = ~np.isnan(h)
    assert out.dtype == np.float32 and not np.isnan(out).any()
    assert np.array_equal(out[valid], h[valid])
    assert out[0, 0] == pytest.approx((1.0 + 6.0) / 2)
    assert out[2, 2] == pytest.approx((8.0 + 20.0 + 13.0) / 3)     # its valid 4-neighbours, first ring
    assert out[2, 3] == pytest.approx((9.0 + 21.0 + 16.0) / 3)
    with pytest.raises(ValueError, match="heights"):
        bench.fill_voids(np.full((2, 2), np.nan))


@needs_grass
def test_rhorizon_directions_rows_and_units(bench):
    """A 200 m tower on flat ground: cells 1..5 cells south, north, west and east of it read
    atan((200 - L^2 / 2R) / L) degrees at the azimuth that faces it (band i at 360 i / N)."""
    size, cell, tower = 21, 25.0, 200.0
    h = np.zeros((size, size), np.float32)
    h[10, 10] = tower
    angles = bench.run_grass(Heightmap.from_array(h, cell), 8)["angles"]
    k = {0.0: 0, 90.0: 2, 180.0: 4, 270.0: 6}
    for az, (dr, dc) in ((0.0, (1, 0)), (180.0, (-1, 0)), (90.0, (0, -1)), (270.0, (0, 1))):
        for d in range(1, 6):
            length = d * cell
            expected = math.degrees(math.atan((tower - length * length / (2 * R_GRASS)) / length))
            assert angles[k[az], 10 + d * dr, 10 + d * dc] == pytest.approx(expected, abs=1e-4), (az, d)


@needs_grass
def test_rhorizon_matches_its_model_everywhere(bench):
    """Every cell and azimuth of r.horizon's map equals the replica: no half-cell or row offsets,
    directions uncorrected (spherical Mercator at the equator), heights imported losslessly and
    nothing read past the west and south edges (the bench's null border)."""
    h = canyon_crater(40, 48, seed=3, relief=900.0)
    dx, dy = 20.0, 30.0
    n = 16
    got = bench.run_grass(Heightmap.from_array(h, (dx, dy)), n)["angles"]
    h64 = h.astype(np.float64)
    for k, az in enumerate(azimuth_grid(n)):
        for i in range(h.shape[0]):
            for j in range(h.shape[1]):
                want = replica(h64, dx, dy, i, j, az)[0]
                if want == -90.0:       # no terrain sample: r.horizon's only sample is the null border
                    assert got[k, i, j] < -89.0 or got[k, i, j] == -90.0, (az, i, j)
                else:
                    assert got[k, i, j] == pytest.approx(want, abs=1e-4), (az, i, j)


@needs_grass
def test_rhorizon_in_parallel_jobs_is_the_same_map(bench):
    """r.horizon split into 3 processes (blocks of 5, 5 and 6 of 16 directions, so the blocks'
    start and end angles are not multiples of 90) gives the single run's angles bit for bit, in
    the same azimuth order, and times the jobs' wall span and their sum."""
    hm = Heightmap.from_array(canyon_crater(24, 20, seed=5, relief=600.0), (25.0, 25.0))
    one = bench.run_grass(hm, 16)
    three = bench.run_grass(hm, 16, jobs=3)
    assert three["angles"].shape == one["angles"].shape == (16, 24, 20)
    np.testing.assert_array_equal(three["angles"], one["angles"])
    assert (one["jobs"], three["jobs"]) == (1, 3)
    assert one["process_seconds"] == pytest.approx(one["seconds"])
    # the wall span covers the longest job, at least the mean of the 3 (it need not be under their
    # sum: on a loaded machine these millisecond jobs may not overlap, and the gaps count)
    assert three["seconds"] >= three["process_seconds"] / 3 - 1e-6 > 0.0
    with pytest.raises(ValueError, match="jobs"):
        bench.run_grass(hm, 8, jobs=9)


@needs_grass
def test_peer_classes(bench):
    """peer_difference's classes partition the compared cells, r.horizon's near-sample and rim
    flags agree with the replica, and oclshade's near-field flag holds where its exact angle is
    the bilinear surface's slope at the cell (a saddle patch; the r.horizon example in docs)."""
    h = canyon_crater(40, 48, seed=3, relief=900.0)
    dx, dy = 20.0, 30.0
    hm = Heightmap.from_array(h, (dx, dy))
    n = 8
    caster = HorizonCaster(hm, cache=False, curvature=Curvature())
    ours = caster.horizons(n)
    theirs = bench.run_grass(hm, n)["angles"]
    res = bench.peer_difference(hm, ours, theirs, caster.coefficient)
    assert res["cells"] == res["near"]["cells"] + res["rim"]["cells"] + res["far"]["cells"]
    assert res["near"]["cells"] > 0 and res["far"]["cells"] > 0
    h64 = h.astype(np.float64)
    for k, az in enumerate(azimuth_grid(n)):
        near = bench.grass_near_samples(h, dx, dy, az) >= theirs[k] - 1e-4
        rim = bench.grass_rim_samples(h, dx, dy, az) >= theirs[k] - 1e-4
        for i in range(h.shape[0]):
            for j in range(h.shape[1]):
                angle, where, is_rim = replica(h64, dx, dy, i, j, az)
                if angle > -90.0:
                    assert near[i, j] == (where <= bench.NEAR_CELLS * max(dx, dy)), (az, i, j)
                    assert (not is_rim) or rim[i, j], (az, i, j)
    # a saddle: the cell's west neighbour 191 m higher, its north neighbour 107 m lower, the
    # north-west one 23 m lower: at 315 degrees the bilinear surface rises at once, at
    # atan((191 - 107) / (30 sqrt 2)) = 63.2 degrees, which r.horizon (first sample the
    # north-west cell, -28.5 degrees, then nothing higher on flat ground) does not see
    flat = np.zeros((9, 9), np.float32)
    flat[4, 4], flat[4, 3], flat[3, 4], flat[3, 3] = 400.0, 591.0, 293.0, 377.0
    saddle = Heightmap.from_array(flat, 30.0)
    near = bench.near_horizon(saddle, 315.0, 0.0)
    exact = math.degrees(math.atan((191.0 - 107.0) / (30.0 * math.sqrt(2.0))))
    assert near[4, 4] == pytest.approx(exact, abs=0.01)
    ours_saddle = HorizonCaster(saddle, cache=False).horizons([315.0])[0]
    assert ours_saddle[4, 4] == pytest.approx(exact, abs=0.01)
    rh = bench.run_grass(saddle, 8)["angles"][7]
    assert rh[4, 4] == pytest.approx(math.degrees(math.atan((377.0 - 400.0 - 3600.0 / (4 * R_GRASS))
                                                            / (30.0 * math.sqrt(2.0)))), abs=1e-4)


def test_near_horizon_is_a_lower_bound_and_exact_on_a_plane(bench):
    """near_horizon (the bound behind the near-field class) never exceeds the float64 reference's
    horizon of the whole surface (a rough map, axis and oblique azimuths, flat and curved), is nothing
    (-90) exactly on the cells whose ray leaves the map at once, and on a plane it is the plane's slope
    along the ray (every sample lies on it), so its shifted-slice sampling lands where it should."""
    hm = Heightmap.from_array(canyon_crater(23, 31, seed=5, relief=800.0), (20.0, 30.0))
    slack = 1e-6     # degrees: both trace Sun.ray's ray; float64 rounding at the first sample, 1e-6 cell out
    for curvature in (0.0, 1.0 / (2.0 * R_GRASS)):
        for az in (0.0, 33.75, 90.0, 180.0, 247.5, 270.0, 315.0):
            near = bench.near_horizon(hm, az, curvature)
            exact = horizon_angles(hm, az, curvature)
            seen = near > -90.0
            assert seen.sum() > 0.8 * near.size, az
            assert (near[seen] <= exact[seen] + slack).all(), (az, float((near[seen] - exact[seen]).max()))
    east = bench.near_horizon(hm, 90.0, 0.0)
    assert (east[:, -1] == -90.0).all() and (east[:, :-1] > -90.0).all()
    rows, cols, dx = 19, 27, 25.0
    plane = Heightmap.from_array(np.tile(0.7 * dx * np.arange(cols, dtype=np.float32), (rows, 1)), dx)
    for az in (60.0, 90.0, 135.0):
        near = bench.near_horizon(plane, az, 0.0)
        rising = math.degrees(math.atan(0.7 * math.sin(math.radians(az))))
        inner = near[1:-1, :-1]                        # cells whose first sample is on the map
        assert np.abs(inner - rising).max() < 1e-5, az


def test_difference_summary_is_numpys_on_the_joined_parts(bench):
    """The peer differences' summary, taken part by part (joined they did not fit in memory at
    4096^2 x 64 azimuths), is numpy's on the joined values: mean, mean |.|, RMS and max to the
    float64 sum's order, the 99th percentile (np.percentile of the values in float64) exactly,
    with empty parts, signed zeros, ties and values over eight decades."""
    rng = np.random.default_rng(7)
    for sizes in ([1], [0, 3], [1000, 0, 57, 4000], [100_000, 33_333]):
        parts = [(rng.standard_normal(n) * 10.0 ** rng.uniform(-6, 2, n)).astype(np.float32) for n in sizes]
        parts[-1][: len(parts[-1]) // 3] = np.float32(-2.5)               # ties across the percentile
        parts[0][:1] = -0.0
        d = np.concatenate(parts).astype(np.float64)
        got = bench._summary(parts)
        assert got["cells"] == d.size
        assert got["p99_abs_deg"] == np.percentile(np.abs(d), 99)
        assert got["max_abs_deg"] == np.abs(d).max()
        for key, want in (("mean_deg", d.mean()), ("mean_abs_deg", np.abs(d).mean()),
                          ("rms_deg", np.sqrt(np.square(d).mean()))):
            assert got[key] == pytest.approx(want, rel=1e-12, abs=1e-15), key
    assert bench._summary([np.zeros(0, np.float32)]) == {"cells": 0}


# ----------------------------------------------------------------------------- WhiteboxTools
needs_whitebox = pytest.mark.skipif(importlib.util.find_spec("whitebox_workflows") is None,
                                    reason="whitebox-workflows not installed (a test extra)")


@needs_whitebox
def test_whitebox_reads_the_map_and_its_azimuths_are_ours(bench):
    """A tower east and a wall north of a cell on flat ground: WhiteboxTools' HorizonAngle, run as
    bench/solar.py runs it (a plain GeoTIFF it can read, azimuths clockwise from north), gives the
    flat-Earth angles atan(dz / d) at those azimuths and 0 on the flat sides."""
    h = np.zeros((61, 61), np.float32)
    h[30, 50] = 400.0                        # 20 cells east of (30, 30)
    h[10, 25:36] = 250.0                     # 20 cells north
    hm = Heightmap.from_array(h, 25.0)
    angles = bench.run_whitebox(hm, 4)["angles"]            # azimuths 0, 90, 180, 270
    assert angles.shape == (4, 61, 61)
    expect = [math.degrees(math.atan(250.0 / 500.0)), math.degrees(math.atan(400.0 / 500.0)), 0.0, 0.0]
    np.testing.assert_allclose(angles[:, 30, 30], expect, atol=1e-4)


@needs_whitebox
def test_whitebox_agrees_with_oclshade_off_the_near_field(bench):
    """On a smooth map (no kinks the bilinear surface and grid-line samples see differently)
    WhiteboxTools' angles equal oclshade's flat-Earth angles where oclshade's horizon is set
    beyond the near field, to a small fraction of a degree in the mean."""
    hm = Heightmap.from_array(canyon_crater(96, 96, seed=3, relief=400.0), 30.0)
    ours = HorizonCaster(hm, cache=False).horizons(8)
    theirs = bench.run_whitebox(hm, 8)["angles"]
    d = bench.near_far_difference(hm, ours, theirs)
    assert d["cells"] > 8 * 96 * 96 // 2                    # most cells see terrain
    assert d["far"]["cells"] > 0 and abs(d["far"]["mean_deg"]) < 0.05, d["far"]


@needs_whitebox
def test_whitebox_subset_from_a_start_azimuth_is_those_bands_of_the_grid(bench):
    """``--whitebox-start``: K azimuths from DEG are the bands of the N-grid at DEG + 360 i / K
    (here 45 and 225 of 8, off the grid's axes), and their near/far split is taken at those
    azimuths, equal to the same bands' split within the full grid."""
    hm = Heightmap.from_array(canyon_crater(48, 48, seed=5, relief=300.0), 30.0)
    all8 = bench.run_whitebox(hm, 8)["angles"]
    two = bench.run_whitebox(hm, 2, start=45.0)["angles"]
    np.testing.assert_array_equal(two, all8[1::4])
    ours = HorizonCaster(hm, cache=False).horizons(8)
    full = bench.near_far_difference(hm, ours[1::4], two, azimuths=np.array([45.0, 225.0]))
    near = bench.near_cells(hm, ours)
    assert full == bench.near_far_difference(hm, ours[1::4], two, near=near[1::4])
    unrotated = bench.near_far_difference(hm, ours[1::4], two)        # read as azimuths 0 and 180
    assert unrotated["near"]["cells"] != full["near"]["cells"]


def test_horayzon_mesh_lies_on_the_sphere_wound_anticlockwise(bench):
    """The mesh handed to HORAYZON: every vertex at radius R + h from the centre, the map's centre
    at the origin, north (the pole's side) along -rows and east along +columns, every triangle's
    normal pointing away from the centre (HORAYZON refuses other windings), two per patch."""
    h = canyon_crater(9, 12, seed=2, relief=300.0).astype(np.float32)
    hm = Heightmap.from_array(h, (20.0, 30.0))
    verts, faces, centre, pole = bench.horayzon_mesh(hm, radius=1.0e6)
    v = verts.astype(np.float64).reshape(9, 12, 3)
    radius = np.linalg.norm(v - centre, axis=-1)
    np.testing.assert_allclose(radius, 1.0e6 + h.astype(np.float64), rtol=0, atol=0.02)   # float32 coordinates
    assert np.linalg.norm(pole - centre) == pytest.approx(1.0e6)
    assert v[0, 5, 1] > v[8, 5, 1] and v[4, 11, 0] > v[4, 0, 0]            # row 0 north, column 0 west
    np.testing.assert_allclose(v[4, 5, 0] + v[4, 6, 0], 0.0, atol=0.01)   # centre between columns 5, 6
    assert faces.shape == (2 * 8 * 11, 3) and faces.max() == 9 * 12 - 1
    p = verts.astype(np.float64)[faces]
    normal = np.cross(p[:, 2] - p[:, 1], p[:, 0] - p[:, 1])
    assert np.all(np.einsum("ij,ij->i", normal, p.mean(axis=1) - centre) > 0)


needs_horayzon = pytest.mark.skipif(importlib.util.find_spec("horayzon_extpar") is None,
                                    reason="horayzon-extpar not installed (a test extra on x86-64 Linux)")


@needs_horayzon
def test_horayzon_agrees_with_oclshade_along_grid_lines(bench):
    """At azimuths 0, 90, 180 and 270 degrees every ray runs along a grid line, where the bilinear
    surface and HORAYZON's triangles are the same polyline: off the map's border its angles are
    oclshade's curved ones within its accuracy (plus the sphere's departure from the d^2 / 2R drop,
    and its ray origin's offset off the vertex: under 0.005 degrees on a 2 km map).  Border cells
    are left out: a ray along the mesh's edge line can miss it in HORAYZON (docs/solar.md)."""
    hm = Heightmap.from_array(canyon_crater(64, 64, seed=5, relief=350.0), 30.0)
    ours = HorizonCaster(hm, cache=False, curvature=Curvature()).horizons(4)
    z = bench.run_horayzon(hm, 4, accuracy=0.01)
    inner = np.zeros(hm.shape, bool)
    inner[1:-1, 1:-1] = True
    seen = (ours > bench.HORAYZON_LOWEST + 1.0) & inner
    assert seen.mean() > 0.5
    d = np.abs(z["angles"] - ours)[seen]
    assert d.max() <= 0.015, np.quantile(d, [0.5, 0.99, 0.999, 1.0])
    assert z["seconds"] > 0 and z["rays"] >= 1


def test_peers_option_runs_only_the_named_peers(bench, monkeypatch, tmp_path):
    """--peers leaves the others out, saying so in the record; a name it does not know is a usage
    error naming the choices."""
    called = []
    monkeypatch.setattr(bench, "grass_version", lambda: called.append("grass") or None)
    monkeypatch.setattr(bench, "whitebox_version", lambda: called.append("whitebox") or None)
    monkeypatch.setattr(bench, "horayzon_version", lambda: called.append("horayzon") or None)
    res = bench.run(True, 10, 16, 5, ("canyon",), None, (4,), ("rvt",))
    assert called == []
    assert res["grass"] == res["whitebox"] == res["horayzon"] == "not run (--peers)"
    run = res["maps"]["canyon 256^2"]["runs"][4]
    assert "grass_s" not in run and "whitebox_s" not in run and "horayzon_s" not in run
    monkeypatch.setattr("sys.argv", ["solar.py", "--peers", "grass,saga", "--out", str(tmp_path / "x")])
    with pytest.raises(SystemExit) as stop:
        bench.main()
    assert stop.value.code == 2


def test_svf_by_band_is_the_reference_sky_view_factor(bench):
    """bench/solar.py sums the sky-view factor one band at a time (a 4096^2 x 64 stack in float64
    did not fit in memory); it equals the reference's up to the float64 sum's order."""
    from oclshade import reference as ref
    rng = np.random.default_rng(3)
    angles = (rng.random((16, 20, 30)) * 120.0 - 30.0).astype(np.float32)
    angles[:, 4, 5] = np.nan
    for definition in ("cosine", "solid-angle"):
        got, want = bench.svf_by_band(angles, definition), ref.sky_view_factor(angles, definition)
        assert np.isnan(got[4, 5]) and np.isnan(want[4, 5])
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


@pytest.fixture(scope="module")
def frontier():
    return load_bench_script("horayzon_frontier")


@needs_horayzon
def test_horayzon_frontier_records_each_accuracy_against_the_exact_walk(frontier, tmp_path):
    """bench/horayzon_frontier.py: oclshade's curved angles held to the float64 reference (none
    outside the float32 band), then one HORAYZON run per accuracy, coarsest first, each with its
    time, rays and near / far differences; JSON, Markdown and plot written."""
    hm = Heightmap.from_array(canyon_crater(48, 48, seed=2, relief=300.0), 30.0)
    out = tmp_path / "frontier"
    res = frontier.measure("canyon 48^2", hm, 4, (0.1, 0.05), 40, out)
    assert res["reference"]["cells"] == 40 and res["reference"]["outside_band"] == 0
    assert [r["accuracy_deg"] for r in res["runs"]] == [0.1, 0.05]
    for run in res["runs"]:
        assert run["seconds"] > 0 and run["rays"] >= 1
        assert run["vs_oclshade"]["near"]["cells"] + run["vs_oclshade"]["far"]["cells"] > 0
    assert res["runs"][1]["rays"] >= res["runs"][0]["rays"]      # a finer accuracy takes more steps
    text = out.with_suffix(".md").read_text()
    assert "| 0.1 |" in text and "| 0.05 |" in text
    assert out.with_suffix(".png").stat().st_size > 0 and out.with_suffix(".json").exists()


def test_horayzon_frontier_refuses_bad_accuracies(frontier, monkeypatch, tmp_path):
    monkeypatch.setattr("sys.argv", ["horayzon_frontier.py", "--accuracies", "0.1,-1", "--out", str(tmp_path / "x")])
    with pytest.raises(SystemExit) as stop:
        frontier.main()
    assert stop.value.code == 2


def test_the_peer_difference_is_computed_once_per_stack(bench):
    """bench/solar.py compares r.horizon's k azimuths with ours at every N once: the same bits
    reuse the first result, one bit changed computes anew."""
    rng = np.random.default_rng(7)
    ours, theirs = rng.random((4, 8, 8), np.float32), rng.random((4, 8, 8), np.float32)
    calls = []
    same = bench.SameBands()

    def difference(stack):
        calls.append(stack.copy())
        return {"calls": len(calls)}

    assert same.compare(ours, theirs, difference) == {"calls": 1}
    assert same.compare(np.stack([ours, ours])[0], theirs.copy(), difference) == {"calls": 1}
    nudged = ours.copy()
    nudged[3, 7, 7] = np.nextafter(nudged[3, 7, 7], np.float32(2))
    assert same.compare(nudged, theirs, difference) == {"calls": 2}
    assert same.compare(ours, theirs[::-1], difference) == {"calls": 3}
    assert len(calls) == 3


def test_rhorizon_is_compared_on_the_chosen_directions(bench, monkeypatch):
    """--grass-compare C: r.horizon's difference is taken on every (K / C)-th of its K directions,
    against our curved angles at the same azimuths; 0 records its time only and says so; without
    it every direction is compared.  (r.horizon and the comparison stubbed: the band stacks
    handed over are what is checked.)"""
    monkeypatch.setattr(bench, "grass_version", lambda: "GRASS (stub)")

    def stub_grass(hm, k, jobs=1):
        bands = np.broadcast_to(azimuth_grid(k)[:, None, None], (k, *hm.shape))
        return {"seconds": 1.0, "angles": bands.astype(np.float32)}

    handed = []

    def stub_difference(hm, ours, theirs, curvature):
        handed.append((ours.copy(), theirs[:, 0, 0].tolist()))
        return {"cells": 1, "mean_abs_deg": 0.0, "p99_abs_deg": 0.0, "max_abs_deg": 0.0,
                **{c: {"cells": 0} for c in ("near", "rim", "far")}}

    monkeypatch.setattr(bench, "run_grass", stub_grass)
    monkeypatch.setattr(bench, "peer_difference", stub_difference)
    hm = bench.maps(True, ("canyon",))["canyon 256^2"]
    curved = HorizonCaster(hm, cache=False, curvature=Curvature())
    for compare, azimuths in ((None, [0.0, 90.0, 180.0, 270.0]), (2, [0.0, 180.0]), (0, [])):
        handed.clear()
        res = bench.run(True, 10, 16, 5, ("canyon",), 4, (8,), ("grass",), grass_compare=compare)
        row = res["maps"]["canyon 256^2"]["runs"][8]
        assert row["grass_s"] == 2.0 and row["grass_directions"] == 4     # 4 of 8 run, time scaled
        text = bench.markdown(res)
        if azimuths:
            [(ours, theirs)] = handed
            assert theirs == azimuths
            np.testing.assert_array_equal(ours, curved.horizons(azimuths))
            assert "grass_vs_oclshade" in row
        else:
            assert handed == [] and "grass_vs_oclshade" not in row
            assert "not compared (`--grass-compare 0`)" in text
        assert row.get("grass_compared_directions", 4) == len(azimuths)
        assert ("(on 2 of its directions)" in text) == (compare == 2)
    with pytest.raises(ValueError, match="grass_compare"):
        bench.run(True, 10, 16, 5, ("canyon",), 4, (8,), ("grass",), grass_compare=3)


@pytest.mark.parametrize("compare", ["3", "-1"])
def test_grass_compare_must_divide_the_directions(bench, monkeypatch, tmp_path, compare):
    monkeypatch.setattr("sys.argv", ["solar.py", "--azimuths", "8", "--grass-compare", compare,
                                     "--out", str(tmp_path / "x")])
    with pytest.raises(SystemExit) as stop:
        bench.main()
    assert stop.value.code == 2


def test_the_record_names_the_cpu_the_driver_and_the_command(bench, monkeypatch, tmp_path):
    """Every figure carries the CPU (its family and model: cloud CPUs share one name), the PoCL
    version and the LLVM target it compiled for, and the command that made it; the .md says so in
    its first lines."""
    res = bench.run(True, 10, 16, 5, ("canyon",), None, (4,), ())
    machine, device = res["machine"], get_runtime().device
    assert machine["platform_version"] == device.platform.version.strip()
    assert machine["device_version"] == device.version.strip()
    cpuinfo = Path("/proc/cpuinfo")
    text = cpuinfo.read_text() if cpuinfo.exists() else ""
    family = re.search(r"^cpu family\s*:\s*(\d+)", text, re.M)
    model = re.search(r"^model\s*:\s*(\d+)", text, re.M)
    if family and model:
        assert f"(family {family[1]} model {model[1]}; " in machine["cpu"]
    monkeypatch.setattr(bench, "run", lambda *args, **kwargs: res)
    monkeypatch.setattr(bench, "plot", lambda *args: None)
    argv = ["--reduced", "--maps", "canyon", "--azimuths", "4", "--peers", "rvt", "--out", str(tmp_path / "r")]
    monkeypatch.setattr("sys.argv", ["solar.py", *argv])
    bench.main()
    saved = json.loads((tmp_path / "r.json").read_text())
    assert saved["command"] == " ".join(["python", "bench/solar.py", *argv])
    head = "\n".join((tmp_path / "r.md").read_text().splitlines()[:4])
    for fact in (machine["cpu"], machine["platform_version"], machine["device_version"], saved["command"]):
        assert fact in head
