"""Smoke test of bench/screen_shadows.py: a quick canyon-only run writes its three reports."""
from __future__ import annotations

from pathlib import Path

import pytest
from bench_smoke import needs_bench, run_quick


@needs_bench
def test_screen_shadows_quick(tmp_path: Path) -> None:
    out = tmp_path / "results"
    # puget is asked for with an absent data folder: it must be recorded as skipped, not fail
    res = run_quick("screen_shadows", out, "--datasets", "canyon,puget", "--data", str(tmp_path / "no-shared-data"))
    assert {"date", "cpu", "cores", "device", "pocl_version", "command"} <= set(res["meta"])
    by_name = {d["name"]: d for d in res["datasets"]}
    assert by_name["puget"]["skipped"]
    canyon = by_name["canyon"]
    assert canyon["skipped"] is None and canyon["shape"] == [256, 256]
    assert [s["elevation"] for s in canyon["suns"]] == [0.0, 30.0, 60.0, 90.0]
    for sun in canyon["suns"]:
        runs = sun["runs"]
        assert {"exact/q0", "exact/q1", "exact/q2", "exact/q3", "exact/auto", "exact/auto-1", "maxmip/q0",
                "maxmip/auto", "dda/q0", "dda/auto"} <= set(runs)
        assert runs["exact/q0"]["error_pct"] == 0.0                 # the baseline itself
        for method in ("maxmip", "dda"):                           # exact methods agree at q = 0
            assert runs[f"{method}/q0"]["error_pct"] == 0.0
        for r in runs.values():
            assert r["time_ms"]["min"] > 0 and r["error_pct"] == pytest.approx(r["missed_pct"] + r["added_pct"]) and r["error_pct"] >= 0.0
    # q = 0 against the float64 twin: five views, every pixel, no disagreement
    assert {r["view"] for r in canyon["twin"]} == {"top", "oblique", "low", "close-few", "close-many"}
    assert all(r["disagreements"] == 0 and r["tests"] > 0 for r in canyon["twin"])
    # the q table: every setting per view, q = 0 is the truth
    assert {r["view"] for r in canyon["q_table"]} == {"top", "oblique", "low"}
    for r in canyon["q_table"]:
        assert r["runs"]["q0"]["error_pct"] == 0.0 and r["runs"]["q0"]["steps_per_pixel"] > 0
    assert {"auto_error_pct_max", "auto_error_pct_mean", "maxmip_over_exact_low_sun", "twin",
            "q_error_max"} <= set(canyon["summary"])
    assert any(k.endswith("/exact/auto") for k in canyon["steps"])
    md = (out / "screen_shadows.md").read_text()
    assert "## canyon" in md and "| elev |" in md
    assert "### q = 0 against the float64 twin" in md and "### Error against time for q" in md
