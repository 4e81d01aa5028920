"""Smoke test of bench/tuning_variants.py: a quick run compares each family's default with its
variants and writes both reports."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from bench_smoke import BENCH, needs_bench


@needs_bench
def test_tuning_variants_quick(tmp_path: Path) -> None:
    cmd = [sys.executable, str(BENCH / "tuning_variants.py"), "--quick", "--reps", "1", "--no-saga",
           "--data", str(tmp_path / "no-shared-data"), "--out", str(tmp_path)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-4000:]
    (report,) = tmp_path.glob("tuning_variants_*.json")
    assert report.with_suffix(".md").stat().st_size > 0
    res = json.loads(report.read_text())
    families = {row["family"] for row in res["rows"]}
    assert families == {"shadow", "terrain", "screen_shadows", "ssao"}
    for row in res["rows"]:
        assert row["default_over_best"] >= 1.0
        assert row["best_ms"] == min(row["variants_ms"].values())
        assert json.dumps(row["default"], sort_keys=True, separators=(",", ":")) in row["variants_ms"]
        assert row["source"].split(",")[0] in ("user", "shipped", "rule", "safe")
