#!/usr/bin/env python
"""Copy this machine's tuning entries (written by ``oclshade tune``) into the shipped database.

    oclshade tune                                  # per device (OCLSHADE_DEVICE=N for others)
    python bench/ship_tuning.py                    # merges ~/.cache/oclshade/tuning/*.json

An entry replaces the shipped one of the same device key; probe records stay
out (they are per machine).  The database is ``oclshade/tuning/devices.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from oclshade.cachedir import tuning_dir

DATABASE = Path(__file__).resolve().parent.parent / "oclshade" / "tuning" / "devices.json"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("entries", nargs="*", type=Path, help="user entries (default: every one in the cache)")
    args = p.parse_args(argv)
    paths = args.entries or sorted(tuning_dir().glob("*.json"))
    db = json.loads(DATABASE.read_text())
    shipped = {json.dumps(e["device"], sort_keys=True): e for e in db["entries"]}
    for path in paths:
        entry = json.loads(path.read_text())
        if not entry.get("families"):
            print(f"{path}: no measured families, skipped", file=sys.stderr)
            continue
        key = json.dumps(entry["device"], sort_keys=True)
        shipped[key] = {"device": entry["device"], "families": entry["families"]}
        print(f"{path}: {entry['device']['device']} ({entry['device']['host_cpu'] or entry['device']['version']})")
    db["entries"] = sorted(shipped.values(), key=lambda e: json.dumps(e["device"], sort_keys=True))
    DATABASE.write_text(json.dumps(db, indent=1, sort_keys=True) + "\n")
    print(f"{DATABASE}: {len(db['entries'])} entries")
    return 0


if __name__ == "__main__":
    sys.exit(main())
