"""The benchmark's outputs: the summary table (stdout), ``bench.json``, ``bench.md`` and
``bench.png`` (matplotlib, when installed)."""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

from .portability import failures, mismatches


def number(value: float) -> str:
    """3 significant digits, without an exponent up to 10^6."""
    return f"{value:.0f}" if 1e3 <= abs(value) < 1e6 else f"{value:.3g}"


def _ms(value: float | None) -> str:
    return "-" if value is None else number(value)


def _pct(value: float | None) -> str:
    return "-" if value is None else number(100 * value)


def _roof(device: dict) -> str:
    r = device["roofline"]
    return "roofline not measured" if r is None else f"{number(r['bandwidth_gbs'])} GB/s, {number(r['gflops'])} GFLOP/s"


def _table(head: list[str], rows: list[list[str]], right: set[int]) -> list[str]:
    widths = [max(len(r[k]) for r in (head, *rows)) for k in range(len(head))]
    fmt = lambda r: "  ".join(c.rjust(w) if k in right else c.ljust(w)  # noqa: E731
                              for k, (c, w) in enumerate(zip(r, widths))).rstrip()
    return [fmt(head), *(fmt(r) for r in rows)]


def summary(report: dict) -> str:
    """The plain-text summary: devices, per case the median time and roofline share on each
    device and whether the outputs agree, PP per family, and what went wrong."""
    devices = report["devices"]
    lines = [f"oclshade bench ({report['sizes']} sizes, {report['reps']} reps; times in ms, "
             "roof% = share of the device's measured roofline)"]
    for n, d in enumerate(devices):
        lines.append(f"  [{n}] {d['key']} (driver {d['driver_version']}): {_roof(d)}")
    head = ["case"] + [h for n in range(len(devices)) for h in (f"[{n}] median", f"[{n}] roof%")] + ["outputs"]
    rows = []
    for case in report["cases"]:
        cid = case["id"]
        cells = [cid]
        for d in devices:
            r = d["cases"][cid]
            cells += ["FAILED", "-"] if r["error"] else [_ms(r["median_ms"]), _pct(r["roofline_fraction"])]
        a = report["agreement"][cid]
        cells.append(a["status"] + (" (must match)" if a["must_match"] else ""))
        rows.append(cells)
    lines += [""] + _table(head, rows, set(range(1, 1 + 2 * len(devices))))
    fam_head = ["family", "PP"] + [f"[{n}] eff" for n in range(len(devices))]
    fam_rows = [[fam, f"{p['pp']:.3g}"] + [_ms(p["efficiency"][d["key"]]) for d in devices]
                for fam, p in report["portability"]["families"].items()]
    lines += ["", "performance portability (harmonic mean over devices of the roofline share; 0 if one fails):"]
    lines += _table(fam_head, fam_rows, set(range(1, 2 + len(devices))))
    bad = mismatches(report)
    if bad:
        lines += ["", f"MISMATCH: exact outputs differ between devices: {', '.join(bad)}"]
    failed = failures(report)
    if failed:
        lines += ["", f"FAILED: {'; '.join(failed)}"]
    return "\n".join(lines)


def _atomic_write(path: Path, data: bytes) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_json(path: Path, report: dict) -> None:
    _atomic_write(path, (json.dumps(report, indent=1) + "\n").encode())


