"""``oclshade bench`` on tiny inputs (``--sizes tiny``, one device): report schema, files,
``--compare`` and its exit status; the cross-device logic on a report with a second device
made up from the first."""
from __future__ import annotations

import contextlib
import copy
import io
import json
import re
from pathlib import Path

import pytest

from oclshade.bench.compare import compare
from oclshade.bench.portability import agreement, mismatches, pennycook, portability
from oclshade.bench.report import summary
from oclshade.bench.suite import FAMILIES, SPECS
from oclshade.cli import main

HEX64 = re.compile(r"[0-9a-f]{64}")
TINY = ["bench", "--sizes", "tiny", "--device", "0"]


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> tuple[int, str, Path]:
    out = tmp_path_factory.mktemp("bench")
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        status = main([*TINY, "--quiet", "--out", str(out)])
    return status, stdout.getvalue(), out


@pytest.fixture(scope="module")
def report(run) -> dict:
    return json.loads((run[2] / "bench.json").read_text())


def test_runs_and_prints_the_summary(run):
    status, stdout, _ = run
    assert status == 0, stdout
    for spec in SPECS:
        assert spec.id in stdout
    assert "performance portability" in stdout


def test_json_schema(report):
    assert report["schema"] == "oclshade-bench/1" and report["sizes"] == "tiny" and report["reps"] == 2
    for key in ("date", "cpu", "cores", "os", "python", "pyopencl", "numpy", "oclshade"):
        assert report["machine"][key], key
    if Path("/proc/cpuinfo").exists():                          # cloud CPUs share a model name: numbers too
        assert re.search(r"\(family \S+ model \S+; \w+\)$", report["machine"]["cpu"]), report["machine"]["cpu"]
    assert report["families"] == list(FAMILIES)
    assert [c["id"] for c in report["cases"]] == [s.id for s in SPECS]
    assert {c["family"] for c in report["cases"]} == set(FAMILIES)
    (dev,) = report["devices"]
    for key in ("platform", "platform_version", "name", "version", "driver_version"):
        assert isinstance(dev[key], str) and dev[key], key
    assert dev["error"] is None
    roof = dev["roofline"]
    assert roof["bandwidth_gbs"] > 0 and roof["gflops"] > 0 and roof["probes"]
    for cid, r in dev["cases"].items():
        assert r["error"] is None, (cid, r["error"])
        assert HEX64.fullmatch(r["digest"]) and HEX64.fullmatch(r["input_digest"]), cid
        assert 0 < r["roofline_fraction"] <= 10, (cid, r["roofline_fraction"])
        assert 0 < r["min_ms"] <= r["median_ms"] and r["reps"] == len(r["times_ms"]) >= 1, cid
        assert r["throughput_per_s"] > 0 and r["bytes"] > 0 and r["flops"] > 0, cid
    for cid, a in report["agreement"].items():
        assert a["status"] == "single device" and a["must_match"] == (cid in ("pyramid", "masks/exact", "horizons",
                                                                                "horizons/radius", "horizons/sun_disc", "horizons/blocks", "horizons/radius_blocks",
                                                                                "sunshine/masks",
                                                                                "masks/sun_field"))
    for fam in FAMILIES:
        p = report["portability"]["families"][fam]
        assert 0 < p["pp"] <= 10 and p["pp"] == pytest.approx(p["efficiency"][dev["key"]]), fam
    # the exact traversals give the same mask
    cases = dev["cases"]
    assert cases["masks/exact"]["digest"] == cases["masks/maxmip"]["digest"] == cases["masks/dda"]["digest"]


