"""bench/shadow_volumes.py runs (a tiny frame) and writes its table, plot and JSON."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DATA = REPO.parent / "shared" / "data" / "meshes"


@pytest.mark.skipif(not all((DATA / f).is_file() for f in ("iss.obj", "stanford-bunny.obj")),
                    reason="needs the shared ISS and bunny meshes")
def test_bench_runs_small(tmp_path: Path) -> None:
    sys.path.insert(0, str(REPO / "bench"))
    try:
        import shadow_volumes as bench
    finally:
        sys.path.remove(str(REPO / "bench"))
    assert bench.main(["--size", "64x36", "--faces", "0,300", "--reps", "1", "--out", str(tmp_path)]) == 0
    res = json.loads((tmp_path / "shadow_volumes.json").read_text())
    zero, row = res["runs"]["rows"]
    assert zero["faces"] == 0 and zero["silhouette"]["min"] == 0.0
    assert row["faces"] == 300 and row["silhouette_edges"] > 0
    assert row["volume_faces"] < row["all_face_volume_faces"]
    assert row["differ"]["silhouette_vs_all_faces"] == 0                  # the same masks
    assert (tmp_path / "shadow_volumes.png").stat().st_size > 0
    assert "| 300 |" in (tmp_path / "shadow_volumes.md").read_text()