def markdown(report: dict) -> str:
    """``bench.md``: machine, devices, per-device case tables, output agreement, PP."""
    m = report["machine"]
    devices = report["devices"]
    out = ["# oclshade bench", "",
           f"`{report['command']}`: {report['sizes']} sizes, {report['reps']} timed repetitions per case after a "
           f"warm-up (builds excluded), {m['date']}.", "",
           f"- CPU: {m['cpu']} ({m['cores']} logical cores); OS: {m['os']}",
           f"- oclshade {m['oclshade']}, Python {m['python']}, pyopencl {m['pyopencl']}, numpy {m['numpy']}", ""]
    bad = mismatches(report)
    if bad:
        out += [f"**MISMATCH: exact outputs differ between devices: {', '.join(bad)}**", ""]
    failed = failures(report)
    if failed:
        out += [f"**FAILED: {'; '.join(failed)}**", ""]
    out += ["## Devices", "",
            "| # | device | platform version | device version | driver | CUs | MHz | copy GB/s | GFLOP/s |",
            "|---|---|---|---|---|---:|---:|---:|---:|"]
    for n, d in enumerate(devices):
        r = d["roofline"] or {}
        out.append(f"| {n} | {d['key']} | {d['platform_version']} | {d['version']} | {d['driver_version']} | "
                   f"{d['compute_units']} | {d['max_clock_mhz']} | {_ms(r.get('bandwidth_gbs'))} | "
                   f"{_ms(r.get('gflops'))} |")
    out += ["", "Roofline probes (kernels/roofline.cl): float4 copy bandwidth; the best multiply-add rate over "
            "vector widths, mad() or a separate multiply and add. Work model per case: `oclshade/bench/suite.py`.", ""]
    for n, d in enumerate(devices):
        out += [f"## [{n}] {d['key']}", "", "| case | what | reps | min ms | median ms | throughput /s | "
                "MB | MFLOP | roofline % | digest |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---|"]
        for cid, r in d["cases"].items():
            if r["error"]:
                out.append(f"| {cid} | {r['what'] or ''} | FAILED: {r['error']} | | | | | | | |")
                continue
            out.append(f"| {cid} | {r['what']} | {r['reps']} | {_ms(r['min_ms'])} | {_ms(r['median_ms'])} | "
                       f"{r['throughput_per_s']:.3g} {r['unit']} | {number(r['bytes'] / 1e6)} | "
                       f"{number(r['flops'] / 1e6)} | {_pct(r['roofline_fraction'])} | `{r['digest'][:12]}` |")
        out.append("")
    out += ["## Outputs across devices", "", "| case | must match | status | " +
            " | ".join(f"[{n}]" for n in range(len(devices))) + " |",
            "|---|---|---|" + "---|" * len(devices)]
    for cid, a in report["agreement"].items():
        digests = " | ".join(f"`{a['digests'][d['key']][:12]}`" if a["digests"][d["key"]] else "-" for d in devices)
        status = f"**{a['status']}**" if a["must_match"] and a["status"] == "differs" else a["status"]
        out.append(f"| {cid} | {'yes' if a['must_match'] else 'no'} | {status} | {digests} |")
    out += ["", "## Performance portability", "",
            "Pennycook's PP: the harmonic mean over the devices of the efficiency, here the share of the "
            "device's measured roofline reached (per family: summed roofline time over summed best time of "
            "its cases); 0 when a device fails a case.", "",
            "| family | PP | " + " | ".join(f"[{n}] efficiency" for n in range(len(devices))) + " |",
            "|---|---:|" + "---:|" * len(devices)]
    for fam, p in report["portability"]["families"].items():
        out.append(f"| {fam} | {p['pp']:.3g} | " + " | ".join(_ms(p["efficiency"][d["key"]]) for d in devices) + " |")
    if report.get("compare"):
        c = report["compare"]
        out += ["", "## Compared with an earlier run", "",
                f"`{c['against']}` ({c['against_date']}), threshold {c['threshold_pct']:g} % on the median time: "
                f"{len(c['regressions'])} regression(s).", ""]
        out += [f"- {f['device']}: {f['case']}: {f['detail']}" for f in c["regressions"]]
        out += [f"- note: {note}" for note in c["notes"]]
    return "\n".join(out) + "\n"


def write_markdown(path: Path, report: dict) -> None:
    _atomic_write(path, markdown(report).encode())


def write_plots(path: Path, report: dict) -> bool:
    """``bench.png``: best time per case per device (log scale) and the share of the roofline
    per case per device.  Returns False, writing nothing, when matplotlib is not installed."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.ticker import FormatStrFormatter
    except ImportError:
        return False
    devices = report["devices"]
    ids = [c["id"] for c in report["cases"]]
    fig = Figure(figsize=(12, 0.35 * len(ids) * max(len(devices), 1) + 2.5))
    FigureCanvasAgg(fig)
    height = 0.8 / max(len(devices), 1)
    for k, (key, label, scale) in enumerate((("min_ms", "best time (ms)", 1.0),
                                             ("roofline_fraction", "share of the roofline (%)", 100.0))):
        ax = fig.add_subplot(1, 2, k + 1)
        for n, d in enumerate(devices):
            ys = [i + n * height for i in range(len(ids))]
            vals = [(d["cases"][cid][key] or 0.0) * scale for cid in ids]
            ax.barh(ys, vals, height=height, label=f"[{n}] {d['key']}")
        ax.set_yticks([i + (len(devices) - 1) * height / 2 for i in range(len(ids))])
        ax.set_yticklabels(ids if k == 0 else [])
        ax.invert_yaxis()
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(FormatStrFormatter(""))
        ax.set_xlabel(label)
        ax.grid(axis="x", alpha=0.3)
    fig.axes[0].legend(loc="lower left", bbox_to_anchor=(0.0, 1.01), fontsize=8)
    fig.suptitle(f"oclshade bench, {report['sizes']} sizes, {report['machine']['date']}", y=0.995)
    fig.tight_layout()
    fig.savefig(str(path), dpi=100)
    return True
