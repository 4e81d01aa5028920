"""Per-device tuning: the lookup order, probes that survive crashing and hanging compilers,
kernel caches that recover, and quiet builds."""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest

from oclshade import cachedir, tuning
from oclshade.runtime import get_runtime
from oclshade.tuning import probe, store
from oclshade.tuning.device import DeviceKey
from oclshade.tuning.rules import rule_values

CANYON = Path(__file__).resolve().parent.parent / "data" / "canyon_512.tif"


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A fresh user cache (tuning entries, probe records) and no shipped entry, for one test."""
    monkeypatch.setenv(cachedir.CACHE_ENV, str(tmp_path / "cache"))
    monkeypatch.setattr(store, "shipped_entries", lambda: ())
    cachedir.cache_root.cache_clear()
    tuning.clear()
    yield tmp_path / "cache"
    cachedir.cache_root.cache_clear()
    tuning.clear()


def shadow_family() -> tuning.Family:
    return tuning.family("shadow")


def rule_lanes() -> int:
    return rule_values(shadow_family(), get_runtime().device)["lanes"]


def test_rule_follows_the_target_vector_width():
    from oclshade.tuning.rules import float_lanes
    dev = get_runtime().device
    width = float_lanes(dev)
    lanes = rule_lanes()
    if dev.type & cl.device_type.CPU:
        assert lanes == max([v for v in (4, 8, 16) if v <= width], default=0)
    else:
        assert lanes == 0


class FakeDevice:
    def __init__(self, version: str, native: int = 8):
        self.version, self.native_vector_width_float = version, native


@pytest.mark.parametrize("target,lanes", [("znver3", 8), ("haswell", 8), ("penryn", 4), ("skylake-avx512", 16),
                                          ("znver4", 16), ("x86-64-v3", 8), ("x86-64", 4), ("sandybridge", 8)])
def test_target_lanes_come_from_the_compiler_target_not_the_host(target, lanes):
    from oclshade.tuning.rules import float_lanes
    assert float_lanes(FakeDevice(f"OpenCL 3.0 PoCL HSTR: pthread-x86_64-pc-linux-gnu-{target}", 16)) == lanes
    assert float_lanes(FakeDevice("OpenCL 3.0 CUDA", 1)) == 1


class FakeDriver:
    def __init__(self, version: str, driver: str, type_: int = cl.device_type.CPU):
        self.version, self.driver_version, self.type = version, driver, type_
        self.native_vector_width_float, self.host_unified_memory = 8, True


@pytest.mark.parametrize("version,driver,inline", [
    ("OpenCL 3.0 PoCL HSTR: pthread-x86_64-unknown-linux-gnu-znver1", "3.0-rc2", 1),        # the PyPI wheel
    ("OpenCL 3.0 PoCL HSTR: pthread-x86_64-pc-linux-gnu-haswell", "3.1+debian", 0),        # Debian's 3.1
    ("OpenCL 3.0 PoCL HSTR: pthread-x86_64-pc-linux-gnu-haswell", "4.0", 0),
    ("OpenCL 3.0 CUDA", "3.0.1", 0)])                                                      # not PoCL
def test_inline_builtins_follow_the_driver_that_leaves_them_as_calls(version, driver, inline):
    """The rule turns own_builtins on, on PoCL 3.0's CPU devices, for the families that declare
    rule="library_calls" (pyramid, shadow, terrain, screen_shadows, horizon), and never for SSAO."""
    device = FakeDriver(version, driver)
    for name in ("pyramid", "shadow", "terrain", "screen_shadows", "horizon"):
        assert rule_values(tuning.family(name), device)["own_builtins"] == inline, name
    assert rule_values(tuning.family("ssao"), device)["own_builtins"] == 0
    gpu = FakeDriver(version, driver, cl.device_type.GPU)
    assert rule_values(tuning.family("terrain"), gpu)["own_builtins"] == 0



@pytest.mark.parametrize("target,lanes", [("penryn", 8), ("haswell", 8), ("znver3", 8), ("skylake-avx512", 16),
                                          ("rocketlake", 16)])
def test_ssao_lanes_follow_the_target_only_upwards(target, lanes):
    """SSAO's lanes (rule="wider") are 16 on AVX-512 targets and never below their safe 8."""
    device = FakeDriver(f"OpenCL 3.0 PoCL HSTR: pthread-x86_64-pc-linux-gnu-{target}", "3.1+debian")
    assert rule_values(tuning.family("ssao"), device)["lanes"] == lanes
    gpu = FakeDriver("OpenCL 3.0 CUDA", "580", cl.device_type.GPU)
    assert rule_values(tuning.family("ssao"), gpu)["lanes"] == 8

