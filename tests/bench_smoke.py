"""Shared by the benchmark smoke tests: run a bench/ script with --quick and check its reports."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "bench"
needs_bench = pytest.mark.skipif(not BENCH.is_dir(), reason="bench/ is not in this tree (installed package only)")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def run_quick(name: str, out: Path, *args: str, plot: bool = True) -> dict:
    """Run ``bench/<name>.py --quick ARGS --out OUT``; assert it succeeds and writes non-empty
    ``<name>.json`` and ``.md`` (and a ``.png`` plot when ``plot``); return the parsed JSON."""
    cmd = [sys.executable, str(BENCH / f"{name}.py"), "--quick", *args, "--out", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-4000:]
    for ext in ("json", "md", "png") if plot else ("json", "md"):
        f = out / f"{name}.{ext}"
        assert f.is_file() and f.stat().st_size > 0, f
    if plot:
        assert (out / f"{name}.png").read_bytes()[:8] == PNG_MAGIC
    return json.loads((out / f"{name}.json").read_text())
