"""Smoke test of bench/skipping.py: a --quick run writes its three reports with every section."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "bench" / "skipping.py"


@pytest.mark.skipif(not SCRIPT.is_file(), reason="bench/ is not in this tree (installed package only)")
def test_skipping_quick(tmp_path: Path) -> None:
    out = tmp_path / "results"
    proc = subprocess.run([sys.executable, str(SCRIPT), "--quick", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-4000:]
    for ext in ("json", "md", "png"):
        assert (out / f"skipping.{ext}").stat().st_size > 0
    assert (out / "skipping.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    res = json.loads((out / "skipping.json").read_text())
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
