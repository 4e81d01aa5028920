"""The ``devices`` and ``tune`` commands: what each device gets, and measuring it."""
from __future__ import annotations

import argparse
import json
import sys

from ..runtime import get_runtime, list_devices
from . import families, settings, store
from .device import DeviceKey


def add_parsers(sub) -> None:
    dev = sub.add_parser("devices", help="list OpenCL devices and the tuning each gets",
                         description="List the OpenCL devices (use an index or a name substring with --device "
                                     "or OCLSHADE_DEVICE) and, per kernel family, the tuning values each gets "
                                     "and which source decided them: user (oclshade tune), shipped (the "
                                     "package's database), rule (device properties) or safe.")
    dev.add_argument("--json", action="store_true", help="machine-readable output (for the C host API's knobs)")
    dev.add_argument("--no-tuning", action="store_true", help="only the device list (no probes, no builds)")
    tune = sub.add_parser("tune", help="measure the kernels' tuning knobs on a device",
                          description="Measure each kernel family's knobs on representative inputs and write "
                                      "this device's tuning entry to the user cache (later runs use it).")
    tune.add_argument("--device", metavar="SPEC", help="OpenCL device: index or name substring")
    tune.add_argument("--quick", action="store_true", help="one pass on small inputs (about a minute or two)")
    tune.add_argument("--family", action="append", choices=sorted(families()), metavar="NAME",
                      help=f"tune only this family (repeatable; {', '.join(sorted(families()))})")


def run_devices(args: argparse.Namespace) -> int:
    devices = list_devices()
    if not devices:
        sys.stderr.write("oclshade: error: no OpenCL device found; install 'pocl-binary-distribution' "
                         "(pip) or a GPU driver's ICD\n")
        return 1
    records = []
    for d in devices:
        rec = {"index": d.index, "platform": d.platform.strip(), "device": d.name.strip(), "type": d.device_type,
               "driver": d.driver_version.strip(), "opencl": d.opencl_version.strip(), "compute_units": d.compute_units,
               "max_alloc_mib": d.max_alloc_bytes // 2**20}
        if not args.no_tuning:
            rt = get_runtime(d.index)
            key = DeviceKey.of(rt.device)
            rec["key"] = key.as_dict()
            rec["tuning"] = {}
            for name in sorted(families()):
                dec = settings(rt, name)
                rec["tuning"][name] = {"values": dec.values, "source": dec.source, "notes": list(dec.notes)}
            rec["user_entry"] = str(store.user_path(key))
        records.append(rec)
    if args.json:
        json.dump(records, sys.stdout, indent=1)
        print()
        return 0
    head = ("index", "platform", "device", "type", "driver", "OpenCL", "CUs", "max alloc MiB")
    rows = [tuple(str(r[k]) for k in ("index", "platform", "device", "type", "driver", "opencl", "compute_units",
                                      "max_alloc_mib")) for r in records]
    widths = [max(len(r[k]) for r in (head, *rows)) for k in range(len(head))]
    for r in (head, *rows):
        print("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())
    for r in records:
        if "tuning" not in r:
            continue
        print(f"\ndevice {r['index']}: {DeviceKey(**r['key']).describe()}")
        print(f"  user entry: {r['user_entry']}")
        for name, t in r["tuning"].items():
            vals = ", ".join(f"{k}={v}" for k, v in t["values"].items())
            notes = f"  ({'; '.join(t['notes'])})" if t["notes"] else ""
            print(f"  {name:15s} {vals:40s} [{t['source']}]{notes}")
    return 0


def run_tune(args: argparse.Namespace) -> int:
    from .tuner import tune

    rt = get_runtime(args.device)
    fams = families()
    chosen = [fams[n] for n in (args.family or sorted(fams))]
    results = tune(rt, chosen, quick=args.quick, report=lambda line: print(line, file=sys.stderr))
    for name, (values, measured) in results.items():
        gain = measured["safe_ms"] / measured["best_ms"] if measured["best_ms"] else float("nan")
        vals = ", ".join(f"{k}={v}" for k, v in values.items())
        print(f"{name:15s} {vals:40s} {measured['best_ms']:9.1f} ms  ({gain:.2f}x the safe values)")
    print(f"written: {store.user_path(DeviceKey.of(rt.device))}")
    return 0
