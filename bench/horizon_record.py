"""Exact horizon maps at the size of the GPU record (issue 19): Timonen & Westerholm 2010,
1024^2 heightmap, 64 azimuths, 23 frames/s on a GTX 280 (about 43 ms a frame).

Per map (1024^2: the generated canyon, and centre crops of the shared SRTM N22W160 tile
and the Puget Sound map when ``../shared/data`` is present), on one OpenCL device:

* ``frame``: a fresh caster (extrema pyramid built, caches off) and the horizon angles of
  all 64 azimuths on the device, ``queue.finish()`` at the end: what one frame of the
  record computes;
* ``frame + readback``: the same, the 64 bands copied to host memory (``horizons(64)``);
* ``svf``: the sky-view factor of the 64 azimuths summed on the device (no angles written);
* ``sweep frame`` (left out with ``--no-sweep``): the same angles by the sweep (kernels/horizon.cl, "The
  sweep"), which the hosts take only within a search radius: here a radius of the map's
  diagonal (so the same quantity as the whole map's) with ``sweep_far`` 2, every azimuth swept
  to the map's edge, no pyramid.  The default frame is the seeded pyramid walk over the whole
  map.  Both are exact: the sweep's angles must be within the float32 band of the default's;

* ``--variant KNOB=V[,KNOB=V]`` (repeatable): the frame with those horizon tuning knobs (the
  rest the device's), e.g. ``batch=1`` against the batched default on a GPU; its angles must be
  the default frame's bit for bit;

each the minimum (and median) of ``--reps`` runs after a warm-up that includes the builds.
The angles are checked against the float64 reference on ``--samples`` seeded cells x every
azimuth (bench/solar.py's ``reference_error``): the run fails if any is outside the float32
band.  Every map is timed before the first check (the slow part, on the host), and
``horizon_record.json`` and ``.md`` are written to ``--out`` after each map's timings and
each check, so a run cut short keeps what it measured.  Figures depend on the device; the
JSON records which.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Callable

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from shadow_masks import DEFAULT_DATA, Skip, load_dataset  # noqa: E402
from solar import reference_error  # noqa: E402

from oclshade.bench.machine import machine_facts  # noqa: E402
from oclshade.bench.timing import time_case  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.horizon import HorizonCaster, azimuth_grid  # noqa: E402
from oclshade.runtime import Runtime, get_runtime  # noqa: E402

#: the sweep to the map's edge: within a radius of the map's diagonal, every azimuth swept
SWEEP_KNOBS = {"sweep_far": 2}
RECORD = {"paper": "Timonen & Westerholm 2010", "device": "NVIDIA GTX 280", "size": 1024, "azimuths": 64,
          "frames_per_s": 23.0}
MAPS = ("canyon", "srtm_N22W160", "puget")


def timed(fn: Callable[[], object], reps: int) -> dict:
    """Min and median ms of ``reps`` runs after a warm-up (oclshade.bench.timing.time_case)."""
    t = time_case(fn, reps, math.inf)
    return {"min_ms": round(1e3 * t.min_s, 3), "median_ms": round(1e3 * t.median_s, 3)}


def load(name: str, size: int, data: Path) -> Heightmap:
    d = load_dataset(name, size, data)
    return Heightmap.from_array(d["heights"].astype(np.float32), (d["dx"], d["dy"]))


def sweep_caster(hm: Heightmap, rt: Runtime) -> HorizonCaster:
    """A caster that sweeps every azimuth to the map's edge (a radius of the map's diagonal)."""
    diagonal = math.hypot(hm.shape[0] * hm.dy, hm.shape[1] * hm.dx)
    return HorizonCaster(hm, rt, cache=False, max_distance=diagonal, knobs=SWEEP_KNOBS)


def parse_variant(text: str) -> dict[str, int]:
    """``knob=value[,knob=value...]``: the horizon family's knobs for a variant frame."""
    try:
        return dict((k.strip(), int(v)) for k, v in (kv.split("=") for kv in text.split(",")))
    except ValueError:
        raise argparse.ArgumentTypeError(f"a variant is knob=value[,knob=value...], got {text!r}") from None


def variant_name(knobs: dict[str, int]) -> str:
    return ",".join(f"{k}={v}" for k, v in knobs.items())


