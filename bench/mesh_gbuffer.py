#!/usr/bin/env python
"""Mesh G-buffers: the BVH ray caster (kernels/mesh.cl, kept) against a minimal compute
rasteriser (bench/prototypes/mesh_raster.cl, a bench-only prototype), on the bunny and the
ISS at 1920x1080 (issue 20: "prototype both on two meshes, measure, keep one, say why").

    python bench/mesh_gbuffer.py                        # 1920x1080, the lead's figures
    python bench/mesh_gbuffer.py --quick --out /tmp/b   # 480x270, 2 reps (a check that it runs)

Per mesh and view (``front``: the mesh fills about half the frame's height; ``close``: a
quarter of it fills the frame, most triangles off screen or large): the time of one frame's
G-buffer (min of ``--reps`` after a warm-up, queue finished), for the BVH caster (cast:
position, normal, uv, uv_grad, depth, albedo, ids) and the rasteriser (clear, depth pass,
id pass, resolve: position, normal, depth); the host work the BVH needs once per mesh (SAH
build and upload) and the rasteriser needs per frame (view-space vertices, upload); and
how far the two agree (pixels hit by one and not the other; depth difference).  Writes
mesh_gbuffer.json / .md to ``--out``; timings are for the machine that ran it (recorded).
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

MESHES = {"bunny": ("bunny_oded.obj", 100.0), "iss": ("iss.obj", 1.0)}      # file, scale (metres)
DATA = REPO.parent / "shared" / "data" / "meshes"
PROTOTYPE = REPO / "bench" / "prototypes" / "mesh_raster.cl"
_T0 = time.perf_counter()


def log(msg: str) -> None:
    print(f"[{time.perf_counter() - _T0:8.1f} s] {msg}", file=sys.stderr, flush=True)


def views(mesh, size: tuple[int, int]) -> dict:
    from oclshade.camera import Camera
    lo, hi = mesh.bounds
    centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
    direction = np.array([0.6, -0.7, 0.4])
    direction /= np.linalg.norm(direction)
    fov = 40.0
    fit = radius / np.tan(np.radians(fov / 2))
    out = {}
    for name, distance in (("front", 2.0 * fit), ("close", 0.5 * fit)):
        out[name] = Camera(centre + distance * direction, centre, *size, fov=fov, near=0.01 * radius,
                           far=distance + 2 * radius)
    return out


def best_ms(run, reps: int, queue) -> float:
    run()
    queue.finish()
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        run()
        queue.finish()
        times.append(1e3 * (time.perf_counter() - t0))
    return min(times)


class Raster:
    """The prototype rasteriser on one device (bench/prototypes/mesh_raster.cl)."""

    def __init__(self, mesh, runtime):
        import pyopencl as cl
        self.cl, self.rt, self.mesh = cl, runtime, mesh
        program = cl.Program(runtime.context, PROTOTYPE.read_text()).build(options=["-cl-std=CL1.2"])
        self.kernels = {name: cl.Kernel(program, name) for name in ("raster_depth", "raster_id", "raster_resolve")}
        self.normals = mesh.vertex_normals[mesh.faces]           # (M, 3, 3) world
        self.nt = len(mesh.faces)
        self.bufs: dict | None = None

    def upload(self, camera) -> None:
        """View-space vertices and normals (float64 on the host, rounded once), per frame."""
        rot = camera.rotation
        v = (self.mesh.vertices[self.mesh.faces] - camera.position) @ rot.T
        pad = ((0, 0), (0, 0), (0, 1))
        self.vtx = self.rt.to_device(np.pad(v, pad).astype(np.float32), "raster vertices")
        self.nrm = self.rt.to_device(np.pad(self.normals @ rot.T, pad).astype(np.float32), "raster normals")

    def frame(self, camera) -> dict:
        cl, rt = self.cl, self.rt
        w, h = camera.width, camera.height
        n = w * h
        if self.bufs is None or self.bufs["depth"].size != 4 * n:
            self.bufs = {"zbuf": rt.empty(4 * n, "zbuf"), "ids": rt.empty(4 * n, "ids"),
                         "position": rt.empty(16 * n, "position"), "normal": rt.empty(16 * n, "normal"),
                         "depth": rt.empty(4 * n, "depth")}
        b = self.bufs
        sx, sy = camera.scale
        cam = np.array([sx, sy, camera.near, camera.far], np.float32)
        cl.enqueue_fill_buffer(rt.queue, b["zbuf"], np.uint32(0x7F800000), 0, 4 * n)
        cl.enqueue_fill_buffer(rt.queue, b["ids"], np.int32(-1), 0, 4 * n)
        k = self.kernels
        tris = ((-(-self.nt // 64) * 64,), (64,))
        k["raster_depth"].set_args(np.int32(self.nt), self.vtx, np.int32(w), np.int32(h), cam, b["zbuf"])
        cl.enqueue_nd_range_kernel(rt.queue, k["raster_depth"], *tris)
        k["raster_id"].set_args(np.int32(self.nt), self.vtx, np.int32(w), np.int32(h), cam, b["zbuf"], b["ids"])
        cl.enqueue_nd_range_kernel(rt.queue, k["raster_id"], *tris)
        k["raster_resolve"].set_args(self.vtx, self.nrm, np.int32(w), np.int32(h), cam, b["zbuf"], b["ids"],
                                     b["position"], b["normal"], b["depth"])
        cl.enqueue_nd_range_kernel(rt.queue, k["raster_resolve"], (-(-w // 16) * 16, -(-h // 4) * 4), (16, 4))
        return b

    def depth(self, camera) -> np.ndarray:
        out = np.empty((camera.height, camera.width), np.float32)
        self.cl.enqueue_copy(self.rt.queue, out, self.frame(camera)["depth"])
        self.rt.queue.finish()
        return out


def run_mesh(name: str, args) -> dict:
    from oclshade.meshes import MeshCaster, load_mesh
    from oclshade.runtime import get_runtime
    file, scale = MESHES[name]
    mesh = load_mesh(DATA / file).placed(scale=scale)
    rt = get_runtime()
    t0 = time.perf_counter()
    caster = MeshCaster([mesh], device=rt)
    rt.queue.finish()
    build_ms = 1e3 * (time.perf_counter() - t0)
    raster = Raster(mesh, rt)
    out = {"mesh": name, "file": file, "triangles": int(len(mesh.faces)), "bvh_build_upload_ms": build_ms,
           "views": []}
    for view, camera in views(mesh, args.size).items():
        log(f"{name} {view} {camera.width}x{camera.height}")
        frame = caster.cast(camera)
        bvh_ms = best_ms(lambda: caster.cast(camera, frame), args.reps, rt.queue)
        gbuf = frame[0].to_host()
        t0 = time.perf_counter()
        raster.upload(camera)
        rt.queue.finish()
        upload_ms = 1e3 * (time.perf_counter() - t0)
        raster_ms = best_ms(lambda: raster.frame(camera), args.reps, rt.queue)
        depth = raster.depth(camera)
        hit_r, hit_b = np.isfinite(depth), gbuf.hit
        both = hit_r & hit_b
        rel = np.abs(depth[both] - gbuf.depth[both]) / gbuf.depth[both]
        out["views"].append({
            "view": view, "size": [camera.width, camera.height], "hit_pixels": int(hit_b.sum()),
            "bvh_ms": bvh_ms, "raster_ms": raster_ms, "raster_host_upload_ms": upload_ms,
            "hit_differs": int((hit_r != hit_b).sum()),
            "depth_rel_p99": float(np.percentile(rel, 99)) if rel.size else None,
            "depth_rel_max": float(rel.max()) if rel.size else None})
    return out


def markdown(res: dict) -> str:
    c = res["config"]
    lines = [f"# Mesh G-buffers: BVH ray casting against a compute rasteriser ({c['size'][0]}x{c['size'][1]})", "",
             f"Machine: {res['meta']['cpu']}, {res['meta']['cores']} cores; device {res['meta']['device']} "
             f"({res['meta']['pocl_version']}); {res['meta']['date']}; `{res['meta']['command']}`"
             + (" (quick: not figures of record)" if c["quick"] else ""), "",
             "Times: min of %d frames after a warm-up, queue finished (ms)." % c["reps"], "",
             "| mesh | triangles | view | hit pixels | BVH cast | raster (3 passes) | raster / BVH "
             "| raster's per-frame upload | BVH build + upload (once) | hit/miss differ | depth rel. p99 |",
             "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for m in res["meshes"]:
        for v in m["views"]:
            p99 = "-" if v["depth_rel_p99"] is None else f"{v['depth_rel_p99']:.1e}"
            lines.append(f"| {m['mesh']} | {m['triangles']} | {v['view']} | {v['hit_pixels']} | {v['bvh_ms']:.1f} | "
                         f"{v['raster_ms']:.1f} | {v['raster_ms'] / v['bvh_ms']:.2f} | "
                         f"{v['raster_host_upload_ms']:.1f} | {m['bvh_build_upload_ms']:.0f} | {v['hit_differs']} "
                         f"| {p99} |")
    lines += ["", "The rasteriser is a prototype (no near-plane clipping, no alpha cut-outs, textures or "
              "normal maps; it writes position, normal and depth only); the BVH caster writes the whole "
              "G-buffer. docs/meshes.md says which is kept and why.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="480x270, 2 reps (a check that it runs)")
    ap.add_argument("--out", type=Path, default=REPO / "bench" / "results")
    ap.add_argument("--reps", type=int, default=None, help="frames per figure (default 5; quick 2)")
    ap.add_argument("--meshes", default=",".join(MESHES), help=f"comma-separated of {', '.join(MESHES)}")
    args = ap.parse_args(argv)
    args.reps = args.reps or (2 if args.quick else 5)
    args.size = (480, 270) if args.quick else (1920, 1080)
    names = args.meshes.split(",")
    if not set(names) <= set(MESHES):
        ap.error(f"--meshes takes {', '.join(MESHES)}")
    missing = [MESHES[n][0] for n in names if not (DATA / MESHES[n][0]).is_file()]
    if missing:
        print(f"mesh_gbuffer: the shared meshes {', '.join(missing)} are not in {DATA}", file=sys.stderr)
        return 2
    res = {"meta": metadata(sys.argv if argv is None else ["bench/mesh_gbuffer.py", *argv]),
           "config": {"size": list(args.size), "reps": args.reps, "quick": args.quick},
           "meshes": [run_mesh(n, args) for n in names]}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "mesh_gbuffer.json").write_text(json.dumps(res, indent=1))
    (args.out / "mesh_gbuffer.md").write_text(markdown(res))
    log(f"wrote {args.out / 'mesh_gbuffer.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
