#!/usr/bin/env python
"""Paper 003's table: mesh shadows by shadow volumes, frame time against the number of
shadow-casting faces, silhouette volumes against all-face volumes and against BVH shadow
rays, in the same run (issue 20).

    python bench/shadow_volumes.py                        # 1920x1080, the lead's figures (~30 min here)
    python bench/shadow_volumes.py --quick --out /tmp/b   # 480x270, 2 reps (a check that it runs)

Scene: the ISS (iss.obj, metres) and the Stanford bunny (stanford-bunny.obj, 20 m tall) side
by side over a ground quad, sun at azimuth 135, elevation 35; the frame sees all of them.
Casters: the first N faces of the ISS then the bunny (N = the paper's 0, 4258, 6787, 9720,
11710, 16489), as one open mesh (two-sided casters); every mesh stays in the G-buffer.  Per
N: the shadow pass of one frame (min / mean / max of --reps frames after a warm-up, queue
finished; the volumes kept, the mask counted afresh each frame, as when the camera moves),
for silhouette volumes (MeshShadows), all-face volumes (MeshShadows(per_face=True): one prism
per caster, no edge cancellation) and any-hit shadow rays through the BVHs
(MeshCaster.shadow_rays); the G-buffer time (once, the same for all) makes the frame time;
the host's volume build (casters, silhouette, extrusion: once per light) and how many pixels
the three disagree on.  Writes shadow_volumes.json / .md / .png to --out.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))          # the source tree (its kernels), not an installed copy
sys.path.insert(0, str(REPO / "bench"))
from shadow_masks import metadata  # noqa: E402

DATA = REPO.parent / "shared" / "data" / "meshes"
FILES = ("iss.obj", "stanford-bunny.obj")
FACES = (0, 4258, 6787, 9720, 11710, 16489)              # paper 003's table
PAPER_MS = {0: (15, 15, 15), 4258: (15, 20, 31), 6787: (15, 24, 35), 9720: (15, 27, 41), 11710: (15, 29, 45),
            16489: (15, 31, 62)}
_T0 = time.perf_counter()


def log(msg: str) -> None:
    print(f"[{time.perf_counter() - _T0:8.1f} s] {msg}", file=sys.stderr, flush=True)


def scene(size: tuple[int, int]):
    """(meshes in the frame, the caster pool's vertices and faces, camera, sun)."""
    from oclshade.camera import Camera
    from oclshade.meshes import TriangleMesh, load_mesh
    from oclshade.sun import Sun
    iss = load_mesh(DATA / FILES[0])
    lo, hi = iss.bounds
    iss = iss.placed(translate=-0.5 * (lo + hi) + np.array([0.0, 0.0, 25.0]))
    bunny = load_mesh(DATA / FILES[1], up="y")
    lo, hi = bunny.bounds
    scale = 20.0 / float(hi[2] - lo[2])
    bunny = bunny.placed(scale=scale)
    lo, hi = bunny.bounds
    bunny = bunny.placed(translate=np.array([30.0, 0.0, 0.0]) - np.array([0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]),
                                                                          lo[2]]))
    ground = TriangleMesh([[-80, -80, 0], [100, -80, 0], [100, 80, 0], [-80, 80, 0]], [[0, 1, 2], [0, 2, 3]],
                          cast_shadows=False, name="ground")
    vertices = np.concatenate([iss.vertices, bunny.vertices])
    faces = np.concatenate([iss.faces, bunny.faces + len(iss.vertices)])
    camera = Camera([60.0, -75.0, 55.0], [10.0, 5.0, 8.0], *size, fov=50, near=0.5, far=400.0)
    return [iss, bunny, ground], vertices, faces, camera, Sun(135.0, 35.0)


def timed(run, reps: int, queue, warm: bool = True) -> list[float]:
    if warm:
        run()
        queue.finish()
    out = []
    for _ in range(reps):
        t0 = time.perf_counter()
        run()
        queue.finish()
        out.append(1e3 * (time.perf_counter() - t0))
    return out


