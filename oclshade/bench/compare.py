"""``--compare OLD.json``: which cases got slower, changed their outputs or started failing.

Devices are matched by their key ("platform / device", see
:func:`oclshade.bench.machine.device_key`), cases by id.  A regression is a
case whose median time grew by more than the threshold, whose output digest
changed, or that failed now but not then.  Devices and cases found in only
one of the two runs are notes, not regressions.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

from .report import number
from .runner import SCHEMA


@dataclass(frozen=True)
class Finding:
    device: str
    case: str
    kind: str        # "slower", "digest" or "failed"
    detail: str


def load_report(path: str | Path, what: str = "--compare") -> dict:
    """A ``bench.json`` written by this version's schema; errors name ``what`` and the file."""
    try:
        report = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{what} {path}: cannot read: {exc}") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{what} {path}: not JSON: {exc}") from None
    if not isinstance(report, dict) or report.get("schema") != SCHEMA:
        found = report.get("schema") if isinstance(report, dict) else type(report).__name__
        raise ValueError(f"{what} {path}: not an 'oclshade bench' report of schema {SCHEMA} (found {found!r})")
    return report


def compare(new: dict, old: dict, threshold_pct: float) -> tuple[list[Finding], list[str]]:
    """(regressions, notes) of ``new`` against ``old``; ``threshold_pct``: how much slower
    (per cent, on the median time) counts as a regression."""
    if not threshold_pct >= 0:
        raise ValueError(f"threshold_pct must be >= 0, got {threshold_pct!r}")
    if new["sizes"] != old["sizes"]:
        raise ValueError(f"the runs used different sizes ({old['sizes']!r} then {new['sizes']!r}): not comparable")
    found: list[Finding] = []
    notes: list[str] = []
    old_devices = {d["key"]: d for d in old["devices"]}
    for dev in new["devices"]:
        before = old_devices.pop(dev["key"], None)
        if before is None:
            notes.append(f"{dev['key']}: not in the earlier run")
            continue
        for cid, now in dev["cases"].items():
            then = before["cases"].get(cid)
            if then is None:
                notes.append(f"{dev['key']}: {cid}: not in the earlier run")
                continue
            found += _case(dev["key"], cid, now, then, threshold_pct, notes)
    notes += [f"{key}: in the earlier run only" for key in old_devices]
    return found, notes


def _case(key: str, cid: str, now: dict, then: dict, threshold_pct: float, notes: list[str]) -> list[Finding]:
    if now["error"] is not None:
        if then["error"] is None:
            return [Finding(key, cid, "failed", f"fails now ({now['error']}), ran before")]
        return []
    if then["error"] is not None:
        notes.append(f"{key}: {cid}: runs now, failed before")
        return []
    out = []
    ratio = now["median_ms"] / then["median_ms"]
    if ratio > 1.0 + threshold_pct / 100.0:
        out.append(Finding(key, cid, "slower", f"median {number(now['median_ms'])} ms against "
                                               f"{number(then['median_ms'])} ms (+{100 * (ratio - 1):.0f} %)"))
    if now["digest"] != then["digest"]:
        why = " (its input changed too)" if now["input_digest"] != then["input_digest"] else ""
        out.append(Finding(key, cid, "digest", f"outputs changed{why}: {then['digest'][:12]} -> {now['digest'][:12]}"))
    return out


def comparison(new: dict, old: dict, against: str, threshold_pct: float) -> dict:
    """The ``compare`` section of a report."""
    found, notes = compare(new, old, threshold_pct)
    return {"against": against, "against_date": old["machine"]["date"], "threshold_pct": threshold_pct,
            "regressions": [asdict(f) for f in found], "notes": notes}


def format_comparison(section: dict) -> str:
    lines = [f"compared with {section['against']} ({section['against_date']}), threshold "
             f"{section['threshold_pct']:g} %: {len(section['regressions'])} regression(s)"]
    lines += [f"  REGRESSION {f['device']}: {f['case']}: {f['detail']}" for f in section["regressions"]]
    lines += [f"  note: {n}" for n in section["notes"]]
    return "\n".join(lines)
