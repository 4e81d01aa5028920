#!/usr/bin/env python
"""The device's default tuning against every variant, per kernel family, in one process.

    python bench/tuning_variants.py --reps 3 --out bench/results
    OCLSHADE_DEVICE=1 python bench/tuning_variants.py ...     # another device / driver

For each family the default values (``oclshade.tuning.settings``: user entry,
shipped database, rule or safe, ``source`` says which) and variants around
them (each knob through its legal values with the others at the default, and
for the shadow masks every lane count) are timed in rotation, ``--reps``
rounds, minimum per variant (program builds and the first run excluded), on
the headline cases:

* ``shadow``: 4096^2 ``exact`` mask at 20 degrees with its pyramid (a fresh
  caster per run, caches off), canyon (generated) and Puget Sound
  (``../shared/data``), azimuths 37 and 135; SAGA's ``ta_lighting 0``
  (bench/saga_peer.py) on the same data and sun, same process;
* ``terrain``: 1920x1080 bisect frame of the 1024^2 Puget flyover;
* ``screen_shadows``: 1920x1080 per-pixel exact shadows, sun 37/10, 2048^2 canyon;
* ``ssao``: 1920x1080 SSAO, the library default (20 line samples), same view.

Also timed: the rule's values (what a device without an entry gets) and the
safe values.  Writes ``tuning_variants_<device slug>.{json,md}`` to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Callable

sys.path.insert(0, str(Path(__file__).resolve().parent))
from saga_peer import SagaPeer, saga_cmd, saga_version  # noqa: E402
from shadow_masks import DEFAULT_DATA, REPO, Skip, load_dataset, log, metadata  # noqa: E402
from terrain_cast import flyover, resample, terrain  # noqa: E402

from oclshade import tuning  # noqa: E402
from oclshade.runtime import get_runtime  # noqa: E402
from oclshade.tuning.device import DeviceKey  # noqa: E402
from oclshade.tuning.rules import rule_values  # noqa: E402
from oclshade.tuning.store import values_id  # noqa: E402

Case = Callable[[dict], Callable[[], None]]   # knobs -> a run (first call builds)


def variants(fam: tuning.Family, default: dict, every: tuple[str, ...] = ()) -> list[dict]:
    """The default, each knob through its values around it, the rule's and the safe values."""
    out = [dict(default)]
    for p in fam.params:
        for v in p.values:
            cand = {**default, p.name: v}
            if cand not in out:
                out.append(cand)
    for extra in (rule_values(fam, get_runtime().device), fam.safe()):
        if extra not in out:
            out.append(extra)
    return out


def rotate(case: Case, knob_sets: list[dict], reps: int, finish: Callable[[], None]) -> list[float]:
    """Min wall time (ms) per knob set, the sets timed in rotation (drift hits all alike)."""
    runs = [case(k) for k in knob_sets]
    for run in runs:       # builds and first runs
        run()
        finish()
    best = [float("inf")] * len(runs)
    for _ in range(reps):
        for i, run in enumerate(runs):
            t0 = time.perf_counter()
            run()
            finish()
            best[i] = min(best[i], 1e3 * (time.perf_counter() - t0))
    return best


def summarise(name: str, fam: tuning.Family, case_name: str, knob_sets: list[dict], ms: list[float]) -> dict:
    dec = tuning.settings(get_runtime(), fam.name)
    rule = rule_values(fam, get_runtime().device)
    table = {values_id(k): t for k, t in zip(knob_sets, ms)}
    best_id = min(table, key=table.get)
    default_ms = table[values_id(dec.values)]
    row = {"family": fam.name, "case": case_name, "default": dec.values, "source": dec.source,
           "default_ms": default_ms, "best": json.loads(best_id), "best_ms": table[best_id],
           "default_over_best": default_ms / table[best_id], "rule": rule, "rule_ms": table[values_id(rule)],
           "safe_ms": table[values_id(fam.safe())], "variants_ms": table}
    log(f"{name}: default {values_id(dec.values)} [{dec.source}] {default_ms:.0f} ms, best {best_id} "
        f"{table[best_id]:.0f} ms ({row['default_over_best']:.3f}x), rule {row['rule_ms']:.0f} ms, "
        f"safe {row['safe_ms']:.0f} ms")
    return row


