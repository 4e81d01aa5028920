#!/usr/bin/env python
"""The picture gallery of ``oclshade render`` (docs/gallery/): every picture and the README
that shows them, from one script, so that a change in look is seen in review.

    python bench/gallery.py                     # writes docs/gallery/*.png and README.md
    python bench/gallery.py --out /tmp/g --quick   # small frames, a check that it runs

Pictures (640x360 unless said; PNG, optimised):

* ``canyon_before.png`` / ``canyon_after.png``: the bundled canyon (data/canyon_512.tif) as
  ``oclshade render data/canyon_512.tif view.png --view 200,25 --sun 300,15 --ao 6`` shows it,
  with the look before docs/methods.md "Image quality in render" (faceted normals, sun 1.6 and
  sky (0.22, 0.26, 0.32), paper 000 eq. (1)'s shadow levels) and after; the same camera.
* ``facets_before.png`` / ``facets_after.png``: a close view of the canyon's plateau, faceted
  (the G-buffer's normal) and smooth shading normals.
* ``framing_whole.png``: ``--crop 0`` (the whole map; ``canyon_after.png`` has the default crop).
* ``shadow_overlay.png`` (512x512): the exact heightmap shadow mask (sun 300,15) on a
  hillshade, as ``oclshade shadow --preview`` draws it.
* ``ao_off.png`` / ``ao_on.png`` / ``ao_factor.png``: AO off and on (radius 30 cells: at 6
  cells the canyon's walls, about 1 km high, hardly occlude anything) with the sun low behind
  the terrain (20,12), and the AO factor (white = 1, unoccluded).
* ``pixel_shadows_q0.png`` / ``pixel_shadows_auto.png`` / ``pixel_shadows_diff.png``: per-pixel
  shadows at level 0 (exact) and at Algo 1's automatic level, and the pixels where they differ.
* ``ssaa1.png`` / ``ssaa3.png``: a 160x90 crop of the frame at 1 and 3 x 3 samples per pixel,
  magnified 4 times (nearest).
* ``real_before.png`` / ``real_after.png``: a real DEM (``/work/shared/data``: SRTM30, central
  Japan; left out with a note when absent).

Figures written into the README (no timings: these are properties of the frames): on the
command above at 1280x720, the fraction of terrain pixels that cast shadows darken and the
median ratio of their value with and without shadows (mean of the sRGB channels), for the
before and after looks; the fraction of the frame that shows terrain at several views with
``crop=0`` and the default crop.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from PIL import Image  # noqa: E402

from oclshade.camera import DEFAULT_CROP, Camera, frame_heightmap  # noqa: E402
from oclshade.compose import Lighting  # noqa: E402
from oclshade.frames import AOSettings, FrameSettings, TerrainScene  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.io import read_dem  # noqa: E402
from oclshade.preview import shadow_overlay  # noqa: E402
from oclshade.screen_shadows import LodOptions  # noqa: E402
from oclshade.shadows import ShadowCaster  # noqa: E402
from oclshade.terrain import Heightfield  # noqa: E402

CANYON = REPO / "data" / "canyon_512.tif"
REAL = Path("/work/shared/data/dem/srtm30_qgis2threejs/dem_srtm30.tif")
VIEW, SUN, AO_CELLS = (200.0, 25.0), (300.0, 15.0), 6.0
AO_SUN, AO_WIDE = (20.0, 12.0), 30.0          # the AO pictures: the sun behind the terrain, a wide radius
#: the look before docs/methods.md "Image quality in render" (what is cheap to bring back)
BEFORE = dict(normals="geometric", shadow_k=(0.25, 0.65))
BEFORE_LIGHT = dict(sun_intensity=1.6, sky=(0.22, 0.26, 0.32))
FRAMING_VIEWS = ((200.0, 30.0), (200.0, 25.0), (0.0, 30.0), (45.0, 30.0), (135.0, 45.0), (200.0, 60.0),
                 (90.0, 15.0), (30.0, 89.0))


def load(path: Path) -> Heightmap:
    r = read_dem(path)
    return Heightmap.from_array(r.heights, cellsize=(r.dx, r.dy))


def settings(before: bool, sun: tuple[float, float] = SUN, **kw) -> FrameSettings:
    light = Lighting(sun=sun, **(BEFORE_LIGHT if before else {}))
    return FrameSettings(lighting=light, **(BEFORE if before else {}), **kw)


def save(img: np.ndarray, path: Path) -> str:
    Image.fromarray(np.ascontiguousarray(img[..., :3])).save(path, optimize=True)
    return path.name


def shadow_contrast(scene: TerrainScene, camera: Camera, base: FrameSettings) -> tuple[float, float, float]:
    """(terrain fraction of the frame, fraction of terrain pixels cast shadows darken, median
    ratio of their value with / without shadows), values the mean of the sRGB channels."""
    on = scene.frame(camera, SUN, base)
    hit = on.gbuffer.to_host().hit
    lum_on = on.image[..., :3].astype(float).mean(-1)
    lum_off = scene.frame(camera, SUN, dataclasses.replace(base, shadows=False)).image[..., :3].astype(float).mean(-1)
    dark = hit & (lum_on < lum_off)
    return float(hit.mean()), float(dark.sum() / hit.sum()), float(np.median(lum_on[dark] / lum_off[dark]))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=REPO / "docs" / "gallery")
    ap.add_argument("--quick", action="store_true", help="small frames (a check that the script runs)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    w, h = (160, 90) if args.quick else (640, 360)
    big = (320, 180) if args.quick else (1280, 720)
    hm = load(CANYON)
    scene = TerrainScene(Heightfield(hm))
    ao = AOSettings(radius=AO_CELLS * max(hm.dx, hm.dy))
    cam = frame_heightmap(hm, w, h, *VIEW)
    files: dict[str, str] = {}
    lines: list[str] = []

    def frame(name: str, camera: Camera, s: FrameSettings, sun: tuple[float, float] = SUN) -> np.ndarray:
        image = scene.frame(camera, sun, s).image
        files[name] = save(image, args.out / f"{name}.png")
        return image

    for look in ("before", "after"):
        frame(f"canyon_{look}", cam, settings(look == "before", ao=ao))
    close = Camera(np.array([4200.0, -11800.0, 2300.0]), np.array([6200.0, -8200.0, 1350.0]), w, h,
                   near=10.0, far=3e4)
    frame("facets_before", close, settings(False, normals="geometric"))
    frame("facets_after", close, settings(False))
    frame("framing_whole", frame_heightmap(hm, w, h, *VIEW, crop=0.0), settings(False, ao=ao))
    mask = ShadowCaster(hm).cast(SUN).mask
    files["shadow_overlay"] = save(shadow_overlay(hm.heights, hm.dx, hm.dy, *SUN, mask), args.out / "shadow_overlay.png")
    frame("ao_off", cam, settings(False, sun=AO_SUN), AO_SUN)
    wide = scene.frame(cam, AO_SUN, settings(False, sun=AO_SUN, ao=AOSettings(radius=AO_WIDE * max(hm.dx, hm.dy))))
    files["ao_on"] = save(wide.image, args.out / "ao_on.png")
    factor = wide.ao_factor()
    files["ao_factor"] = save(np.repeat((255.0 * factor[..., None] + 0.5).astype(np.uint8), 3, -1),
                              args.out / "ao_factor.png")
    hit = wide.gbuffer.to_host().hit
    lines.append(f"- AO radius {AO_WIDE:g} cells, view {VIEW[0]:g},{VIEW[1]:g}: mean AO factor over terrain pixels "
                 f"{factor[hit].mean():.3f}; at the command's radius {AO_CELLS:g} cells "
                 f"{scene.frame(cam, SUN, settings(False, ao=ao)).ao_factor()[hit].mean():.3f}")
    q0 = frame("pixel_shadows_q0", cam, settings(False, lod=LodOptions(force_q=0)))
    auto = frame("pixel_shadows_auto", cam, settings(False))
    differ = np.any(q0[..., :3] != auto[..., :3], axis=-1)
    diff = (0.5 * q0[..., :3].astype(float).mean(-1, keepdims=True)).repeat(3, -1).astype(np.uint8)
    diff[differ] = (230, 30, 30)
    files["pixel_shadows_diff"] = save(diff, args.out / "pixel_shadows_diff.png")
    lines.append(f"- per-pixel shadows, automatic q against q = 0: {differ.mean():.2%} of the pixels differ "
                 f"(red in pixel_shadows_diff.png)")
    zoom = (slice(h // 4, h // 4 + h // 4), slice(w // 2, w // 2 + w // 4))
    for n in (1, 3):
        img = scene.frame(cam, SUN, settings(False, ssaa=n)).image[zoom]
        files[f"ssaa{n}"] = save(img.repeat(4, 0).repeat(4, 1), args.out / f"ssaa{n}.png")
    if REAL.exists():
        real = load(REAL)
        real_scene = TerrainScene(Heightfield(real))
        real_cam = frame_heightmap(real, w, h, 160.0, 35.0)
        real_ao = AOSettings(radius=AO_CELLS * max(real.dx, real.dy))
        for look in ("before", "after"):
            img = real_scene.frame(real_cam, (250.0, 20.0), settings(look == "before", sun=(250.0, 20.0), ao=real_ao))
            files[f"real_{look}"] = save(img.image, args.out / f"real_{look}.png")
    else:
        lines.append(f"- the real DEM ({REAL}) is absent: its frames are left out")

    # figures
    cmd_cam = frame_heightmap(hm, *big, *VIEW)
    whole_cam = frame_heightmap(hm, *big, *VIEW, crop=0.0)
    for look in ("before", "after"):
        for label, c in (("default framing", cmd_cam), ("whole map, crop 0", whole_cam)):
            t, d, r = shadow_contrast(scene, c, settings(look == "before", ao=ao))
            lines.append(f"- {look} look, {label}: cast shadows darken {d:.1%} of the terrain pixels to a median "
                         f"{r:.3f} of their value without shadows (terrain {t:.1%} of the frame)")
    lines.append("")
    lines.append(f"Terrain fraction of a {big[0]}x{big[1]} frame of the canyon, perspective (fov 45):")
    lines.append("")
    lines.append(f"| view (az, el) | crop 0 (whole map) | default crop {DEFAULT_CROP:g} |")
    lines.append("|---|---|---|")
    renderer = scene.renderer
    for az, el in FRAMING_VIEWS:
        f0 = renderer.render(frame_heightmap(hm, *big, az, el, crop=0.0)).hit.mean()
        f1 = renderer.render(frame_heightmap(hm, *big, az, el)).hit.mean()
        lines.append(f"| {az:g}, {el:g} | {f0:.1%} | {f1:.1%} |")
    (args.out / "README.md").write_text(readme(files, lines, big))
    print("\n".join(lines))
    return 0


def pair(files: dict[str, str], a: str, b: str, caption_a: str, caption_b: str) -> str:
    cells = [f"![{caption}]({files[k]})" if k in files else "(absent)" for k, caption in ((a, caption_a), (b, caption_b))]
    return f"| {caption_a} | {caption_b} |\n|---|---|\n| {cells[0]} | {cells[1]} |\n"


def readme(files: dict[str, str], figures: list[str], size: tuple[int, int]) -> str:
    cmd = "oclshade render data/canyon_512.tif view.png --view 200,25 --sun 300,15 --ao 6 --size 640x360"
    return f"""# Gallery: what `oclshade render` draws

