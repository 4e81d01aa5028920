"""Time against accuracy: HORAYZON's horizon search at several accuracies against oclshade's
exact walk, same map, same azimuths, one process (issue 19, "faster than all of them").

HORAYZON (``horayzon-extpar``, Embree) finds each horizon to within a requested accuracy: per
cell and azimuth it steps the elevation by twice that accuracy from the previous azimuth's
angle, one ray per step, so its time grows as the accuracy tightens.  oclshade's angles are
exact (float32 rounding of the float64 reference, held to its band on sampled cells here).
This script measures where the two meet: HORAYZON's time at each ``--accuracies`` value, its
rays per cell and azimuth, its ratio to oclshade's time with Earth curvature (HORAYZON's
sphere), and its difference from oclshade's angles split near / far as bench/solar.py does
(HORAYZON's triangles and oclshade's bilinear patches are different surfaces: the near field
differs by the surface model, not only by the accuracy).

Maps: the generated canyon at ``--side`` (default 4096, bench/solar.py's 4096^2 canyon; 30 m
cells) or a shared SRTM tile (``--map N22W160`` / ``S16E166``, skipped cleanly without
``../shared/data``).  The results are rewritten after every accuracy, so a run stopped part
way keeps what it measured.  Writes ``--out`` .json, .md and .png.  Figures depend on the
machine; the JSON records which.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from solar import (HORAYZON_LOWEST, _near_far_cells, fill_voids, horayzon_version, maps,  # noqa: E402
                   near_cells, near_far_difference, reference_error, run_horayzon, time_ours)

from oclshade.bench.machine import machine_facts  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.horizon import Curvature, HorizonCaster  # noqa: E402
from oclshade.runtime import get_runtime  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ACCURACIES = (0.1, 0.03, 0.01)


def load_map(name: str, side: int) -> tuple[str, Heightmap]:
    """The canyon at side^2 or a shared SRTM tile (bench/solar.py's maps)."""
    found = maps(False, (name,), side)
    if not found:
        raise SystemExit(f"--map {name}: the tile is not in ../shared/data (nothing measured)")
    return next(iter(found.items()))


def measure(label: str, hm: Heightmap, n: int, accuracies: tuple[float, ...], samples: int, out: Path) -> dict:
    rt = get_runtime()
    voids = int(np.isnan(hm.heights).sum())
    peer_map = Heightmap.from_array(fill_voids(hm.heights), (hm.dx, hm.dy)) if voids else hm
    caster = HorizonCaster(peer_map, rt, cache=False, curvature=Curvature())
    caster.horizons([0.0])                                   # warm-up: pyramid and kernel build
    seconds, angles = time_ours(caster, n)
    res = {"command": " ".join(["python", "bench/horayzon_frontier.py", *sys.argv[1:]]),
           "machine": {**machine_facts(), "device": rt.label}, "map": label, "shape": list(hm.shape),
           "dx": hm.dx, "dy": hm.dy, "voids_filled": voids, "azimuths": n, "horayzon": horayzon_version(),
           "horayzon_floor_deg": HORAYZON_LOWEST, "oclshade_curved_s": seconds,
           "reference": reference_error(peer_map, angles, samples, curvature=caster.coefficient), "runs": []}
    print(f"{label}: oclshade curved {seconds:.2f} s, reference {json.dumps(res['reference'])}", flush=True)
    write(res, out)
    near = near_cells(peer_map, angles, caster.coefficient)      # the same classes for every accuracy
    for accuracy in accuracies:
        z = run_horayzon(peer_map, n, accuracy)
        run = {"accuracy_deg": accuracy, "seconds": z["seconds"], "rays": z["rays"],
               "vs_oclshade": near_far_difference(peer_map, angles, z["angles"], caster.coefficient,
                                                  floor=HORAYZON_LOWEST + 1.0, near=near)}
        del z
        res["runs"].append(run)
        print(f"  accuracy {accuracy:g} deg: {run['seconds']:.2f} s, {run['rays']} rays per cell and azimuth, "
              f"{run['seconds'] / seconds:.2f}x oclshade's time", flush=True)
        write(res, out)
    return res


def markdown(res: dict) -> str:
    ref = res["reference"]
    m = res["machine"]
    lines = ["# HORAYZON's accuracy against its time, and oclshade's exact walk (issue 19)", "",
             f"Machine: {m['cpu']}, {m['cores']} CPUs; device {m['device']}; {m['date']}. {res['horayzon']}.", "",
             f"`{res['command']}`" + (f" ({res['note']})" if res.get("note") else ""), "",
             f"Map: {res['map']} ({res['shape'][1]}x{res['shape'][0]}, cells {res['dx']:g} x {res['dy']:g} m"
             + (f", {res['voids_filled']} voids filled for both" if res["voids_filled"] else "")
             + f"), {res['azimuths']} azimuths, Earth curvature (mean radius, no refraction) on both sides.", "",
             f"oclshade (exact walk, fresh pyramid, kernel built before): **{res['oclshade_curved_s']:.2f} s**; "
             f"its angles against the float64 reference on {ref['cells']} sampled cells x every azimuth: max "
             f"|difference| {ref['max_abs_deg']:.2e} deg, {ref['outside_band']} outside the float32 band of "
             f"{ref['band_deg']:.2e} deg.", "",
             "HORAYZON: its horizon call's time (the BVH built before), rays per cell and azimuth from its own "
             "report, and its angles less oclshade's on the cells where oclshade's angle is above HORAYZON's "
             f"floor ({res['horayzon_floor_deg']:g} deg) plus 1 degree; *near*: oclshade's angle is reached "
             "within 3 cells (bilinear patches against two triangles each: a surface difference, not an "
             "accuracy one); *far*: the rest.", "",
             "| accuracy (deg) | HORAYZON s | HORAYZON / oclshade | rays per cell and azimuth | HORAYZON - "
             "oclshade mean / p99 / max abs (deg): all | near | far |", "|---|---|---|---|---|---|---|"]
    for run in res["runs"]:
        rays = f"{run['rays']:.1f}" if run.get("rays") else "-"
        lines.append(f"| {run['accuracy_deg']:g} | {run['seconds']:.2f} | "
                     f"{run['seconds'] / res['oclshade_curved_s']:.2f}x | {rays} | "
                     + _near_far_cells(run["vs_oclshade"]) + " |")
    return "\n".join(lines) + "\n"


def plot(res: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    acc = [r["accuracy_deg"] for r in res["runs"]]
    ax.loglog(acc, [r["seconds"] for r in res["runs"]], "o-", label="HORAYZON (Embree), within its accuracy")
    ax.axhline(res["oclshade_curved_s"], color="k", ls="--",
               label=f"oclshade, exact (max {res['reference']['max_abs_deg']:.1e} deg from float64)")
    ax.set_xlabel("HORAYZON's accuracy (degrees)")
    ax.set_ylabel("seconds")
    ax.invert_xaxis()
    ax.set_title(f"{res['map']}, {res['azimuths']} azimuths")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write(res: dict, out: Path) -> None:
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".json").write_text(json.dumps(res, indent=1) + "\n")
    out.with_suffix(".md").write_text(markdown(res))
    if res["runs"]:
        plot(res, out.with_suffix(".png"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--map", default="canyon", choices=("canyon", "N22W160", "S16E166"))
    parser.add_argument("--side", type=int, default=4096, help="the canyon's side in cells (default 4096)")
    parser.add_argument("--azimuths", type=int, default=16, help="azimuth count N (default 16)")
    parser.add_argument("--accuracies", default=",".join(map(str, ACCURACIES)),
                        help="comma-separated HORAYZON accuracies in degrees, run coarsest first "
                             f"(default {','.join(map(str, ACCURACIES))})")
    parser.add_argument("--samples", type=int, default=500, help="reference cells (default 500)")
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "results" / "horayzon_frontier")
    args = parser.parse_args()
    try:
        accuracies = tuple(sorted((float(a) for a in args.accuracies.split(",") if a.strip()), reverse=True))
    except ValueError:
        accuracies = ()
    if not accuracies or min(accuracies) <= 0:
        parser.error(f"--accuracies takes comma-separated positive degrees, got {args.accuracies!r}")
    if args.side < 16 or args.azimuths < 1 or args.samples < 1:
        parser.error("--side must be at least 16, --azimuths and --samples at least 1")
    if horayzon_version() is None:
        raise SystemExit("HORAYZON is not installed (pip install horayzon-extpar): nothing to compare")
    label, hm = load_map(args.map, args.side)
    res = measure(label, hm, args.azimuths, accuracies, args.samples, args.out)
    print(markdown(res))


if __name__ == "__main__":
    main()
