"""Smoke test of bench/reflections.py: a quick run writes its reports with every section."""
from __future__ import annotations

from pathlib import Path

from bench_smoke import needs_bench, run_quick


@needs_bench
def test_reflections_quick(tmp_path: Path) -> None:
    res = run_quick("reflections", tmp_path, "--only", "times,unused,generate,parallax,mitsuba", plot=False)
    assert [r["objects"] for r in res["times"]] == [1, 8]
    assert all(r["object_pixels"] > 0 and r["frame_ms"] > 0 for r in res["times"])
    assert {"gbuffer", "normals", "shadows", "ao", "compose"} <= set(res["times"][0]["passes_ms"])
    assert len(res["unused"]) == 5 and all("cost_percent" in r for r in res["unused"].values())
    assert next(iter(res["unused"])).startswith("noise floor")                 # the A/A row comes first
    assert [r["every"] for r in res["generate"]["path"]] == [1, 6, "once"]
    assert [r["generations"] for r in res["generate"]["path"]] == [24, 4, 1]
    assert [(r["radius"], r["height"]) for r in res["parallax"]] == [(30.0, 10.0), (300.0, 10.0)]
    assert all(r["rays"] > 0 and 0.0 <= r["median_deg"] <= 180.0 for r in res["parallax"])
    mitsuba = res["mitsuba"]
    if "skipped" not in mitsuba:                   # the bench extra installed: the check must hold
        assert mitsuba["sphere interior (2 px in)"]["rmse"] < 0.02 * mitsuba["sphere interior (2 px in)"]["mean_value"]
    md = (tmp_path / "reflections.md").read_text()
    assert "## Frame time with N reflective spheres" in md and "## What a feature no object uses costs" in md
