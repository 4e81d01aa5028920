"""Traversal iterations per cell by pyramid level (``ShadowCaster.step_counts``) on the
canyon-and-crater terrain, for every method and three elevations: deterministic counts
that explain the timings.  Writes ``shadow_steps.json`` and ``shadow_steps.md`` to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from shadow_masks import REPO, metadata  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    argv_list = list(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=1024)
    p.add_argument("--azimuth", type=float, default=135.0)
    p.add_argument("--quick", action="store_true", help="smoke run on a 64^2 map")
    p.add_argument("--out", type=Path, default=REPO / "bench" / "results")
    args = p.parse_args(argv_list)
    if args.quick:
        args.size = 64
    from oclshade.heightmap import Heightmap
    from oclshade.shadows import METHODS, ShadowCaster
    from oclshade.synthetic import canyon_crater

    hm = Heightmap.from_array(canyon_crater(args.size, args.size, seed=0), 30.0)
    caster = ShadowCaster(hm, cache=False)
    meta = metadata(["bench/shadow_steps.py", *argv_list])
    title = f"canyon {args.size}^2, 30 m, az {args.azimuth:g}: traversal iterations per cell by level (0 = patch tests)"
    lines, rows = [title], []
    for alt in (5.0, 20.0, 45.0):
        for method in METHODS:
            per_cell = caster.step_counts((args.azimuth, alt), method) / hm.heights.size
            rows.append({"sun": [args.azimuth, alt], "method": method, "steps_per_cell": per_cell.tolist()})
            lines.append(f"alt {alt:2.0f} {method:6s} total {per_cell.sum():6.2f}  by level "
                         + " ".join(f"{v:.2f}" for v in per_cell))
    text = ["# Traversal iterations per cell by pyramid level", "",
            f"Canyon-and-crater terrain (`oclshade.synthetic.canyon_crater({args.size})`, 30 m cells), "
            f"azimuth {args.azimuth:g}, from `ShadowCaster.step_counts` (deterministic counts, not timings); "
            f"PoCL {meta['pocl_version']}, {meta['date']}; `{meta['command']}`.", "",
            "```", *lines, "```", "",
            "exact and maxmip take identical steps at every level: the min early exit never fires in a "
            "conservative traversal (see the comment at the min test in kernels/shadow.cl for the proof). "
            "paper's steps are few because, after its first texel, it restarts at the 1x1 top level whose "
            "exit-point max test is almost never reached: most rays leave the map \"lit\" at once, which is "
            "also where its error comes from.  The counts are those of `shadow_cells` (one ray per work-item); "
            "the ray-packet kernel takes the same steps per ray."]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "shadow_steps.json").write_text(json.dumps({"meta": meta, "size": args.size, "rows": rows}, indent=1) + "\n")
    (args.out / "shadow_steps.md").write_text("\n".join(text) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