def shadow_rows(data: Path, size: int, reps: int, saga: bool) -> list[dict]:
    from oclshade.heightmap import Heightmap
    from oclshade.shadows import TUNING, ShadowCaster

    fam = TUNING
    dec = tuning.settings(get_runtime(), "shadow")
    sets = variants(fam, dec.values)
    sets += [k for k in ({**dec.values, "lanes": v} for v in (0, 4, 8, 16)) if k not in sets]
    rows = []
    for name in ("canyon", "puget"):
        try:
            d = load_dataset(name, size, data)
        except Skip as why:
            log(f"shadow {name}: skipped ({why})")
            continue
        hm = Heightmap.from_array(d["heights"], (d["dx"], d["dy"]))
        peer = SagaPeer(d["heights"], (d["dx"], d["dy"])) if saga and saga_cmd() else None
        for az in (37.0, 135.0):
            def case(knobs: dict, az: float = az) -> Callable[[], None]:
                return lambda: ShadowCaster(hm, cache=False, knobs=knobs).cast((az, 20.0))
            ms = rotate(case, sets, reps, lambda: None)
            row = summarise(f"shadow {name} az {az:g}", fam, f"{name} {size}^2 exact + pyramid, sun {az:g}/20",
                            sets, ms)
            if peer is not None:
                runs = [peer.run((az, 20.0)) for _ in range(reps)]
                row["saga_module_ms"] = 1e3 * min(r.module_seconds for r in runs)
                row["saga_wall_ms"] = 1e3 * min(r.wall_seconds for r in runs)
                row["saga_over_default"] = row["saga_module_ms"] / row["default_ms"]
                log(f"  SAGA module {row['saga_module_ms']:.0f} ms ({row['saga_over_default']:.2f}x the default), "
                    f"whole saga_cmd {row['saga_wall_ms']:.0f} ms")
            rows.append(row)
        if peer is not None:
            peer.close()
    return rows


def frame_rows(data: Path, reps: int, quick: bool) -> list[dict]:
    from oclshade.camera import frame_heightmap
    from oclshade.heightmap import Heightmap
    from oclshade.screen_shadows import TUNING as SCREEN, ScreenShadowCaster
    from oclshade.ssao import DEFAULT_FEATURES, DEFAULT_M, SSAO, TUNING as AO, AOInputs
    from oclshade.synthetic import canyon_crater
    from oclshade.terrain import TUNING as TERRAIN, Heightfield, TerrainRenderer

    rt = get_runtime()
    width, height = (480, 270) if quick else (1920, 1080)
    rows = []
    h, cell, source = terrain(data, quick=quick)
    size = 256 if quick else 1024
    k = h.shape[0] // size
    field = Heightfield(Heightmap.from_array(resample(h, size), cell * k))
    cam = flyover(size * cell * k, width, height)
    sets = variants(TERRAIN, tuning.settings(rt, "terrain").values)

    def render_case(knobs: dict) -> Callable[[], None]:
        r = TerrainRenderer(field, **knobs)
        r.pyramid
        return lambda: r.render(cam, on_device=True)
    rows.append(summarise("terrain", TERRAIN, f"{width}x{height} bisect, {source} at {size}^2", sets,
                          rotate(render_case, sets, reps, rt.queue.finish)))

    hm = Heightmap.from_array(canyon_crater(512 if quick else 2048, seed=0, relief=1500.0), 30.0)
    renderer = TerrainRenderer(Heightfield(hm))
    view = frame_heightmap(hm, width, height, azimuth=200.0, elevation=35.0)
    gbuf = renderer.render(view, on_device=True)
    sets = variants(SCREEN, tuning.settings(rt, "screen_shadows").values)

    def screen_case(knobs: dict) -> Callable[[], None]:
        caster = ScreenShadowCaster(hm, pyramid=renderer.pyramid, **knobs)
        bufs = caster.shade_to_device(gbuf, (37.0, 10.0))
        return lambda: caster.shade_to_device(gbuf, (37.0, 10.0), out=bufs)
    rows.append(summarise("screen_shadows", SCREEN, f"{width}x{height} exact (q = 0, the default), sun 37/10", sets,
                          rotate(screen_case, sets, reps, rt.queue.finish)))

    inputs = AOInputs(gbuf.shape, gbuf.buffers["position"], gbuf.buffers["normal"])
    sets = variants(AO, tuning.settings(rt, "ssao").values)

    def ao_case(knobs: dict) -> Callable[[], None]:
        ssao = SSAO(rt, **knobs)
        return lambda: ssao.run(inputs, view.projection_matrix, radius=120.0, m=DEFAULT_M, features=DEFAULT_FEATURES)
    what = f"{width}x{height} default AO (m = {DEFAULT_M}, {DEFAULT_FEATURES.distribution}), radius 120 m"
    rows.append(summarise("ssao", AO, what, sets,
                          rotate(ao_case, sets, reps, rt.queue.finish)))
    return rows


