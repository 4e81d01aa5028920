"""Runs the roofline probes and every case on each device and gathers the report (a dict,
written as ``bench.json``; its layout is in :mod:`oclshade.bench`)."""
from __future__ import annotations

import time
from typing import Callable, Sequence

from ..runtime import DeviceInfo, get_runtime
from ..tuning import families, settings
from .machine import device_facts, device_key, machine_facts
from .portability import agreement, portability
from .report import number
from .roofline import Roofline, measure_roofline, roofline_seconds
from .suite import FAMILIES, SPECS, CaseSpec, Sizes, Workload, digest
from .timing import time_case

SCHEMA = "oclshade-bench/1"
Progress = Callable[[str], None]


def _error_text(exc: BaseException) -> str:
    lines = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {lines[0] if lines else ''}".rstrip(": ")


def _empty_result(spec: CaseSpec) -> dict[str, object]:
    return {"family": spec.family, "exact": spec.exact, "what": None, "unit": None, "items": None,
            "input_digest": None, "reps": 0, "times_ms": [], "warm_up_ms": None, "min_ms": None,
            "median_ms": None, "throughput_per_s": None, "bytes": None, "flops": None, "roofline_ms": None,
            "roofline_fraction": None, "digest": None, "error": None}


def run_case(spec: CaseSpec, workload: Workload, roof: Roofline | None, reps: int) -> dict[str, object]:
    """One case on one device: prepare, warm up, time, digest; a failure is recorded in
    ``error`` (the other cases go on)."""
    out = _empty_result(spec)
    try:
        case = spec.prepare(workload)
        out.update(what=case.what, unit=case.unit, items=case.items, input_digest=case.input_digest,
                   bytes=case.nbytes, flops=case.flops)
        timing = time_case(case.run, reps, workload.sizes.max_case_s)
        out["digest"] = digest(case.outputs())
    except Exception as exc:  # noqa: BLE001 - a device that fails a case is a result, not a crash
        out["error"] = _error_text(exc)
        return out
    best = timing.min_s
    out.update(reps=len(timing.seconds), times_ms=[1e3 * s for s in timing.seconds],
               warm_up_ms=1e3 * timing.warm_up_s, min_ms=1e3 * best, median_ms=1e3 * timing.median_s,
               throughput_per_s=case.items / best)
    if roof is not None:
        bound = roofline_seconds(case.nbytes, case.flops, roof)
        out.update(roofline_ms=1e3 * bound, roofline_fraction=bound / best)
    return out


def _describe(case_id: str, r: dict[str, object]) -> str:
    if r["error"] is not None:
        return f"{case_id}: FAILED: {r['error']}"
    frac = "" if r["roofline_fraction"] is None else f", {100 * r['roofline_fraction']:.2g}% of roofline"
    return (f"{case_id}: {number(r['min_ms'])} ms (median {number(r['median_ms'])}, {r['reps']} reps), "
            f"{number(r['throughput_per_s'] / 1e6)} M{r['unit']}/s{frac}")


def bench_device(info: DeviceInfo, key: str, sizes: Sizes, reps: int, progress: Progress) -> dict[str, object]:
    """Roofline and cases of one device (``reps`` timed repetitions per case)."""
    rt = get_runtime(info.index)
    out: dict[str, object] = {**device_facts(rt, info, key), "roofline": None, "error": None, "cases": {}}
    roof = None
    try:
        t0 = time.perf_counter()
        roof = measure_roofline(rt, sizes.copy_bytes, sizes.probe_s)
        out["roofline"] = roof.as_dict()
        progress(f"{key}: roofline {number(roof.bandwidth_gbs)} GB/s, {number(roof.gflops)} GFLOP/s "
                 f"({time.perf_counter() - t0:.1f} s)")
    except Exception as exc:  # noqa: BLE001
        out["error"] = f"roofline probes failed: {_error_text(exc)}"
        progress(f"{key}: {out['error']}")
    workload = Workload(rt, sizes)
    for spec in SPECS:
        result = run_case(spec, workload, roof, reps)
        out["cases"][spec.id] = result
        progress(f"{key}: {_describe(spec.id, result)}")
    out["tuning"] = {}
    for name in sorted(families()):
        decision = settings(rt, name)
        out["tuning"][name] = {"values": dict(decision.values), "source": decision.source}
    return out


def run_benchmark(infos: Sequence[DeviceInfo], sizes: Sizes, reps: int, command: str,
                  progress: Progress) -> dict[str, object]:
    """The whole report: machine facts, each device's roofline and cases, the cross-device
    digest agreement and the performance-portability metric."""
    if not infos:
        raise ValueError("infos: no OpenCL device to benchmark")
    everyone = list(infos)
    devices = []
    for n, info in enumerate(everyone, 1):
        key = device_key(info, everyone)
        progress(f"device {n}/{len(everyone)}: {key} ({sizes.name} sizes, {reps} reps)")
        devices.append(bench_device(info, key, sizes, reps, progress))
    cases = [{"id": s.id, "family": s.family, "exact": s.exact} for s in SPECS]
    return {
        "schema": SCHEMA,
        "command": command,
        "sizes": sizes.name,
        "reps": reps,
        "machine": machine_facts(),
        "families": list(FAMILIES),
        "cases": cases,
        "devices": devices,
        "agreement": agreement(cases, devices),
        "portability": portability(cases, devices),
    }