Made by `python bench/gallery.py` (every picture and this page; run it again after a change
in look and review the difference).  The model behind the pictures: docs/methods.md, "Image
quality in render".  "Before" is the look before that section, as far as it is cheap to bring
back: faceted normals, sun 1.6 and sky (0.22, 0.26, 0.32), paper 000 eq. (1)'s shadow levels
(0.25 + 0.4 sin(sun elevation) of the sun left in shadow); the sky's tilt factor (1 + cos) / 2
is the one part of the new model it keeps.

## Before and after

`{cmd}` (the before look: FrameSettings(normals="geometric", shadow_k=(0.25, 0.65)) and
Lighting(sun_intensity=1.6, sky=(0.22, 0.26, 0.32)); the same camera)

{pair(files, "canyon_before", "canyon_after", "before", "after")}
A close view of the plateau: the G-buffer's geometric normal (every bilinear patch a facet)
and the smooth shading normal (slopes interpolated from the samples' central differences).

{pair(files, "facets_before", "facets_after", "faceted normals", "smooth shading normals")}
## Framing

`--crop 0` (the whole map, fitted tightly) and the default (the camera moves in until the map
fills the frame or {DEFAULT_CROP:g} of the map has left it).

{pair(files, "framing_whole", "canyon_after", "--crop 0", f"default (--crop {DEFAULT_CROP:g})")}
## Shadows and ambient occlusion

The exact heightmap shadow mask for the sun 300,15 on a hillshade (as `oclshade shadow
--preview` draws it), beside the rendered frame's per-pixel shadows:

| shadow mask on a hillshade | per-pixel shadows, q = 0 (exact) |
|---|---|
| ![mask]({files["shadow_overlay"]}) | ![q0]({files["pixel_shadows_q0"]}) |

Per-pixel shadows at Algo 1's automatic level q (the default) and where they differ from q = 0
(red):

{pair(files, "pixel_shadows_auto", "pixel_shadows_diff", "automatic q", "differs from q = 0")}
AO scales the sky term only: it shows where the sky lights the ground, in shadow above all.
Sun 20,12 (low, behind the terrain), radius 30 cells (`--ao 30`; at `--ao 6`, 180 m, the
canyon's walls, about 1 km high, occlude almost nothing: see the figures below), and the AO
factor (white = 1):

{pair(files, "ao_off", "ao_on", "AO off", "--ao 30")}
![AO factor]({files["ao_factor"]})

## Supersampling

A crop magnified 4 times: one sample per pixel, and `--ssaa 3` (shadows and AO per sample,
box-filtered):

{pair(files, "ssaa1", "ssaa3", "--ssaa 1", "--ssaa 3")}
## A real DEM

SRTM30, central Japan (/work/shared/data/dem/srtm30_qgis2threejs/dem_srtm30.tif), view 160,35,
sun 250,20, AO 6 cells:

{pair(files, "real_before", "real_after", "before", "after")}
## Figures

On `oclshade render data/canyon_512.tif view.png --view 200,25 --sun 300,15 --ao 6` at
{size[0]}x{size[1]} (values: mean of the sRGB channels; "darken": darker than with --no-shadows):

{chr(10).join(figures)}
"""


if __name__ == "__main__":
    sys.exit(main())
