"""Prototype: how many steps the horizon walk takes, per cell and azimuth, and a proxy for a GPU's
time: the sum over warps (blocks of 4 x 8 cells, the H200 entry's width 4) of the warp's longest
walk (issue 19; docs/gpu.md, "The horizon record").

The kernel's text is patched (a step counter written in place of the angle) and run on the CPU
device with one azimuth per launch.  ``--kernel FILE`` walks another horizon.cl (e.g. an older
commit's, ``git show REV:kernels/horizon.cl``).  Per map: the mean steps, the warp proxy (steps a
cell, as the warps' longest walks make it), the proxy if each work-item walked ``--merge`` cells
one after another (bench/prototypes/horizon_walk_merged.patch), and the steps after the last raise
of the tangent (the proof that nothing further is higher).  For the record's frame on the H200 the
proxy of the walk before "Levels" (16 azimuths) tracked the time at 0.76-0.79 ms per unit on all three maps.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from horizon_record import load  # noqa: E402
from shadow_masks import DEFAULT_DATA  # noqa: E402
from oclshade.horizon import HorizonCaster, azimuth_grid  # noqa: E402
from oclshade.runtime import get_runtime  # noqa: E402
from prototypes.horizon_walk_gpu import ORIGINAL, kernel_text, use_source  # noqa: E402

LOOP = "for (int it = 0; it < OCLS_MAX_ITERATIONS; ++it) {"
RAISE = "if (patch > best) *t_best = t_at;"


def counting(text: str, kind: str) -> str:
    """horizon.cl with a per-cell step counter (``all`` steps, or ``tail``: those after the last
    raise) written to the angle output."""
    edits = [("float *t_best)\n{", "float *t_best, int *ocls_steps)\n{"), ("&t_best)", "&t_best, &ocls_steps)"),
             ("float t_best = 0.0f", "float t_best = 0.0f; int ocls_steps = 0"),
             ("    store_outputs(angle, svf, idx, T);\n}", "    angle[idx] = (float)ocls_steps;\n}"),
             (LOOP, LOOP + " ++*ocls_steps;")]
    if kind == "tail":
        edits.append((RAISE, "if (patch > best) { *t_best = t_at; *ocls_steps = 0; }"))
    for old, new in edits:
        if old not in text:
            raise SystemExit(f"the kernel has no {old!r}: this prototype's patch does not apply")
        text = text.replace(old, new)
    return text


def steps(hm, rt, text: str, azimuths: np.ndarray) -> np.ndarray:
    use_source(text)
    try:
        return HorizonCaster(hm, rt, cache=False, knobs={"batch": 1}).horizons(azimuths)
    finally:
        use_source(None)


def warp_proxy(a: np.ndarray, merge: int, bw: int = 4, bh: int = 8) -> dict[str, float]:
    """Steps per cell as the warps' longest walks make them: now, and with ``merge`` cells a
    work-item (cells W / merge apart, as the merged patch lays them out)."""
    n, rows, cols = a.shape
    a = np.nan_to_num(a[:, :rows // bh * bh, :cols // (bw * merge) * bw * merge], nan=0)
    blocks = a.reshape(n, rows // bh, bh, a.shape[2] // bw, bw)
    merged = a.reshape(n, rows // bh, bh, merge, a.shape[2] // (bw * merge), bw).sum(axis=3)
    return {"warp": float(blocks.max(axis=(2, 4)).sum()) * bw * bh / a.size,
            f"warp_merge{merge}": float(merged.max(axis=(2, 4)).sum()) * bw * bh / a.size}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kernel", type=Path, default=None, help="a horizon.cl to walk (default: kernels/)")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--azimuths", type=int, default=16, help="of the record's 64, evenly spaced")
    ap.add_argument("--merge", type=int, default=8)
    ap.add_argument("--maps", default="canyon,srtm_N22W160,puget")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    text = kernel_text(args.kernel) if args.kernel else ORIGINAL("horizon.cl")
    rt = get_runtime(None)
    az = azimuth_grid(64)[::max(1, 64 // args.azimuths)]
    res = {"kernel": str(args.kernel or "kernels/horizon.cl"), "device": rt.device.name, "azimuths": az.tolist(),
           "maps": {}}
    for name in args.maps.split(","):
        hm = load(name, args.size, DEFAULT_DATA)
        every = steps(hm, rt, counting(text, "all"), az)
        tail = steps(hm, rt, counting(text, "tail"), az)
        row = {"mean": float(np.nanmean(every)), **warp_proxy(every, args.merge), "tail_mean": float(np.nanmean(tail))}
        res["maps"][name] = {k: round(v, 2) for k, v in row.items()}
        print(name, res["maps"][name], flush=True)
    if args.out:
        args.out.write_text(json.dumps(res, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
