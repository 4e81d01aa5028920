"""Smoke test of bench/objects.py: a quick run writes its reports, every row timed both ways."""
from __future__ import annotations

from pathlib import Path

from bench_smoke import needs_bench, run_quick


@needs_bench
def test_objects_quick(tmp_path: Path) -> None:
    res = run_quick("objects", tmp_path, "--mixes", "mirror,mixed", plot=False)
    rows = res["rows"]
    assert [(r["objects"], r["mix"]) for r in rows] == [(1, "mirror"), (1, "mixed"), (8, "mirror"), (8, "mixed")]
    assert all(r["object_pixels"] > 0 and r["specialised_ms"] > 0 and r["uber_ms"] > 0 for r in rows)
    assert all(abs(r["ratio"] - r["uber_ms"] / r["specialised_ms"]) < 1e-12 for r in rows)
    assert rows[0]["groups"] == [["REFLECT"]]
    assert rows[3]["groups"] == [["FRESNEL", "REFLECT"], ["REFLECT"], ["REFLECT", "ROUGH"]]
    md = (tmp_path / "objects.md").read_text()
    assert "| uber / specialised |" in md and "at most 2 %" in md