def write_markdown(path: Path, r: dict) -> None:
    meta = r["meta"]
    lines = [f"# Default tuning against every variant: {r['device']['device']}", "",
             f"- {meta['date']}; `{meta['command']}`",
             f"- CPU: {meta['cpu']}, {meta['cores']} cores; device: {DeviceKey(**r['device']).describe()}",
             f"- minimum wall time of {r['reps']} rounds, variants timed in rotation; builds excluded", "",
             "| family | case | default (source) | default ms | fastest variant | fastest ms | default / fastest "
             "| rule ms | safe ms | SAGA module ms (saga_cmd ms) |",
             "|---|---|---|---:|---|---:|---:|---:|---:|---:|"]
    for row in r["rows"]:
        saga = (f"{row['saga_module_ms']:.0f} ({row['saga_wall_ms']:.0f})" if "saga_module_ms" in row else "-")
        lines.append(f"| {row['family']} | {row['case']} | {values_id(row['default'])} ({row['source']}) | "
                     f"{row['default_ms']:.0f} | {values_id(row['best'])} | {row['best_ms']:.0f} | "
                     f"{row['default_over_best']:.3f} | {row['rule_ms']:.0f} | {row['safe_ms']:.0f} | {saga} |")
    lines += ["", "Every variant's time (ms):", ""]
    for row in r["rows"]:
        lines.append(f"- {row['family']}, {row['case']}: " +
                     ", ".join(f"`{k}` {v:.0f}" for k, v in sorted(row["variants_ms"].items(), key=lambda kv: kv[1])))
    path.write_text("\n".join(lines) + "\n")


def main(argv: list[str] | None = None) -> int:
    argv_list = list(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", type=Path, default=DEFAULT_DATA)
    p.add_argument("--reps", type=int, default=3)
    p.add_argument("--quick", action="store_true", help="smoke run on small inputs")
    p.add_argument("--no-saga", action="store_true")
    p.add_argument("--only", choices=("shadow", "frames"), help="one part only")
    p.add_argument("--out", type=Path, default=REPO / "bench" / "results")
    args = p.parse_args(argv_list)
    key = DeviceKey.of(get_runtime().device)
    rows = []
    if args.only in (None, "shadow"):
        rows += shadow_rows(args.data, 256 if args.quick else 4096, args.reps, not args.no_saga)
    if args.only in (None, "frames"):
        rows += frame_rows(args.data, args.reps, args.quick)
    result = {"meta": metadata(["bench/tuning_variants.py", *argv_list]), "device": key.as_dict(),
              "reps": args.reps, "saga": saga_version() if saga_cmd() else None, "rows": rows}
    args.out.mkdir(parents=True, exist_ok=True)
    stem = f"tuning_variants_{key.slug}" + (f"_{args.only}" if args.only else "")
    (args.out / f"{stem}.json").write_text(json.dumps(result, indent=1) + "\n")
    write_markdown(args.out / f"{stem}.md", result)
    log(f"wrote {args.out}/{stem}.{{json,md}}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