def test_markdown_and_png_written(run):
    out = run[2]
    md = (out / "bench.md").read_text()
    for heading in ("## Devices", "## Outputs across devices", "## Performance portability"):
        assert heading in md
    assert "masks/exact" in md
    assert f"- CPU: {json.loads((out / 'bench.json').read_text())['machine']['cpu']} (" in md
    assert (out / "bench.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_compare_flags_a_regression_and_exits_3(run, report, tmp_path, capsys):
    old = copy.deepcopy(report)
    cases = old["devices"][0]["cases"]
    cases["masks/exact"]["median_ms"] = 1e-6          # "before" it took a nanosecond
    cases["pyramid"]["digest"] = "0" * 64              # the pyramid's bits "changed"
    path = tmp_path / "old.json"
    path.write_text(json.dumps(old))
    assert main([*TINY, "--quiet", "--compare", str(path), "--threshold", "50"]) == 3
    out = capsys.readouterr().out
    assert re.search(r"REGRESSION .*: masks/exact: median .* \(\+\d+ %\)", out), out
    assert re.search(r"REGRESSION .*: pyramid: outputs changed", out), out


def test_compare_with_itself_passes(run, capsys):
    old = run[2] / "bench.json"
    assert main([*TINY, "--quiet", "--compare", str(old), "--threshold", "100000"]) == 0
    assert "0 regression(s)" in capsys.readouterr().out


@pytest.mark.parametrize("args, message", [
    (["--threshold", "5"], "--threshold needs --compare"),
    (["--compare", "/nonexistent/bench.json"], "cannot read"),
    (["--threshold", "-1"], "--threshold must be"),
    (["--reps", "0"], "--reps must be"),
])
def test_bad_arguments_exit_2(args, message, capsys):
    assert main(["bench", "--sizes", "tiny", *args]) == 2
    err = capsys.readouterr().err
    assert message in err and err.startswith("oclshade: error:"), err


def test_compare_refuses_other_sizes(report, tmp_path, capsys):
    path = tmp_path / "old.json"
    path.write_text(json.dumps(report))
    assert main(["bench", "--quick", "--compare", str(path)]) == 2
    assert "'tiny' sizes" in capsys.readouterr().err


def _two_devices(report: dict) -> dict:
    """The report with a made-up second device: the first one's results under another key."""
    twin = copy.deepcopy(report["devices"][0])
    twin["key"] = "Made-up platform / twin"
    out = copy.deepcopy(report)
    out["devices"].append(twin)
    return _refresh(out)


def _refresh(report: dict) -> dict:
    report["agreement"] = agreement(report["cases"], report["devices"])
    report["portability"] = portability(report["cases"], report["devices"])
    return report


def test_two_devices_agree_and_pp_is_the_harmonic_mean(report):
    two = _two_devices(report)
    two["devices"][1]["cases"]["masks/paper"]["roofline_ms"] /= 2.0     # half the efficiency
    two["devices"][1]["cases"]["masks/paper"]["roofline_fraction"] /= 2.0
    agree = agreement(two["cases"], two["devices"])
    assert {a["status"] for a in agree.values()} == {"identical"}
    pp = portability(two["cases"], two["devices"])
    e = report["devices"][0]["cases"]["masks/paper"]["roofline_fraction"]
    assert pp["cases"]["masks/paper"]["pp"] == pytest.approx(2.0 / (1.0 / e + 2.0 / e))
    assert pennycook([0.5, 0.25]) == pytest.approx(1.0 / 3.0)
    assert pennycook([0.5, None]) == 0.0 and pennycook([]) == 0.0


def test_a_mismatch_of_exact_outputs_is_flagged_loudly(report):
    two = _two_devices(report)
    two["devices"][1]["cases"]["pyramid"]["digest"] = "f" * 64
    two["devices"][1]["cases"]["render/march"]["digest"] = "e" * 64
    _refresh(two)
    assert two["agreement"]["render/march"]["status"] == "differs"
    assert mismatches(two) == ["pyramid"]               # render/march need not match
    assert "MISMATCH: exact outputs differ between devices: pyramid" in summary(two)


def test_a_failed_case_makes_pp_zero_and_is_a_regression(report):
    two = _two_devices(report)
    failed = two["devices"][1]["cases"]["ssao/paper"]
    failed.update(error="ProgramBuildError: made up", min_ms=None, median_ms=None, roofline_ms=None,
                  roofline_fraction=None, digest=None)
    pp = portability(two["cases"], two["devices"])
    assert pp["families"]["ssao"]["pp"] == 0.0 and pp["cases"]["ssao/paper"]["pp"] == 0.0
    assert pp["families"]["masks"]["pp"] > 0
    found, notes = compare(two, _two_devices(report), threshold_pct=1e6)
    assert [(f.case, f.kind) for f in found] == [("ssao/paper", "failed")] and notes == []
