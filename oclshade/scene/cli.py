"""``oclshade render SCENE.toml OUT.png``: a scene file rendered (the render command's hook).

The scene file holds the terrain, camera, sun, render settings, environment and quadrics
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


def is_scene(path: str) -> bool:
    return path.lower().endswith(".toml")


def _render_defaults() -> dict[str, object]:
    from ..cli import build_parser
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["render"]
    return {a.dest: a.default for a in sub._actions if a.dest != "help"}


def run(args: argparse.Namespace) -> int:
    """Render the scene file ``args.input`` to ``args.output``."""
    from ..cli import GBUFFER_NAMES, PROG, CliError, UsageError, gbuffer_bands
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
    with contextlib.ExitStack() as stack:
        image = stack.enter_context(RasterWriter(args.output, (3, height, width), np.uint8))
        gbuffer = None if args.gbuffer is None else stack.enter_context(
            RasterWriter(args.gbuffer, (len(GBUFFER_NAMES), height, width), np.float32, band_names=GBUFFER_NAMES))
        try:
            frame, scene, _ = render_scene(desc, args.device)
        except OSError as exc:
            raise CliError(str(exc)) from None
        for c in range(3):
            image.write(frame.image[..., c])
        if gbuffer is not None:
            for band in gbuffer_bands(frame.gbuffer.to_host())[0]:
                gbuffer.write(band)
            gbuffer.finish()
        image.finish()
    if not args.quiet:
        passes = ", ".join(f"{name} {ms:.0f} ms" for name, ms in frame.ms.items())
        print(f"{PROG}: scene {args.input}: {len(desc.quadrics)} quadrics, {width}x{height} pixels, device "
              f"{scene.runtime.label}: {passes} (with builds; run {time.perf_counter() - t0:.2f} s) -> {args.output}",
              file=sys.stderr)
    return 0