def test_lookup_order_user_then_shipped_then_rule(cache, monkeypatch):
    rt = get_runtime()
    fam, key = shadow_family(), DeviceKey.of(rt.device)
    monkeypatch.setenv(tuning.NO_PROBE_ENV, "1")
    assert tuning.decide(rt, fam).source == "rule"
    shipped = {"lanes": 4, "run": 256, "group": 16}
    entry = {"device": key.as_dict(), "families": {"shadow": {"values": shipped, "kernel_digest": "old"}}}
    monkeypatch.setattr(store, "shipped_entries", lambda: (entry,))
    d = tuning.decide(rt, fam)   # the knobs the entry lacks take the rule's values
    assert d.source == "shipped" and "measured with kernels old" in d.notes
    assert d.values == {**rule_values(fam, rt.device), **shipped}
    mine = {"lanes": 0, "own_builtins": 1, "gather": 1, "cert_tile": 32, "run": 64, "group": 256, "images": 1}
    store.save_user_values(key, fam, mine, {"best_ms": 1.0})
    assert (tuning.decide(rt, fam).values, tuning.decide(rt, fam).source) == (mine, "user")
    # an entry measured with other kernels no longer counts, and says so
    data = json.loads(store.user_path(key).read_text())
    data["families"]["shadow"]["kernel_digest"] = "0" * 16
    store.user_path(key).write_text(json.dumps(data))
    d = tuning.decide(rt, fam)
    assert d.source == "shipped" and any("re-run 'oclshade tune'" in n for n in d.notes)


def test_a_shipped_entry_of_another_cpu_does_not_match(cache, monkeypatch):
    rt = get_runtime()
    key = DeviceKey.of(rt.device).as_dict()
    other = dict(key, host_cpu="Some Other CPU (family 1 model 1; avx512f)")
    entry = {"device": other, "families": {"shadow": {"values": {"lanes": 4, "run": 256, "group": 16}}}}
    monkeypatch.setattr(store, "shipped_entries", lambda: (entry,))
    monkeypatch.setenv(tuning.NO_PROBE_ENV, "1")
    assert tuning.decide(rt, shadow_family()).source == "rule"


def faulty_rule_lanes(monkeypatch, fault: str, timeout: str) -> int:
    """The rule's lane count, its probe child set to misbehave (``fault``) under a time limit;
    skips where the rule picks no packets."""
    lanes = rule_lanes()
    if lanes == 0:
        pytest.skip("the rule picks no packets on this device: nothing to fall back from")
    monkeypatch.setenv(probe.FAULT_ENV, f"{fault}:lanes={lanes}")
    monkeypatch.setenv(probe.TIMEOUT_ENV, timeout)
    return lanes


@pytest.mark.parametrize("fault", ["abort", "hang", "fail"])
def test_a_variant_that_crashes_or_hangs_falls_back_and_is_remembered(cache, monkeypatch, fault):
    lanes = faulty_rule_lanes(monkeypatch, fault, "20")
    rt = get_runtime()
    fam = shadow_family()
    t0 = time.perf_counter()
    d = tuning.decide(rt, fam)
    assert d.values["lanes"] == max(v for v in (0, 4, 8, 16) if v < lanes)
    assert d.source in ("rule, narrowed", "safe")
    assert any("failed" in n for n in d.notes)
    if fault == "hang":
        assert time.perf_counter() - t0 < 120
    # remembered: the next lookup runs no child process
    with monkeypatch.context() as m:
        m.setattr(tuning, "run_probe", lambda *a: pytest.fail("probed again"))
        assert tuning.decide(rt, fam).values == d.values
    # and the fallback gives the same masks as the scalar kernel
    from oclshade import ShadowCaster
    from oclshade.heightmap import Heightmap
    from oclshade.synthetic import canyon_crater
    hm = Heightmap.from_array(canyon_crater(96), 30.0)
    got = ShadowCaster(hm, cache=False, knobs=d.values).cast((37.0, 20.0)).mask
    want = ShadowCaster(hm, cache=False, knobs={"lanes": 0}).cast((37.0, 20.0)).mask
    assert np.array_equal(got, want)


