"""Smoke test of bench/shadow_masks.py: a quick synthetic-only run writes its three reports."""
from __future__ import annotations

from pathlib import Path

from bench_smoke import needs_bench, run_quick


@needs_bench
def test_shadow_masks_quick(tmp_path: Path) -> None:
    out = tmp_path / "results"
    # puget is asked for with an absent data folder: it must be recorded as skipped, not fail
    res = run_quick("shadow_masks", out, "--datasets", "synthetic,puget", "--data", str(tmp_path / "no-shared-data"))
    assert {"meta", "config", "datasets", "speedups"} <= set(res)
    assert {"date", "cpu", "cores", "device", "pocl_version", "platform_version", "numpy", "pyopencl",
            "command"} <= set(res["meta"])
    by_name = {d["name"]: d for d in res["datasets"]}
    assert by_name["puget"]["skipped"]
    canyon = by_name["canyon"]
    assert canyon["skipped"] is None and canyon["shape"] == [512, 512]
    assert {"pyramid_ms", "suns", "crop"} <= set(canyon)
    assert len(canyon["suns"]) == 6
    for sun in canyon["suns"]:
        assert set(sun["methods"]) == {"exact", "paper", "maxmip", "dda"}
        for m, e in sun["methods"].items():
            assert {"time_ms", "shadow_fraction", "crop", "full_diff_vs_exact", "steps_per_cell"} <= set(e)
            assert {"min", "median"} <= set(e["time_ms"])
            assert {"mismatches", "ties", "non_tie"} <= set(e["crop"])
        assert sun["methods"]["exact"]["full_diff_vs_exact"] == 0
        assert sun["methods"]["exact"]["crop"]["non_tie"] == 0
    assert {"exact_vs_dda", "exact_vs_maxmip"} <= set(res["speedups"]["canyon"])
    md = (out / "shadow_masks.md").read_text()
    assert "## canyon" in md and "| exact |" in md


@needs_bench
def test_headlines_quick(tmp_path: Path) -> None:
    res = run_quick("headlines", tmp_path, "--reps", "1", "--data", str(tmp_path / "none"), plot=False)
    assert [r["map"] for r in res["shadow_masks"]] == ["canyon 256^2"] * 2       # puget absent: left out
    assert set(res["render"]["ms"]) == {"bisect", "dda", "march"}
    assert all(res["screen"][k] > 0 for k in ("shadows_exact_ms", "shadows_maxmip_ms", "ao_ms"))
    assert "| 5 |" in (tmp_path / "headlines.md").read_text()


@needs_bench
def test_shadow_steps_quick(tmp_path: Path) -> None:
    res = run_quick("shadow_steps", tmp_path, plot=False)
    steps = {(tuple(r["sun"]), r["method"]): r["steps_per_cell"] for r in res["rows"]}
    assert len(steps) == 12 and all(sum(v) > 0 for v in steps.values())
    for sun in {s for s, _ in steps}:
        assert steps[sun, "exact"] == steps[sun, "maxmip"]           # the min early exit never fires
        assert sum(steps[sun, "dda"][1:]) == 0                       # dda walks level 0 only


@needs_bench
def test_horizon_record_quick(tmp_path: Path) -> None:
    res = run_quick("horizon_record", tmp_path, plot=False)
    assert res["size"] == 128 and res["azimuths"] == 8 and "canyon" in res["maps"]
    for name, m in res["maps"].items():
        assert m["frame"]["min_ms"] > 0 and m["frames_per_s"] > 0, name
        assert m["sweep_frame"]["min_ms"] > 0, name
        assert m["sweep_vs_frame_deg"] <= m["check"]["band_deg"], name
        assert m["check"]["cells"] == 20 and m["check"]["outside_band"] == 0, name
    assert f"host CPU {res['machine']['cpu']}, " in (tmp_path / "horizon_record.md").read_text()


@needs_bench
def test_horizon_seeds_quick(tmp_path: Path) -> None:
    res = run_quick("horizon_seeds", tmp_path, plot=False)
    (entry,) = res["maps"].values()
    assert entry["shape"] == [96, 96] and [r["azimuth"] for r in entry["azimuths"]] == [37.0, 200.0]
    for r in entry["azimuths"]:
        assert r["seeded_s"] > 0 and r["from_nothing_s"] > 0
        assert r["cells_differing"] <= 1e-3 * r["cells"]
        assert all(c["cells"] == 20 and c["outside_band"] == 0 for c in r["reference"].values())
    assert "| canyon 96^2 96x96 | no | 37 |" in (tmp_path / "horizon_seeds.md").read_text()


@needs_bench
def test_horizon_sweep_quick(tmp_path: Path) -> None:
    res = run_quick("horizon_sweep", tmp_path, "--no-rvt", plot=False)
    (rows,) = res["maps"].values()
    assert [r["radius_cells"] for r in rows] == [5.0, 200.0]
    near, far = rows
    assert near["swept_azimuths"] == 4      # 5 cells sweep; 200 (axis azimuths) walk unless the knob is 256
    # (or sweep_far 2): 96^2 is under the pilot's size
    assert far["swept_azimuths"] == (4 if far["sweep_cells"] >= 200 or far["sweep_far"] == 2 else 0)
    assert near["pilot"] is None and far["pilot"] is None
    for r in rows:
        assert all(r["seconds"][mode] > 0 for mode in ("sweep", "walk", "default"))
        assert r["angles_differing"] == 0       # the same bits (the run would have failed)
        assert all(c["cells"] == 20 and c["outside_band"] == 0 for c in r["reference"].values())
    assert "| canyon 96^2 | 5 |" in (tmp_path / "horizon_sweep.md").read_text()