def measure(hm: Heightmap, device: str | None, n: int, reps: int, sweep: bool,
            variants: list[dict[str, int]] = ()) -> dict:
    """The timings of one map (no check); each variant's frame too (the horizon knobs it names,
    the rest the device's), its angles checked bit for bit against the default frame's."""
    rt = get_runtime(device)

    def run_frame(caster: HorizonCaster) -> None:
        for _ in caster.angles_on_device(n):
            pass
        rt.queue.finish()

    def frame() -> None:
        run_frame(HorizonCaster(hm, rt, cache=False))

    def sweep_frame() -> None:
        run_frame(sweep_caster(hm, rt))

    def frame_readback() -> np.ndarray:
        return HorizonCaster(hm, rt, cache=False).horizons(n)

    def svf() -> None:
        HorizonCaster(hm, rt, cache=False).sky_view_factor(n)

    out = {"frame": timed(frame, reps)}
    out["frames_per_s"] = round(1e3 / out["frame"]["min_ms"], 2)
    out["knobs"] = dict(HorizonCaster(hm, rt, cache=False).knobs)
    if variants:
        angles = HorizonCaster(hm, rt, cache=False).horizons(n)
        out["variants"] = {}
        for knobs in variants:
            def variant_frame(knobs: dict[str, int] = knobs) -> None:
                run_frame(HorizonCaster(hm, rt, cache=False, knobs=knobs))
            v = timed(variant_frame, reps)
            v["same_bits"] = bool(np.array_equal(HorizonCaster(hm, rt, cache=False, knobs=knobs).horizons(n),
                                                 angles, equal_nan=True))
            out["variants"][variant_name(knobs)] = v
            print(f"  variant {variant_name(knobs)}: frame {v['min_ms']:.1f} ms, same bits {v['same_bits']}",
                  file=sys.stderr)
    if sweep:
        if not all(sweep_caster(hm, rt).takes_sweep(az) for az in azimuth_grid(n)):     # checked once, untimed
            raise SystemExit(f"the sweep frame would walk some of the {n} azimuths on {hm.shape}")
        out["sweep_frame"] = timed(sweep_frame, reps)
    out["frame_readback"], out["svf"] = timed(frame_readback, reps), timed(svf, reps)
    return out


def write(res: dict, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "horizon_record.json").write_text(json.dumps(res, indent=1) + "\n")
    (out / "horizon_record.md").write_text(markdown(res))


