"""Prototype: the horizon record's frame (1024^2, 64 azimuths, fresh caster, angles on the device)
for variants of the walk's kernel source and knobs, on one device, one run (issue 19).

Variants: ``head`` (a kernel file given with --head, e.g. the previous commit's horizon.cl),
``new`` (kernels/horizon.cl) and ``new`` with each macro of --defines defined at its top; each
with every knob set of --knobs (give knob sets every variant's host understands).  Prints and
writes JSON: min / median ms of --reps frames (and of the sky-view factor with --svf), and how
many angles differ from the first variant's, bit for bit.  Used for the merged-walk experiment
of 2026-12-04 (bench/prototypes/horizon_walk_merged.patch; docs/gpu.md, "The horizon record").
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import oclshade.runtime as runtime  # noqa: E402
from horizon_record import load, timed  # noqa: E402
from shadow_masks import DEFAULT_DATA  # noqa: E402
from oclshade.bench.machine import machine_facts  # noqa: E402
from oclshade.horizon import HorizonCaster, azimuth_grid  # noqa: E402
from oclshade.runtime import get_runtime  # noqa: E402

ORIGINAL = runtime.kernel_source


def use_source(text: str | None) -> None:
    """Build horizon.cl from ``text`` from now on (None: kernels/ again)."""
    runtime.kernel_source = ORIGINAL if text is None else (lambda n: text if n == "horizon.cl" else ORIGINAL(n))


def kernel_text(path: Path) -> str:
    """A horizon.cl file's text with common.h pasted in (what the hosts build)."""
    return path.read_text().replace('#include "common.h"', ORIGINAL("common.h"))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--device", default=None)
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--azimuths", type=int, default=64)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--maps", default="canyon,srtm_N22W160,puget")
    ap.add_argument("--head", type=Path, default=None)
    ap.add_argument("--defines", default="", help="comma-separated macro names, each a variant of new")
    ap.add_argument("--knobs", default="scan=0;scan=1", help="';'-separated knob sets k=v,k=v")
    ap.add_argument("--svf", action="store_true", help="also time sky_view_factor(azimuths)")
    ap.add_argument("--out", type=Path, default=Path("/tmp/walk_gpu.json"))
    args = ap.parse_args()
    rt = get_runtime(args.device)
    az = azimuth_grid(args.azimuths)
    sources: dict[str, str | None] = {}
    if args.head:
        sources["head"] = kernel_text(args.head)
    sources["new"] = None
    for d in filter(None, args.defines.split(",")):
        sources[d] = f"#define {d}\n" + ORIGINAL("horizon.cl")
    knob_sets = [dict((k, int(v)) for k, v in (kv.split("=") for kv in ks.split(","))) if ks else {}
                 for ks in args.knobs.split(";")]
    res = {"machine": machine_facts(), "device": rt.device.name, "driver": rt.device.driver_version,
           "command": " ".join(sys.argv), "maps": {}}
    for name in args.maps.split(","):
        hm = load(name, args.size, DEFAULT_DATA)
        rows, first = {}, None
        for label, src in sources.items():
            for knobs in knob_sets:
                use_source(src)
                key = label + ("" if not knobs else " " + ",".join(f"{k}={v}" for k, v in knobs.items()))
                try:
                    def frame(knobs: dict = knobs) -> None:
                        for _ in HorizonCaster(hm, rt, cache=False, knobs=knobs).angles_on_device(az):
                            pass
                        rt.queue.finish()

                    def svf(knobs: dict = knobs) -> None:
                        HorizonCaster(hm, rt, cache=False, knobs=knobs).sky_view_factor(az)

                    row = timed(frame, args.reps)
                    if args.svf:
                        row["svf_min_ms"] = timed(svf, args.reps)["min_ms"]
                    angles = HorizonCaster(hm, rt, cache=False, knobs=knobs).horizons(az)
                    if first is None:
                        first = angles
                    row["differ_from_first"] = int(np.sum(angles != first) - np.sum(np.isnan(first)))
                    row["max_deg_from_first"] = float(np.nanmax(np.abs(angles - first)))
                finally:
                    use_source(None)
                rows[key] = row
                print(name, key, row, flush=True)
        res["maps"][name] = rows
        args.out.write_text(json.dumps(res, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
