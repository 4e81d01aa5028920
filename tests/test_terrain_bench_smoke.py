"""Smoke test of bench/terrain_cast.py: a --quick run writes its three reports with exact methods exact."""
from __future__ import annotations

from pathlib import Path

from bench_smoke import needs_bench, run_quick


@needs_bench
def test_terrain_cast_quick(tmp_path: Path) -> None:
    out = tmp_path / "results"
    res = run_quick("terrain_cast", out)
    assert {"date", "cpu", "pocl_version", "command"} <= set(res["meta"])
    assert [e["size"] for e in res["maps"]] == res["config"]["sizes"]
    for e in res["maps"]:
        assert set(e["methods"]) == {"bisect", "dda", "march"}
        for name in ("bisect", "dda"):
            v = e["methods"][name]
            assert v["different_cell_fraction"] <= 1e-3 and v["hit_mismatch_off_silhouette"] == 0
    assert len(res["resolution"]) == 3 and len(res["depth_range"]) == 4
    assert set(res["paired"]["growth"]) == {"bisect", "dda"}
    for e in res["maps"]:
        levels = e["per_hit"]["bisect"]["levels"]
        assert len(levels) == len(e["per_hit"]["dda"]["levels"]) and not any(levels[:2])   # leaf level 2
    assert "| bisect |" in (out / "terrain_cast.md").read_text()
