"""The timing must-shows of the issues, measured in one process on one quiet machine.

Each figure is the minimum wall time of ``--reps`` runs after a warm-up (program
builds excluded), on the same data and views as the full benchmarks:

* issue 2: 4096^2 ``exact`` heightmap mask at 20 degrees (azimuths 37 and 135),
  pyramid included (a fresh caster per run, caches off), canyon (generated) and
  Puget Sound (``../shared/data``); with the device's default kernel (ray
  ray packets where the tuning chose them) and, as the baseline, one ray per work-item; beside them the
  outside peer, SAGA's ``ta_lighting 0`` shadows-only mask on the same data and
  sun (bench/saga_peer.py: the tool's own time, grid writing, saga_cmd start-up,
  loading and saving excluded; minimum of ``--reps`` runs), its ratio to the
  default kernel and how much its mask agrees with oclshade's ('not installed'
  when ``saga_cmd`` is absent);
* issue 3: 1920x1080 frame of the 1024^2 terrain (bench/terrain_cast.py's
  Puget flyover), bisect against dda and march;
* issue 4: 1920x1080 per-pixel shadows on the 2048^2 canyon, sun 10 degrees,
  automatic q (bench/screen_shadows.py's view);
* issue 5: 1920x1080 SSAO, the paper's recipe (m = 32 with the 5x5 box blur), and the library's
  default setting (line samples), on the same view.

Writes ``headlines.json`` and ``headlines.md`` to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Callable

sys.path.insert(0, str(Path(__file__).resolve().parent))
from saga_peer import SagaPeer, agreement, saga_cmd, saga_version  # noqa: E402
from shadow_masks import DEFAULT_DATA, REPO, Skip, load_dataset, log, metadata  # noqa: E402
from terrain_cast import flyover, resample, terrain  # noqa: E402


def best_ms(fn: Callable[[], object], finish: Callable[[], None], reps: int) -> float:
    fn()
    finish()
    best = float("inf")
    for _ in range(reps):
        t0 = time.perf_counter()
        fn()
        finish()
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best


def saga_status(enabled: bool) -> str | None:
    """None when the SAGA peer runs, else why not ('not installed', 'skipped (--no-saga)')."""
    if not enabled:
        return "skipped (--no-saga)"
    return None if saga_cmd() is not None else "not installed"


def saga_peer(peer: SagaPeer | None, status: str | None, az: float, reps: int, ms: float,
              ocl_mask, valid) -> dict:
    """SAGA's module time (min of reps) for one sun, its ratio to oclshade's and the agreement."""
    if peer is None:
        return {"saga_ms": None, "saga": status or "not installed"}
    try:
        runs = [peer.run((az, 20.0)) for _ in range(reps)]
    except Exception as exc:  # a peer that fails is recorded, never fatal
        return {"saga_ms": None, "saga": f"failed: {str(exc).splitlines()[0]}"}
    best = min(runs, key=lambda r: r.module_seconds)
    saga_ms = 1e3 * best.module_seconds
    return {"saga_ms": saga_ms, "saga": "ok", "saga_over_oclshade": saga_ms / ms,
            "saga_timing": best.timing, "saga_reported_ms": best.reported_ms,
            "saga_wall_s": min(r.wall_seconds for r in runs), "saga_processors": best.processors,
            "saga_agreement": agreement(best.mask, ocl_mask, valid)}


def shadow_masks(data: Path, size: int, reps: int, saga: bool = True) -> list[dict]:
    import numpy as np
    from oclshade.heightmap import Heightmap
    from oclshade.shadows import ShadowCaster

    status = saga_status(saga)
    rows = []
    for name in ("canyon", "puget"):
        try:
            d = load_dataset(name, size, data)
        except Skip as why:
            log(f"shadows: {name} skipped ({why})")
            continue
        hm = Heightmap.from_array(d["heights"], (d["dx"], d["dy"]))
        peer = None
        if status is None:
            try:   # the grid is written here, outside every timing
                peer = SagaPeer(d["heights"], (d["dx"], d["dy"]))
            except Exception as exc:
                status = f"failed: {exc}"
        for az in (37.0, 135.0):
            def run(single_ray: bool = False) -> None:
                knobs = {"lanes": 0} if single_ray else None   # the device's tuning, or one ray per work-item
                ShadowCaster(hm, cache=False, knobs=knobs).cast((az, 20.0))
            ms = best_ms(run, lambda: None, reps)
            single = best_ms(lambda: run(True), lambda: None, reps)   # one ray per work-item
            row = {"map": f"{name} {size}^2", "sun": [az, 20.0], "ms": ms, "single_ray_ms": single}
            mask = ShadowCaster(hm, cache=False).cast((az, 20.0)).mask if peer is not None else None
            row.update(saga_peer(peer, status, az, reps, ms, mask, np.isfinite(d["heights"])))
            rows.append(row)
            peer_txt = (f"SAGA {row['saga_ms']:.0f} ms ({row['saga_over_oclshade']:.1f}x), agreement "
                        f"{row['saga_agreement']['agree_pct']:.2f} %" if row["saga_ms"] is not None
                        else f"SAGA {row['saga']}")
            log(f"shadows {name} az {az:g}: {ms:.0f} ms (one ray per work-item: {single:.0f} ms); {peer_txt}")
        if peer is not None:
            peer.close()
    return rows


def render(data: Path, size: int, reps: int) -> dict:
    from oclshade.heightmap import Heightmap
    from oclshade.terrain import Heightfield, TerrainRenderer

    h, cell, source = terrain(data, quick=False)
    k = h.shape[0] // size
    hm = Heightmap.from_array(resample(h, size), cell * k)
    renderer = TerrainRenderer(Heightfield(hm))
    cam = flyover(size * cell * k, 1920, 1080)
    out = {"map": f"{source} resampled to {size}^2", "ms": {}}
    for method in ("bisect", "dda", "march"):
        buf = renderer.render(cam, method, on_device=True)
        out["ms"][method] = best_ms(lambda: renderer.render(cam, method, on_device=True, out=buf),
                                    renderer.runtime.queue.finish, reps)
        log(f"render {method}: {out['ms'][method]:.0f} ms")
    return out


def screen_passes(size: int, reps: int) -> dict:
    from oclshade.camera import frame_heightmap
    from oclshade.heightmap import Heightmap
    from oclshade.screen_shadows import ScreenShadowCaster
    from oclshade.ssao import DEFAULT_FEATURES, DEFAULT_M, PAPER_M, PAPER_RECIPE, SSAO, AOInputs
    from oclshade.synthetic import canyon_crater
    from oclshade.terrain import Heightfield, TerrainRenderer

    hm = Heightmap.from_array(canyon_crater(size, size, seed=0, relief=1500.0), 30.0)
    renderer = TerrainRenderer(Heightfield(hm))
    cam = frame_heightmap(hm, 1920, 1080, azimuth=200.0, elevation=35.0)
    gbuf = renderer.render(cam, on_device=True)
    queue = renderer.runtime.queue
    caster = ScreenShadowCaster(hm, pyramid=renderer.pyramid)
    out: dict = {"map": f"canyon_crater({size}, seed=0, relief=1500), 30 m", "view": "frame_heightmap(az 200, el 35)"}
    for method in ("exact", "maxmip"):
        bufs = caster.shade_to_device(gbuf, (37.0, 10.0), method)
        out[f"shadows_{method}_ms"] = best_ms(lambda: caster.shade_to_device(gbuf, (37.0, 10.0), method, out=bufs),
                                              queue.finish, reps)
        log(f"screen shadows {method}: {out[f'shadows_{method}_ms']:.0f} ms")
    ssao = SSAO(renderer.runtime)
    inputs = AOInputs(gbuf.shape, gbuf.buffers["position"], gbuf.buffers["normal"])
    radius = 4.0 * hm.dx
    out["ao_setting"] = f"m = {PAPER_M}, {PAPER_RECIPE}, radius {radius:g} m"
    out["ao_ms"] = best_ms(lambda: ssao.run(inputs, cam.projection_matrix, radius=radius, m=PAPER_M,
                                            features=PAPER_RECIPE), queue.finish, reps)
    out["ao_default_setting"] = f"m = {DEFAULT_M}, {DEFAULT_FEATURES}, radius {radius:g} m"
    out["ao_default_ms"] = best_ms(lambda: ssao.run(inputs, cam.projection_matrix, radius=radius, m=DEFAULT_M,
                                                    features=DEFAULT_FEATURES), queue.finish, reps)
    log(f"ssao: paper recipe {out['ao_ms']:.0f} ms, default {out['ao_default_ms']:.0f} ms")
    out["hit_pixels"] = int(gbuf.to_host().hit.sum())
    return out


def write_markdown(path: Path, r: dict) -> None:
    meta = r["meta"]
    lines = ["# Headline timings (the issues' must-shows)", "",
             f"- {meta['date']}; `{meta['command']}`",
             f"- CPU: {meta['cpu']}, {meta['cores']} cores; device: {meta['device']}; PoCL {meta['pocl_version']}",
             f"- minimum wall time of {r['reps']} runs after a warm-up", "",
             "| issue | what | ms | target | peer: SAGA ms | SAGA / oclshade |",
             "|---|---|---:|---|---:|---:|"]
    for row in r["shadow_masks"]:
        if row.get("saga_ms") is not None:
            peer = f"{row['saga_ms']:.0f} | {row['saga_over_oclshade']:.2f}x"
        else:
            peer = f"{row.get('saga', 'not installed')} | -"
        lines.append(f"| 2 | exact mask + pyramid, {row['map']}, sun {row['sun'][0]:g}/20 | {row['ms']:.0f} | "
                     f"<= 1000 | {peer} |")
        lines.append(f"| 2 | same, one ray per work-item (packets off) | {row['single_ray_ms']:.0f} | baseline | | |")
    rd = r["render"]
    for method, ms in rd["ms"].items():
        lines.append(f"| 3 | 1920x1080 {method}, {rd['map']} | {ms:.0f} | "
                     f"{'<= 400' if method == 'bisect' else 'baseline'} | | |")
    sp = r["screen"]
    lines += [f"| 4 | 1920x1080 per-pixel shadows exact, auto q, sun 37/10, {sp['map']} | "
              f"{sp['shadows_exact_ms']:.0f} | <= 250 | | |",
              f"| 4 | same, maxmip (no min early exit) | {sp['shadows_maxmip_ms']:.0f} | "
              "exact 1.3x faster expected | | |",
              f"| 5 | 1920x1080 SSAO, paper recipe: {sp['ao_setting']} | {sp['ao_ms']:.0f} | <= 150 | | |",
              f"| 5 | 1920x1080 SSAO, default: {sp['ao_default_setting']} | {sp['ao_default_ms']:.0f} | "
              "<= paper recipe | | |",
              "", f"Screen-space view: {sp['view']}, {sp['hit_pixels']} pixels see terrain."]
    pr = r.get("peer", {})
    agree = [f"{row['map'].split()[0]} {row['sun'][0]:g}/20: {row['saga_agreement']['agree_pct']:.2f} %"
             for row in r["shadow_masks"] if row.get("saga_ms") is not None]
    lines += ["", f"Peer: {pr.get('saga', 'SAGA not installed')}. {pr.get('note', '')}".rstrip()]
    if agree:
        lines.append("Cells where SAGA's mask equals oclshade's (valid cells; a different definition, "
                     "not an error): " + "; ".join(agree) + ".")
    path.write_text("\n".join(lines) + "\n")


def main(argv: list[str] | None = None) -> int:
    argv_list = list(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", type=Path, default=DEFAULT_DATA)
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--quick", action="store_true", help="smoke run on small maps")
    p.add_argument("--out", type=Path, default=REPO / "bench" / "results")
    p.add_argument("--no-saga", action="store_true", help="leave out the SAGA peer column")
    args = p.parse_args(argv_list)
    big, mid, small = (256, 128, 64) if args.quick else (4096, 2048, 1024)
    status = saga_status(not args.no_saga)
    peer = {"saga": f"SAGA {status}" if status else
            f"SAGA {saga_version()} `saga_cmd -f=q ta_lighting 0 -METHOD=3 -POSITION=0 "
            "-AZIMUTH=az -DECLINATION=20 -SHADOW=0` (shadows only, slim)",
            "note": "" if status else
            "SAGA ms = the tool alone, timed from saga_cmd's 'Execution started' to 'total execution time' "
            "lines (SAGA's own figure has 1 s resolution), without saga_cmd start-up, grid loading and "
            "saving; oclshade ms include the pyramid and the mask's copy to the host."}
    result = {"meta": metadata(["bench/headlines.py", *argv_list]), "reps": args.reps, "peer": peer,
              "shadow_masks": shadow_masks(args.data, big, args.reps, saga=not args.no_saga),
              "render": render(args.data, small, args.reps),
              "screen": screen_passes(mid, args.reps)}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "headlines.json").write_text(json.dumps(result, indent=1) + "\n")
    write_markdown(args.out / "headlines.md", result)
    log(f"wrote {args.out}/headlines.{{json,md}}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
