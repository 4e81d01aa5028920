"""Smoke test of bench/terrain_cast.py: a --quick run writes its three reports with exact methods exact."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "bench" / "terrain_cast.py"


@pytest.mark.skipif(not SCRIPT.is_file(), reason="bench/ is not in this tree (installed package only)")
def test_terrain_cast_quick(tmp_path: Path) -> None:
    out = tmp_path / "results"
    proc = subprocess.run([sys.executable, str(SCRIPT), "--quick", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-4000:]
    for ext in ("json", "md", "png"):
        assert (out / f"terrain_cast.{ext}").stat().st_size > 0
    res = json.loads((out / "terrain_cast.json").read_text())
    assert {"date", "cpu", "pocl_version", "command"} <= set(res["meta"])
    assert [e["size"] for e in res["maps"]] == res["config"]["sizes"]
    for e in res["maps"]:
        assert set(e["methods"]) == {"bisect", "dda", "march"}
        for name in ("bisect", "dda"):
            v = e["methods"][name]
            assert v["different_cell_fraction"] <= 1e-3 and v["hit_mismatch_off_silhouette"] == 0
    assert len(res["resolution"]) == 3 and len(res["depth_range"]) == 4
    assert "| bisect |" in (out / "terrain_cast.md").read_text()