def stats(ms: list[float]) -> dict:
    return {"min": min(ms), "mean": float(np.mean(ms)), "max": max(ms)}


def run(args) -> dict:
    import pyopencl as cl

    from oclshade.meshes import MeshCaster, MeshShadows, TriangleMesh
    from oclshade.runtime import get_runtime
    rt = get_runtime()
    meshes, vertices, faces, camera, sun = scene(args.size)
    caster = MeshCaster(meshes, device=rt)
    frame = caster.cast(camera)
    gbuffer_ms = timed(lambda: caster.cast(camera, frame), args.reps, rt.queue)
    gbuf = frame[0]
    hit = gbuf.to_host().hit
    rows = []
    for n in args.faces:
        log(f"{n} casting faces, {camera.width}x{camera.height}")
        row = {"faces": n}
        if n == 0:        # no caster: nothing built, compiled or run
            row.update(silhouette=stats([0.0]), all_faces=stats([0.0]), rays=stats([0.0]), volume_build_ms=0.0,
                       silhouette_edges=0, volume_faces=0, all_face_volume_faces=0, differ={})
            rows.append(row)
            continue
        casters = TriangleMesh(vertices, faces[:n], name=f"first {n} faces")
        masks = {}
        for key, per_face in (("silhouette", False), ("all_faces", True)):
            shadows = MeshShadows([casters], rt, per_face=per_face)
            t0 = time.perf_counter()
            vol = shadows.volumes(sun)
            build = 1e3 * (time.perf_counter() - t0)
            buf = shadows.mask(camera, gbuf, sun)      # warm-up: kernels built, volumes long enough
            row[key] = stats(timed(lambda: shadows.mask(camera, gbuf, sun), args.reps, rt.queue, warm=False))
            host = np.empty(hit.shape, np.uint8)       # the timed frames counted into the same buffer
            cl.enqueue_copy(rt.queue, host, buf)
            rt.queue.finish()
            masks[key] = host.astype(bool)
            if per_face:
                row["all_face_volume_faces"] = int(len(vol.faces))
            else:
                row.update(volume_build_ms=build, silhouette_edges=int(vol.silhouette),
                           volume_faces=int(len(vol.faces)))
        rays = MeshCaster([casters], device=rt)
        out = rays.shadow_rays(camera, gbuf, sun)
        row["rays"] = stats(timed(lambda: rays.shadow_rays(camera, gbuf, sun, out), args.reps, rt.queue))
        masks["rays"] = rays.shadow_mask(camera, gbuf, sun)
        row["differ"] = {"silhouette_vs_all_faces": int((masks["silhouette"] != masks["all_faces"])[hit].sum()),
                         "silhouette_vs_rays": int((masks["silhouette"] != masks["rays"])[hit].sum()),
                         "shadowed_pixels": int(masks["silhouette"][hit].sum()), "hit_pixels": int(hit.sum())}
        rows.append(row)
    return {"gbuffer_ms": stats(gbuffer_ms), "rows": rows}


