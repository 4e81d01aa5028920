"""``oclshade render SCENE.toml OUT.png``: a scene file rendered (the render command's hook).

The scene file holds the terrain, camera, sun, render settings, environment, quadrics and meshes
(:mod:`oclshade.scene.description`); on the command line only OUTPUT (.png), --gbuffer
EXR, --device and --quiet apply.  Another render option given with a scene file is an
error naming the file's key to use instead, so nothing is silently ignored.
"""
from __future__ import annotations

import argparse
import contextlib
import sys
import time

import numpy as np

#: render options a scene file replaces, with the key that sets it there
FILE_KEYS = {"size": "[camera] size", "camera": "[camera] position / look_at", "view": "[camera] view",
             "fov": "[camera] fov", "sun": "[sun] azimuth / elevation", "radius": "[terrain] radius",
             "ssaa": "[render] ssaa", "no_shadows": "[render] shadows", "ao": "[render] ao",
             "z_factor": "[terrain] z_factor", "cellsize": "[terrain] cellsize", "nodata": "[terrain] nodata"}
#: the options that apply to a scene file as to a DEM
SCENE_OPTIONS = {"input", "output", "gbuffer", "device", "quiet", "command"}
#: the G-buffer channels a scene with reflective objects (mirror, glossy) adds after the
#: standard ones: the view-space reflection direction R = U - 2 (N.U) N, 0 where no reflection
REFLECTION_NAMES = ["reflection.x", "reflection.y", "reflection.z"]


def is_scene(path: str) -> bool:
    return path.lower().endswith(".toml")


def _render_defaults() -> dict[str, object]:
    from ..cli import build_parser
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["render"]
    return {a.dest: a.default for a in sub._actions if a.dest != "help"}


def reflection_bands(gbuf, ids: np.ndarray, reflective: list[bool], camera) -> list[np.ndarray]:
    """The channels :data:`REFLECTION_NAMES`: R = U - 2 (N.U) N in view space (U the unit
    vector from the eye to the pixel's point, (0, 0, -1) for an orthographic camera; N the
    G-buffer normal) on the pixels of objects whose material reflects (``reflective[k]`` for
    object id k + 1), 0 elsewhere (terrain, empty, diffuse objects).  Float64, then float32."""
    on = np.array([False, *reflective])[ids]
    p = gbuf.position[..., :3].astype(np.float64)
    n = gbuf.normal[..., :3].astype(np.float64)
    if camera.projection == "orthographic":
        u = np.broadcast_to(np.array([0.0, 0.0, -1.0]), p.shape)
    else:
        length = np.linalg.norm(p, axis=-1, keepdims=True)
        u = np.divide(p, length, out=np.zeros_like(p), where=length > 0.0)
    r = u - 2.0 * np.sum(n * u, axis=-1, keepdims=True) * n
    r[~on] = 0.0
    return [r[..., k].astype(np.float32) for k in range(3)]


def run(args: argparse.Namespace) -> int:
    """Render the scene file ``args.input`` to ``args.output``."""
    from ..cli import PROG, CliError, GBufferExr, UsageError, frame_shadow_mask, gbuffer_bands
    from ..io import RasterWriter
    from .description import load_scene
    from .render import render_scene

    for dest, default in _render_defaults().items():
        if dest not in SCENE_OPTIONS and getattr(args, dest, default) != default:
            where = FILE_KEYS.get(dest)
            raise UsageError(f"with a scene file INPUT, --{dest.replace('_', '-')} is not used: "
                             + (f"set {where} in {args.input}" if where else "leave it out"))
    if not args.output.lower().endswith(".png"):
        raise UsageError(f"OUTPUT {args.output!r}: a scene renders a .png (add --gbuffer FILE.exr for the G-buffer)")
    if args.gbuffer is not None and not args.gbuffer.lower().endswith(".exr"):
        raise UsageError("--gbuffer takes an .exr path")
    t0 = time.perf_counter()
    desc = load_scene(args.input)
    if desc.render.ssaa > 1 and args.gbuffer is not None:
        raise UsageError(f"[render] ssaa = {desc.render.ssaa} makes the PNG only: the G-buffer has one sample per "
                         "pixel (set ssaa = 1, or leave out --gbuffer)")
    width, height = desc.camera.size
    reflective = [q.material.kind != "diffuse" for q in desc.quadrics]
    with contextlib.ExitStack() as stack:
        image = stack.enter_context(RasterWriter(args.output, (3, height, width), np.uint8))
        gbuffer = None if args.gbuffer is None else GBufferExr(args.gbuffer)     # checked before any work
        try:
            frame, scene, camera = render_scene(desc, args.device)
        except OSError as exc:
            raise CliError(str(exc)) from None
        for c in range(3):
            image.write(frame.image[..., c])
        image.finish()
        if gbuffer is not None:      # shadow channel, view and projection: oclshade.cli.GBufferExr
            host = frame.gbuffer.to_host()
            bands, names = gbuffer_bands(host, frame_shadow_mask(frame))
            if any(reflective):
                bands += reflection_bands(host, scene.ids.to_host(scene.runtime), reflective, camera)
                names = names + REFLECTION_NAMES
            gbuffer.write(bands, names, camera)
    if not args.quiet:
        passes = ", ".join(f"{name} {ms:.0f} ms" for name, ms in frame.ms.items())
        meshes = f"{len(desc.meshes)} meshes, " if desc.meshes else ""
        print(f"{PROG}: scene {args.input}: {len(desc.quadrics)} quadrics, {meshes}{width}x{height} pixels, device "
              f"{scene.runtime.label}: {passes} (with builds; run {time.perf_counter() - t0:.2f} s) -> {args.output}",
              file=sys.stderr)
    return 0
