"""Smoke test of bench/shadow_masks.py: a quick synthetic-only run writes its three reports."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "bench" / "shadow_masks.py"


@pytest.mark.skipif(not SCRIPT.is_file(), reason="bench/ is not in this tree (installed package only)")
def test_shadow_masks_quick(tmp_path: Path) -> None:
    out = tmp_path / "results"
    # puget is asked for with an absent data folder: it must be recorded as skipped, not fail
    cmd = [sys.executable, str(SCRIPT), "--quick", "--datasets", "synthetic,puget",
           "--data", str(tmp_path / "no-shared-data"), "--out", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-4000:]
    for ext in ("json", "md", "png"):
        f = out / f"shadow_masks.{ext}"
        assert f.is_file() and f.stat().st_size > 0, f
    assert (out / "shadow_masks.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    res = json.loads((out / "shadow_masks.json").read_text())
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


HEADLINES = SCRIPT.parent / "headlines.py"


@pytest.mark.skipif(not HEADLINES.is_file(), reason="bench/ is not in this tree (installed package only)")
def test_headlines_quick(tmp_path: Path) -> None:
    cmd = [sys.executable, str(HEADLINES), "--quick", "--reps", "1", "--data", str(tmp_path / "none"),
           "--out", str(tmp_path)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    res = json.loads((tmp_path / "headlines.json").read_text())
    assert [r["map"] for r in res["shadow_masks"]] == ["canyon 256^2"] * 2       # puget absent: left out
    assert set(res["render"]["ms"]) == {"bisect", "dda", "march"}
    assert all(res["screen"][k] > 0 for k in ("shadows_exact_ms", "shadows_maxmip_ms", "ao_ms"))
    assert "| 5 |" in (tmp_path / "headlines.md").read_text()