def test_a_probe_starved_of_cpu_is_not_a_verdict(cache, monkeypatch):
    """A child that times out without running (a loaded machine, a low priority) is not a
    hung compiler: this run falls back, nothing is remembered, the next run probes again."""
    lanes = faulty_rule_lanes(monkeypatch, "stall", "8")
    rt = get_runtime()
    fam = shadow_family()
    d = tuning.decide(rt, fam)
    assert d.values["lanes"] < lanes
    assert any(n.startswith(f"{store.values_id({**d.values, 'lanes': lanes})} unchecked")
               for n in d.notes), d.notes
    assert store.probe_record(DeviceKey.of(rt.device), fam, {**d.values, "lanes": lanes}) is None
    calls = []

    def ok(runtime, name, values):
        calls.append(values)
        return "ok"

    monkeypatch.setattr(tuning, "run_probe", ok)
    assert tuning.decide(rt, fam).values["lanes"] == lanes
    assert calls and calls[0]["lanes"] == lanes


def test_a_hung_probe_is_told_from_a_starved_one(monkeypatch):
    """The time-out verdict follows the child's CPU time: a spinning child is hung, a
    sleeping one unchecked."""
    rt = get_runtime()
    fam = shadow_family()
    values = {**fam.safe(), "lanes": 4}
    monkeypatch.setenv(probe.TIMEOUT_ENV, "6")
    monkeypatch.setenv(probe.FAULT_ENV, "hang:lanes=4")
    assert probe.run_probe(rt, "shadow", values).startswith("failed: no answer within 6 s")
    monkeypatch.setenv(probe.TIMEOUT_ENV, "10")       # the child's imports take about 1 s of CPU
    monkeypatch.setenv(probe.FAULT_ENV, "stall:lanes=4")
    assert probe.run_probe(rt, "shadow", values).startswith("unchecked: the probe got")


def _child_env(cache_dir: Path, **extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("POCL_CACHE_DIR", "OCLSHADE_DEBUG")}
    env.update({cachedir.CACHE_ENV: str(cache_dir), "PYTHONDONTWRITEBYTECODE": "1"}, **extra)
    return env


MASK_SCRIPT = """
import sys
from oclshade import cast_shadows
from oclshade.synthetic import canyon_crater
m = cast_shadows(canyon_crater(80), 30.0, (37.0, 20.0), cache=False).mask
print("shadowed", int(m.sum()))
"""


