"""Smoke test of bench/gallery.py: a quick run writes every picture its README shows, and the
figures it states (shadows darker in the new look; the default framing fuller than crop 0)."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from bench_smoke import BENCH, PNG_MAGIC, needs_bench


@needs_bench
def test_gallery_quick(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, str(BENCH / "gallery.py"), "--quick", "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-4000:]
    text = (tmp_path / "README.md").read_text()
    shown = re.findall(r"\]\(([\w.]+\.png)\)", text)
    assert len(shown) >= 15
    for name in shown:
        assert (tmp_path / name).read_bytes()[:8] == PNG_MAGIC, name
    ratios = {look: float(m) for look, m in re.findall(r"- (before|after) look, default framing: .* median ([\d.]+)", text)}
    assert ratios["after"] < ratios["before"] - 0.1
    rows = re.findall(r"\| [\d.]+, [\d.]+ \| ([\d.]+)% \| ([\d.]+)% \|", text)
    assert len(rows) == 8 and all(float(b) >= float(a) for a, b in rows)