def markdown(res: dict) -> str:
    r = res["record"]
    lines = [f"# Exact horizons at the record's size ({res['device']['name']})", "",
             f"{res['size']}^2, {res['azimuths']} azimuths; the record (1024^2, 64 azimuths): {r['paper']}, "
             f"{r['frames_per_s']:g} frames/s on an {r['device']} ({1e3 / r['frames_per_s']:.1f} ms). "
             f"Min (median) of {res['reps']} runs, fresh pyramid each.", "",
             "| map | frame (ms) | frames/s | x record | sweep frame (ms; max deg from the frame's) | "
             "+ readback (ms) | SVF (ms) | vs float64 (max deg, outside band) |",
             "|---" * 8 + "|"]
    for name, m in res["maps"].items():
        c = m.get("check")
        check = f"{c['max_abs_deg']:.2g}, {c['outside_band']} of {c['cells']} x {res['azimuths']}" if c else "not run"
        sweep = f"{m['sweep_frame']['min_ms']:.1f}" if "sweep_frame" in m else "not run"
        if "sweep_vs_frame_deg" in m:
            sweep += f"; {m['sweep_vs_frame_deg']:.2g}"
        frame = f"{m['frame']['min_ms']:.1f} ({m['frame']['median_ms']:.1f})"
        lines.append(f"| {name} | {frame} | {m['frames_per_s']:.1f} | {m['frames_per_s'] / r['frames_per_s']:.2f} "
                     f"| {sweep} | {m['frame_readback']['min_ms']:.1f} | {m['svf']['min_ms']:.1f} | {check} |")
    variants = [(name, m["variants"]) for name, m in res["maps"].items() if m.get("variants")]
    if variants:
        lines += ["", "Variant frames (the horizon knobs named, the rest the device's; same bits: the angles "
                  "equal the default frame's bit for bit):", "",
                  "| map | default knobs | default frame (ms) | variant | frame (ms) | x default | same bits |",
                  "|---" * 7 + "|"]
        for name, vs in variants:
            m = res["maps"][name]
            for vname, v in vs.items():
                lines.append(f"| {name} | {variant_name(m['knobs'])} | {m['frame']['min_ms']:.1f} | {vname} | "
                             f"{v['min_ms']:.1f} ({v['median_ms']:.1f}) | {m['frame']['min_ms'] / v['min_ms']:.2f} "
                             f"| {v['same_bits']} |")
    d, mf = res["device"], res["machine"]
    lines += ["", f"Device: {d['name']} ({d['platform']}, driver {d['driver']}, {d['version']}); "
              f"host CPU {mf['cpu']}, {mf['cores']} cores; {mf['date']}.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default=None, help="OpenCL device: index or name substring")
    ap.add_argument("--size", type=int, default=RECORD["size"])
    ap.add_argument("--azimuths", type=int, default=RECORD["azimuths"])
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--samples", type=int, default=500, help="reference cells per map")
    ap.add_argument("--no-sweep", dest="sweep", action="store_false",
                    help="leave out the sweep frame (every azimuth swept to the map's edge)")
    ap.add_argument("--variant", dest="variants", type=parse_variant, action="append", default=[],
                    metavar="KNOB=V[,KNOB=V]", help="also time a frame with these horizon knobs (repeatable)")
    ap.add_argument("--maps", default=",".join(MAPS), help=f"comma-separated, of {', '.join(MAPS)}")
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--out", type=Path, default=Path("bench/results"))
    ap.add_argument("--quick", action="store_true", help="smoke run: 128^2, 8 azimuths, 1 rep, 20 cells")
    args = ap.parse_args(argv)
    if args.quick:
        args.size, args.azimuths, args.reps, args.samples = 128, 8, 1, 20
    rt = get_runtime(args.device)
    res = {"record": RECORD, "size": args.size, "azimuths": args.azimuths, "reps": args.reps,
           "machine": machine_facts(), "command": " ".join(["python", *sys.argv]),
           "device": {"name": rt.device.name, "platform": rt.device.platform.name,
                      "driver": rt.device.driver_version, "version": rt.device.version}, "maps": {}}
    heightmaps = {}
    for name in args.maps.split(","):  # every map's timings first, then the slow float64 checks
        try:
            heightmaps[name] = hm = load(name, args.size, args.data)
        except Skip as why:
            print(f"{name}: skipped ({why})", file=sys.stderr)
            continue
        res["maps"][name] = m = measure(hm, args.device, args.azimuths, args.reps, args.sweep, args.variants)
        print(f"{name}: frame {m['frame']['min_ms']:.1f} ms ({m['frames_per_s']:.1f}/s), "
              + (f"sweep {m['sweep_frame']['min_ms']:.1f} ms, " if args.sweep else "")
              + f"readback {m['frame_readback']['min_ms']:.1f} ms, svf {m['svf']['min_ms']:.1f} ms", file=sys.stderr)
        write(res, args.out)
    for name, hm in heightmaps.items():
        m = res["maps"][name]
        angles = HorizonCaster(hm, rt, cache=False).horizons(args.azimuths)
        m["check"] = reference_error(hm, angles, args.samples)
        if args.sweep:     # exact both: within the float32 band of each other
            m["sweep_vs_frame_deg"] = float(np.nanmax(np.abs(sweep_caster(hm, rt).horizons(args.azimuths) - angles)))
        print(f"{name}: check {m['check']}, sweep against the frame {m.get('sweep_vs_frame_deg')} deg", file=sys.stderr)
        write(res, args.out)
    print(markdown(res))
    bad = [n for n, m in res["maps"].items()
           if m["check"]["outside_band"] or m.get("sweep_vs_frame_deg", 0.0) > m["check"]["band_deg"]
           or not all(v["same_bits"] for v in m.get("variants", {}).values())]
    if bad:
        print("horizon_record: angles outside the float32 band (of the reference, or the sweep's of the "
              f"frame's), or a variant's not the frame's bits, on {', '.join(bad)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