def test_a_build_killed_half_way_does_not_break_later_runs(tmp_path):
    cache_dir = tmp_path / "cache"
    reference = subprocess.run([sys.executable, "-c", MASK_SCRIPT], env=_child_env(tmp_path / "ref"),
                               capture_output=True, text=True, timeout=600)
    assert reference.returncode == 0, reference.stderr
    for delay in (1.0, 2.5):   # mid-probe / mid-build on this machine
        proc = subprocess.Popen([sys.executable, "-c", MASK_SCRIPT], env=_child_env(cache_dir),
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        time.sleep(delay)
        os.killpg(proc.pid, signal.SIGKILL)   # the process and its probe children
        proc.wait()
        again = subprocess.run([sys.executable, "-c", MASK_SCRIPT], env=_child_env(cache_dir),
                               capture_output=True, text=True, timeout=600)
        assert again.returncode == 0, again.stderr
        assert again.stdout == reference.stdout


def test_a_cached_program_without_kernels_is_rebuilt(tmp_path):
    """PoCL's cache entry of the shadow program replaced by one of a program with no kernel of
    that name (what a build that crashed half-way left behind): the run purges and rebuilds."""
    cache_dir = tmp_path / "cache"
    first = subprocess.run([sys.executable, "-c", MASK_SCRIPT], env=_child_env(cache_dir, OCLSHADE_NO_PROBE="1"),
                           capture_output=True, text=True, timeout=600)
    assert first.returncode == 0, first.stderr
    pocl = next(cache_dir.glob("kernels-*/pocl"), None)
    entries = [p.parent for p in pocl.rglob("program.bc")] if pocl else []
    if not entries:
        pytest.skip("the OpenCL driver keeps no PoCL-style kernel cache here")
    empty = subprocess.run([sys.executable, "-c", """
import pyopencl as cl
from oclshade.runtime import get_runtime
rt = get_runtime()
cl.Program(rt.context, "__kernel void unrelated(__global float *x) { x[0] = 1.0f; }").build()
"""], env=_child_env(cache_dir), capture_output=True, text=True, timeout=600)
    assert empty.returncode == 0, empty.stderr
    bogus = next(p.parent for p in pocl.rglob("program.bc") if p.parent not in entries)
    for entry in entries:
        (entry / "program.bc").write_bytes((bogus / "program.bc").read_bytes())
        for sub in entry.iterdir():
            if sub.is_dir():
                for f in sub.rglob("*.so"):
                    f.unlink()
    for p in cache_dir.glob("kernels-*/pyopencl"):
        shutil.rmtree(p)
    again = subprocess.run([sys.executable, "-c", MASK_SCRIPT], env=_child_env(cache_dir, OCLSHADE_NO_PROBE="1"),
                           capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    assert again.stdout == first.stdout


def test_first_run_is_quiet_but_for_one_line_and_later_runs_silent(tmp_path):
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "oclshade", "shadow", str(CANYON), str(out / "m.tif"), "-az", "315", "-alt", "20"]
    env = _child_env(tmp_path / "cache")
    cold = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert cold.returncode == 0, cold.stderr
    lines = cold.stderr.strip().splitlines()
    assert len(lines) == 2, cold.stderr   # the first-run line, then the run's summary
    assert lines[0].startswith("oclshade: compiling OpenCL kernels for"), cold.stderr
    assert lines[1].startswith("oclshade: 512x512 cells, 1 sun(s)"), cold.stderr
    assert "warning" not in (cold.stdout + cold.stderr).lower()
    warm = subprocess.run(cmd + ["--quiet"], env=env, capture_output=True, text=True, timeout=600)
    assert warm.returncode == 0 and warm.stderr == "" and warm.stdout == "", warm.stderr


def test_tune_writes_an_entry_that_the_lookup_then_uses(cache, capsys):
    from oclshade.cli import main

    assert main(["tune", "--quick", "--family", "pyramid"]) == 0
    out = capsys.readouterr().out
    assert "pyramid" in out and "written:" in out
    rt = get_runtime()
    fam = tuning.family("pyramid")
    entry = json.loads(store.user_path(DeviceKey.of(rt.device)).read_text())["families"]["pyramid"]
    assert entry["kernel_digest"] == store.kernel_digest(fam)
    assert entry["measured"]["best_ms"] > 0 and entry["measured"]["safe_ms"] > 0
    tuning.clear()
    d = tuning.settings(rt, "pyramid")
    assert d.source == "user" and d.values == entry["values"]
    # and devices says so
    assert main(["devices", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    mine = [r for r in listed if r["key"] == DeviceKey.of(rt.device).as_dict()]
    assert mine and mine[0]["tuning"]["pyramid"]["source"] == "user"


def test_the_tuner_leaves_a_knob_that_chooses_at_run_time(monkeypatch):
    """A knob declared ``tuned=False`` (horizon sweep_far: its pilot chooses per map) keeps its
    start value through the search, while the others are measured at each of their values."""
    from oclshade.tuning import tuner

    seen: list[dict[str, int]] = []

    def workload(runtime, values, quick):
        seen.append(dict(values))
        return lambda: time.sleep(0.002 if values["fast"] else 0.004)

    fam = tuning.Family("fake", (tuning.Param("fast", (0, 1), 0, "tuned"),
                                 tuning.Param("chooses", (0, 1, 2), 1, "chosen at run time", tuned=False)),
                        (), lambda runtime, values: None, workload)
    monkeypatch.setattr(tuner, "probed", lambda *args: True)
    best, measured = tuner.tune_family(get_runtime(), fam, {"fast": 0, "chooses": 1}, quick=True,
                                       report=lambda line: None)
    assert best == {"fast": 1, "chooses": 1}
    assert {v["fast"] for v in seen} == {0, 1} and {v["chooses"] for v in seen} == {1}
    assert tuning.family("horizon").param("sweep_far").tuned is False
