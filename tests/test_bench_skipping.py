"""Smoke test of bench/skipping.py: a --quick run writes its three reports with every section."""
from __future__ import annotations

from pathlib import Path

from bench_smoke import needs_bench, run_quick


@needs_bench
def test_skipping_quick(tmp_path: Path) -> None:
    out = tmp_path / "results"
    res = run_quick("skipping", out)
    assert {"date", "cpu", "device", "pocl_version", "command"} <= set(res["meta"])
    feat = res["disabled_feature"]
    assert feat["masks_identical"] and feat["source_lines"]["stripped"] < feat["source_lines"]["stock"]
    for rep in res["repeated"]:
        assert rep["ShadowCaster.cast"]["identical"] and rep["cast_shadows"]["identical"]
        assert rep["ShadowCaster.cast"]["speedup"] > 1.0
    for a in res["above_bound"]:
        assert all(s["identical"] and s["skipped"] for s in a["suns"])
    frames = res["frames"]
    n = frames["frames"]
    for name in ("gbuffer", "ao"):                        # camera fixed: once with caching, every frame without
        assert frames["cached"]["passes"][name]["runs"] == 1
        assert frames["uncached"]["passes"][name]["runs"] == n
    for name in ("shadows", "compose"):                   # the sun moves every frame
        assert frames["cached"]["passes"][name]["runs"] == n
    md = (out / "skipping.md").read_text()
    assert "## 1." in md and "## 4." in md and "TerrainScene" in md
