"""Across devices: do the outputs agree, and how portable is the performance?

Performance portability (Pennycook, Sewall and Lee, 2016) of an application
``a`` solving problem ``p`` over the platforms ``H``::

    PP(a, p, H) = |H| / sum_i 1 / e_i(a, p)   if every platform i in H runs it,
                  0                            otherwise,

the harmonic mean of the efficiencies.  Here the efficiency is architectural:
the fraction of the device's measured roofline (:mod:`.roofline`) reached.
For a case that is its ``roofline_fraction``; for a kernel family it is the
family's roofline time over its measured time, summed over the family's
cases (the fraction of the roofline the family's whole workload reaches; a
slow case weighs by its time).  A device that fails a case, or whose roofline
could not be measured, has no efficiency there, and PP is 0.  With one
device PP is that device's efficiency.
"""
from __future__ import annotations

from typing import Sequence


def pennycook(efficiencies: Sequence[float | None]) -> float:
    """The harmonic mean of the efficiencies; 0 when one is missing (None) or 0, or none is given."""
    if not efficiencies or any(e is None or e <= 0 for e in efficiencies):
        return 0.0
    return len(efficiencies) / sum(1.0 / e for e in efficiencies)   # type: ignore[operator]


def family_efficiency(device: dict, family: str) -> float | None:
    """Sum of roofline times over sum of best times of the family's cases on one device;
    None if a case of the family failed there or has no roofline time."""
    results = [r for r in device["cases"].values() if r["family"] == family]
    if not results or any(r["roofline_ms"] is None or r["min_ms"] is None for r in results):
        return None
    return sum(r["roofline_ms"] for r in results) / sum(r["min_ms"] for r in results)


def portability(cases: Sequence[dict], devices: Sequence[dict]) -> dict[str, dict]:
    """PP and the efficiency on each device, per kernel family and per case."""
    families = list(dict.fromkeys(c["family"] for c in cases))
    by_family = {}
    for fam in families:
        eff = {d["key"]: family_efficiency(d, fam) for d in devices}
        by_family[fam] = {"pp": pennycook(list(eff.values())), "efficiency": eff}
    by_case = {}
    for case in cases:
        eff = {d["key"]: d["cases"][case["id"]]["roofline_fraction"] for d in devices}
        by_case[case["id"]] = {"pp": pennycook(list(eff.values())), "efficiency": eff}
    return {"families": by_family, "cases": by_case}


def agreement(cases: Sequence[dict], devices: Sequence[dict]) -> dict[str, dict]:
    """Per case: each device's output digest and a status: "identical" (every device ran it
    and got the same bits), "differs", "single device" or "incomplete" (a device failed it).
    ``must_match`` is set for the exact cases, whose outputs must be identical."""
    out = {}
    for case in cases:
        digests = {d["key"]: d["cases"][case["id"]]["digest"] for d in devices}
        found = [v for v in digests.values() if v is not None]
        if len(found) < len(digests):
            status = "incomplete"
        elif len(found) == 1:
            status = "single device"
        else:
            status = "identical" if len(set(found)) == 1 else "differs"
        out[case["id"]] = {"must_match": case["exact"], "status": status, "digests": digests}
    return out


def mismatches(report: dict) -> list[str]:
    """Exact cases whose outputs differ between devices (a bug: flagged loudly)."""
    return [cid for cid, a in report["agreement"].items() if a["must_match"] and a["status"] == "differs"]


def failures(report: dict) -> list[str]:
    """"device: case" for every case that failed, and "device: roofline" where the probes did."""
    out = [f"{d['key']}: roofline" for d in report["devices"] if d["error"] is not None]
    out += [f"{d['key']}: {cid}" for d in report["devices"] for cid, r in d["cases"].items() if r["error"] is not None]
    return out