def markdown(res: dict) -> str:
    c, m = res["config"], res["meta"]
    g = res["runs"]["gbuffer_ms"]["min"]
    lines = [f"# Shadow volumes (paper 003): frame time against shadow-casting faces ({c['size'][0]}x{c['size'][1]})",
             "", f"Machine: {m['cpu']}, {m['cores']} cores; device {m['device']} ({m['pocl_version']}); {m['date']}; "
             f"`{m['command']}`" + (" (quick: not figures of record)" if c["quick"] else ""), "",
             f"Shadow pass per frame, min / mean / max of {c['reps']} frames after a warm-up (ms; volumes kept, mask "
             f"counted afresh); frame = G-buffer ({g:.1f} ms, min) + shadow pass (min).  Paper 003: GeForce3, "
             "whole frame, min/avg/max.", "",
             "| casting faces | silhouette edges | volume faces (silhouette / all-face) | silhouette volumes | "
             "all-face volumes | silhouette / all-face | BVH shadow rays | frame (silhouette) | "
             "volume build (host, once) "
             "| pixels differ (sil. vs all-face / vs rays) | paper 003 frame |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]

    def f(s: dict) -> str:
        return f"{s['min']:.1f} / {s['mean']:.1f} / {s['max']:.1f}"

    for r in res["runs"]["rows"]:
        ratio = "-" if r["faces"] == 0 else f"{r['silhouette']['min'] / r['all_faces']['min']:.2f}"
        d = r["differ"]
        differ = "-" if not d else f"{d['silhouette_vs_all_faces']} / {d['silhouette_vs_rays']} of {d['hit_pixels']}"
        paper = PAPER_MS.get(r["faces"])
        lines.append(f"| {r['faces']} | {r['silhouette_edges']} | {r['volume_faces']} / {r['all_face_volume_faces']} | "
                     f"{f(r['silhouette'])} | {f(r['all_faces'])} | {ratio} | {f(r['rays'])} | "
                     f"{g + r['silhouette']['min']:.1f} | {r['volume_build_ms']:.0f} | {differ} | "
                     f"{'-' if paper is None else '/'.join(map(str, paper))} |")
    lines += ["", "Casters: the first N faces of the ISS, then of the bunny, as one open mesh (two-sided: "
              "docs/shadow_volumes.md); every mesh is in the G-buffer.  Pixels differ: hit pixels whose "
              "decision differs (float32 ties at shadow boundaries).", ""]
    return "\n".join(lines)


def plot(res: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = res["runs"]["rows"]
    n = [r["faces"] for r in rows]
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for key, label in (("silhouette", "silhouette volumes"), ("all_faces", "all-face volumes"),
                       ("rays", "BVH shadow rays")):
        ax.plot(n, [r[key]["min"] for r in rows], marker="o", label=label)
    ax.set_xlabel("shadow-casting faces")
    ax.set_ylabel("shadow pass per frame (ms, min)")
    c = res["config"]
    ax.set_title(f"Shadow volumes, {c['size'][0]}x{c['size'][1]}" + (" (quick)" if c["quick"] else ""))
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="480x270, 2 reps, 0 / 4258 / 9720 faces (a check)")
    ap.add_argument("--out", type=Path, default=REPO / "bench" / "results")
    ap.add_argument("--reps", type=int, default=None, help="frames per figure (default 3; quick 2)")
    ap.add_argument("--size", default=None, help="WIDTHxHEIGHT (default 1920x1080; quick 480x270)")
    ap.add_argument("--faces", default=None, help="comma-separated caster counts (default the paper's)")
    args = ap.parse_args(argv)
    args.reps = args.reps or (2 if args.quick else 3)
    try:
        args.size = tuple(int(x) for x in args.size.split("x")) if args.size else \
            ((480, 270) if args.quick else (1920, 1080))
        args.faces = tuple(int(x) for x in args.faces.split(",")) if args.faces else \
            ((0, 4258, 9720) if args.quick else FACES)
    except ValueError:
        ap.error("--size takes WIDTHxHEIGHT and --faces integers separated by commas")
    if len(args.size) != 2 or min(args.size) < 1 or min(args.faces) < 0:
        ap.error("--size takes WIDTHxHEIGHT (positive) and --faces counts >= 0")
    missing = [f for f in FILES if not (DATA / f).is_file()]
    if missing:
        print(f"shadow_volumes: the shared meshes {', '.join(missing)} are not in {DATA}", file=sys.stderr)
        return 2
    res = {"meta": metadata(sys.argv if argv is None else ["bench/shadow_volumes.py", *argv]),
           "config": {"size": list(args.size), "reps": args.reps, "quick": args.quick or args.size != (1920, 1080),
                      "faces": list(args.faces)},
           "runs": run(args)}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "shadow_volumes.json").write_text(json.dumps(res, indent=1))
    (args.out / "shadow_volumes.md").write_text(markdown(res))
    plot(res, args.out / "shadow_volumes.png")
    log(f"wrote {args.out / 'shadow_volumes.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
