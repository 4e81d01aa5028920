#!/usr/bin/env python
"""A sun given by its angles on a georeferenced map, as the API and the CLI cast it: what
``ShadowCaster.cast(sun)`` on ``Heightmap.from_raster`` (each block of rows and columns at its
own scale, the field made at the call: ``oclshade.solar.field.banded_field``) costs against the
grid as drawn (``Heightmap.from_array``: one sun, no blocks).

    python bench/sun_by_angles.py             # N22W160's heights on the projected grids and
                                              # EU-DEM tiles of bench/geographic_scale.py
    python bench/sun_by_angles.py --reduced   # a check that the script works (two maps)

Per map and sun: the best of 3 rounds, each the best of 3 casts of either, in turn (a warm-up
first), and their ratio; the field's blocks and column step (its packet runs divide it).
Writes bench/results/sun_by_angles.{json,md}; figures depend on the machine, the results record
where they were taken.  Runs on another commit: copy this file into a worktree of it.
"""
from __future__ import annotations

import sys
import tempfile
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
sys.path.insert(0, str(REPO))

import geographic_scale as gs  # noqa: E402  (its maps)
from shadow_masks import header, log, metadata, publish, results_arguments  # noqa: E402
from sun_field import best_of  # noqa: E402

from oclshade import ShadowCaster, Sun  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.io import read_dem  # noqa: E402
from oclshade.solar.field import on_heightmap  # noqa: E402
from oclshade.sun import SunField  # noqa: E402

SUNS = (Sun(135.0, 15.0), Sun(315.0, 45.0), Sun(90.0, 20.0))
PROJECTED = (32633, 3857, 5070, 3035)      # of bench/geographic_scale.py's PROJECTED


def run(reduced: bool, folder: Path) -> dict:
    base = read_dem(gs.SRTM / "N22W160v2.3a.hgt.zip")
    maps = {"SRTM N22W160": base}
    maps.update({name: gs.projected(base, name, epsg, lon, lat, folder)
                 for name, epsg, lon, lat in gs.PROJECTED if epsg in PROJECTED})
    maps.update({name: gs.tile(base, west, north, folder) for name, west, north in gs.TILES})
    if reduced:
        maps = dict(list(maps.items())[1:2] + list(maps.items())[-1:])
    out = {"meta": metadata(sys.argv), "maps": []}
    for name, raster in maps.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            blocked = Heightmap.from_raster(raster)
        drawn = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
        per_block, as_drawn = ShadowCaster(blocked, cache=False), ShadowCaster(drawn, cache=False)
        for sun in SUNS:
            per_block.cast(sun)
            as_drawn.cast(sun)
            tb, td = [], []
            for _ in range(3):
                tb.append(best_of(lambda: per_block.cast(sun)))
                td.append(best_of(lambda: as_drawn.cast(sun)))
            field = on_heightmap(blocked, sun)
            blocks, step = (len(field.blocks), field.column_step) if isinstance(field, SunField) else (1, None)
            row = {"map": name, "sun": [sun.azimuth, sun.elevation], "blocks": blocks, "column_step": step,
                   "per_block_s": min(tb), "as_drawn_s": min(td), "ratio": min(tb) / min(td)}
            out["maps"].append(row)
            log(f"{name} {sun.azimuth:g}/{sun.elevation:g}: {blocks} blocks, {min(tb) * 1e3:.1f} ms against "
                f"{min(td) * 1e3:.1f} ms, {row['ratio']:.2f}x")
    return out


def markdown(result: dict) -> str:
    m = result["meta"]
    lines = ["# A sun given by its angles, cast per block at the call, against the grid as drawn", "",
             header(m, "python bench/sun_by_angles.py"), "",
             "`ShadowCaster.cast(sun)` on `Heightmap.from_raster` (the field made at each call) against "
             "`Heightmap.from_array` of the same heights; best of 3 rounds of best of 3, in turn.", "",
             "| map | sun az / el | blocks | column step | per block ms | as drawn ms | ratio |",
             "|---|---|---:|---:|---:|---:|---:|"]
    for r in result["maps"]:
        lines.append(f"| {r['map']} | {r['sun'][0]:g} / {r['sun'][1]:g} | {r['blocks']} | {r['column_step']} | "
                     f"{1e3 * r['per_block_s']:.1f} | {1e3 * r['as_drawn_s']:.1f} | {r['ratio']:.2f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    args = results_arguments(argv, __doc__, "sun_by_angles", "two maps")
    if not (gs.SRTM / "N22W160v2.3a.hgt.zip").is_file():
        print(f"{gs.SRTM} absent: nothing to measure", file=sys.stderr)
        return 0
    with tempfile.TemporaryDirectory() as folder:
        result = run(args.reduced, Path(folder))
    return publish(args.out, result, markdown(result))


if __name__ == "__main__":
    sys.exit(main())
