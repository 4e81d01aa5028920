#!/usr/bin/env python
"""SAGA GIS as the outside peer for cast-shadow masks.

    python bench/saga_peer.py --size 1024 --sun 37,20            # canyon (generated)
    python bench/saga_peer.py --dataset puget --size 4096 --sun 135,20

The peer is ``saga_cmd ta_lighting 0`` (Analytical Hillshading) with
``-METHOD=3`` ("Shadows Only": shadowed cells get pi/2, every other cell
no-data), ``-POSITION=0`` (azimuth and height given), ``-AZIMUTH`` in degrees
clockwise from north and ``-DECLINATION`` (the sun's height) in degrees above
the horizon -- the same words as gdaldem and :class:`oclshade.sun.Sun` -- and
``-SHADOW=0`` ("slim", SAGA's default: one trace per cell node; ``--shadow fat``
also marks the side neighbour a ray passes near).  SAGA's definition is not
oclshade's: it walks from every cell *away* from the sun one cell per step
along the major axis (nearest-cell sampling, no interpolation), lowering a
height by tan(height) per step, and marks every cell below that line until the
terrain rises above it.  It is a peer, not a reference: agreement is reported,
never asserted.

Grids go to SAGA as its native ``.sgrd`` header + raw little-endian float32
``.sdat`` (written here, ``TOPTOBOTTOM = TRUE`` so rows go north to south as in
oclshade; ``POSITION_XMIN/YMIN`` is the centre of the lower-left cell; NaN
becomes ``NODATA_VALUE``), before and outside any timing.  SAGA needs square
cells (one ``CELLSIZE``).

Timing: ``saga_cmd`` prints ``total execution time: N milliseconds`` for the
tool, but SAGA 8.5 measures it with one-second resolution (it reads 0 ms for an
80 ms run, 1000 ms for a 0.6 s one), so the module time reported here is taken
from the clock at which saga_cmd's own lines arrive (it flushes every line):
from ``Execution started`` to ``total execution time`` -- the tool alone,
without saga_cmd's start-up (about 1 s of library loading), the grid loading
and the saving, and with progress output off (``-f=q``).  SAGA's own figure and
the wall time of the whole saga_cmd call are kept beside it.  If the lines are
missing, the module time falls back to SAGA's figure, then to the wall time
(``timing`` says which).
"""
from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

SAGA_NODATA = -99999.0
SHADOW_MODES = {"slim": 0, "fat": 1}
_START = re.compile(r"Execution started")
_TOTAL = re.compile(r"total execution time:\s*(\d+)\s*milliseconds")
_VERSION = re.compile(r"SAGA Version:\s*(\S+)")
_PROCESSORS = re.compile(r"processors\s*:\s*(.+)")


def saga_cmd() -> str | None:
    """Path of ``saga_cmd``, or None when SAGA is not installed."""
    return shutil.which("saga_cmd")


def saga_version() -> str | None:
    exe = saga_cmd()
    if exe is None:
        return None
    try:
        out = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    m = _VERSION.search(out)
    return m.group(1) if m else (out.strip().splitlines() or [None])[-1]


# ----------------------------------------------------------------------------- grid files
def write_sgrd(path: Path, heights: np.ndarray, cellsize: float, nodata: float = SAGA_NODATA) -> Path:
    """Write a SAGA grid (``.sgrd`` header + ``.sdat`` float32); rows of ``heights``
    go north to south (row 0 = north), NaN = no-data. Returns the ``.sgrd`` path."""
    path = Path(path).with_suffix(".sgrd")
    h = np.asarray(heights, dtype=np.float32)
    if h.ndim != 2:
        raise ValueError(f"heights must be 2-D, got shape {h.shape}")
    rows, cols = h.shape
    data = np.where(np.isfinite(h), h, np.float32(nodata)).astype("<f4")
    data.tofile(path.with_suffix(".sdat"))
    c = float(cellsize)
    path.write_text("\n".join([
        f"NAME\t= {path.stem}",
        "DESCRIPTION\t= ",
        "UNIT\t= ",
        "DATAFORMAT\t= FLOAT",
        "DATAFILE_OFFSET\t= 0",
        "BYTEORDER_BIG\t= FALSE",
        "TOPTOBOTTOM\t= TRUE",
        f"POSITION_XMIN\t= {0.5 * c:.10f}",     # centre of the lower-left cell
        f"POSITION_YMIN\t= {0.5 * c:.10f}",
        f"CELLCOUNT_X\t= {cols}",
        f"CELLCOUNT_Y\t= {rows}",
        f"CELLSIZE\t= {c:.10f}",
        "Z_FACTOR\t= 1.000000",
        "Z_OFFSET\t= 0.000000",
        f"NODATA_VALUE\t= {nodata:.6f}",
    ]) + "\n")
    return path


def read_sgrd(path: Path) -> tuple[np.ndarray, dict]:
    """A SAGA grid as float64 rows north to south (no-data -> NaN) and its header."""
    path = Path(path).with_suffix(".sgrd")
    hdr: dict[str, str] = {}
    for line in path.read_text().splitlines():
        if "=" in line:
            k, v = line.split("=", 1)
            hdr[k.strip().upper()] = v.strip()
    fmt = hdr.get("DATAFORMAT", "FLOAT").upper()
    dtypes = {"FLOAT": "f4", "DOUBLE": "f8", "BYTE_UNSIGNED": "u1", "BYTE": "i1", "SHORTINT": "i2",
              "SHORTINT_UNSIGNED": "u2", "INTEGER": "i4", "INTEGER_UNSIGNED": "u4"}
    if fmt not in dtypes:
        raise ValueError(f"{path}: unsupported DATAFORMAT {fmt}")
    dt = np.dtype((">" if hdr.get("BYTEORDER_BIG", "FALSE").upper() == "TRUE" else "<") + dtypes[fmt])
    cols, rows = int(hdr["CELLCOUNT_X"]), int(hdr["CELLCOUNT_Y"])
    raw = np.fromfile(path.with_suffix(".sdat"), dtype=dt, count=rows * cols,
                      offset=int(hdr.get("DATAFILE_OFFSET", "0")))
    a = raw.reshape(rows, cols).astype(np.float64)
    a = a * float(hdr.get("Z_FACTOR", "1")) + float(hdr.get("Z_OFFSET", "0"))
    nd = [float(v) for v in hdr.get("NODATA_VALUE", str(SAGA_NODATA)).split(";") if v.strip()]
    lo, hi = (min(nd), max(nd)) if nd else (np.nan, np.nan)
    raw64 = raw.reshape(rows, cols).astype(np.float64)
    a[(raw64 >= lo) & (raw64 <= hi)] = np.nan
    if hdr.get("TOPTOBOTTOM", "FALSE").upper() != "TRUE":
        a = a[::-1]                            # SAGA's default: bottom (south) row first
    return np.ascontiguousarray(a), hdr


# ----------------------------------------------------------------------------- running
@dataclass
class SagaRun:
    module_seconds: float         # the tool alone (see the module docstring for how)
    mask: np.ndarray              # uint8, 1 = shadow, 0 = not, rows north to south
    wall_seconds: float           # the whole saga_cmd call (start-up, load, tool, save)
    reported_ms: int | None       # SAGA's own 'total execution time' (one-second resolution)
    timing: str                   # 'stdout lines', 'saga reported' or 'wall'
    processors: str | None = None
    log: list[str] = field(default_factory=list, repr=False)


class SagaPeer:
    """One heightmap written once as a SAGA grid; :meth:`run` casts one sun.

    Use as a context manager (or call :meth:`close`) to remove the work folder.
    """

    def __init__(self, heights: np.ndarray, cellsize: float | tuple[float, float], *,
                 shadow: str = "slim", cores: int | None = None, workdir: Path | None = None):
        exe = saga_cmd()
        if exe is None:
            raise FileNotFoundError("saga_cmd not found (apt-get install saga)")
        self.exe = exe
        if isinstance(cellsize, (tuple, list)):
            dx, dy = (float(v) for v in cellsize)
            if abs(dx - dy) > 1e-9 * max(abs(dx), abs(dy)):
                raise ValueError(f"SAGA grids have square cells; got {dx:g} x {dy:g} m")
            cellsize = dx
        if shadow not in SHADOW_MODES:
            raise ValueError(f"shadow must be one of {', '.join(SHADOW_MODES)}")
        self.cellsize = float(cellsize)
        self.shadow = shadow
        self.cores = cores
        self.heights = np.asarray(heights, dtype=np.float32)
        self.valid = np.isfinite(self.heights)
        self._tmp = None if workdir is not None else tempfile.TemporaryDirectory(prefix="saga_peer_")
        self.dir = Path(workdir) if workdir is not None else Path(self._tmp.name)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.dem = write_sgrd(self.dir / "dem.sgrd", self.heights, self.cellsize)

    def __enter__(self) -> "SagaPeer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None

    def command(self, azimuth: float, elevation: float, out: Path) -> list[str]:
        cmd = [self.exe, "-f=q"]
        if self.cores:
            cmd.append(f"-c={int(self.cores)}")
        return cmd + ["ta_lighting", "0", f"-ELEVATION={self.dem}", f"-SHADE={out}",
                      "-METHOD=3", "-POSITION=0", f"-AZIMUTH={azimuth % 360.0:.10g}",
                      f"-DECLINATION={elevation:.10g}", f"-SHADOW={SHADOW_MODES[self.shadow]}"]

    def run(self, sun) -> SagaRun:
        """Cast one sun ((azimuth, elevation) degrees, or an object with those attributes)."""
        az, el = (float(sun.azimuth), float(sun.elevation)) if hasattr(sun, "azimuth") else map(float, sun)
        if not 0.0 <= el <= 90.0:
            raise ValueError(f"SAGA takes sun heights in [0, 90] degrees, got {el:g}")
        out = self.dir / "shade.sdat"
        for suffix in (".sdat", ".sgrd", ".mgrd", ".prj"):
            out.with_suffix(suffix).unlink(missing_ok=True)
        cmd = self.command(az, el, out)
        lines: list[str] = []
        t_start = t_total = None
        reported = None
        processors = None
        t0 = time.perf_counter()
        with subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                              bufsize=1, cwd=self.dir) as p:
            assert p.stdout is not None
            for line in p.stdout:
                now = time.perf_counter()
                lines.append(line.rstrip("\n"))
                if t_start is None and _START.search(line):
                    t_start = now
                elif t_total is None and (m := _TOTAL.search(line)):
                    t_total, reported = now, int(m.group(1))
                elif processors is None and (m := _PROCESSORS.search(line)):
                    processors = m.group(1).strip()
            rc = p.wait()
        wall = time.perf_counter() - t0
        if rc != 0 or not out.with_suffix(".sgrd").is_file():
            tail = "\n".join(lines[-20:])
            raise RuntimeError(f"saga_cmd failed (exit {rc}): {' '.join(cmd)}\n{tail}")
        if t_start is not None and t_total is not None:
            module, timing = t_total - t_start, "stdout lines"
        elif reported is not None:
            module, timing = reported / 1e3, "saga reported"
        else:
            module, timing = wall, "wall"
        shade, hdr = read_sgrd(out)
        if shade.shape != self.heights.shape:
            raise RuntimeError(f"SAGA wrote a {shade.shape} grid for a {self.heights.shape} input")
        mask = np.isfinite(shade).astype(np.uint8)   # Shadows Only: shadow = pi/2, the rest no-data
        return SagaRun(module, mask, wall, reported, timing, processors, lines)


def saga_shadows(heights: np.ndarray, cellsize: float | tuple[float, float], sun,
                 **kw) -> tuple[float, np.ndarray]:
    """(module_seconds, mask) of SAGA's shadows-only hillshading for one sun (1 = shadow)."""
    with SagaPeer(heights, cellsize, **kw) as peer:
        r = peer.run(sun)
    return r.module_seconds, r.mask


def agreement(saga_mask: np.ndarray, ocl_mask: np.ndarray, valid: np.ndarray) -> dict:
    """How SAGA's mask compares with oclshade's on valid cells (oclshade: 1 shadow, 0 lit, 255 nodata)."""
    valid = valid & (ocl_mask != 255)
    n = int(valid.sum())
    s = (saga_mask == 1) & valid
    o = (ocl_mask == 1) & valid
    same = int((s == o)[valid].sum())
    return {"valid_cells": n, "agree_pct": 100.0 * same / max(1, n),
            "saga_only_shadow": int((s & ~o).sum()), "oclshade_only_shadow": int((o & ~s).sum()),
            "saga_shadow_pct": 100.0 * int(s.sum()) / max(1, n),
            "oclshade_shadow_pct": 100.0 * int(o.sum()) / max(1, n)}


# ----------------------------------------------------------------------------- script
def main(argv: list[str] | None = None) -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from shadow_masks import DEFAULT_DATA, Skip, load_dataset

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dataset", default="canyon", choices=("canyon", "puget"),
                   help="canyon: oclshade.synthetic.canyon_crater, 30 m cells; puget: ../shared/data (default canyon)")
    p.add_argument("--size", type=int, default=1024, help="map side (puget: centre crop) (default 1024)")
    p.add_argument("--sun", default="37,20", help="azimuth,elevation in degrees, gdaldem words (default 37,20)")
    p.add_argument("--shadow", default="slim", choices=tuple(SHADOW_MODES), help="SAGA's SHADOW choice (default slim)")
    p.add_argument("--reps", type=int, default=3, help="SAGA and oclshade runs; the minimum is shown (default 3)")
    p.add_argument("--data", type=Path, default=DEFAULT_DATA)
    args = p.parse_args(argv)
    try:
        az, el = (float(v) for v in args.sun.split(","))
    except ValueError:
        p.error("--sun wants azimuth,elevation")
    if saga_cmd() is None:
        print("SAGA: not installed (saga_cmd not on PATH; apt-get install saga)")
        return 1
    try:
        d = load_dataset(args.dataset, args.size, args.data)
    except Skip as why:
        print(f"{args.dataset}: skipped ({why})")
        return 1
    h = d["heights"]
    print(f"map: {d['source']}, {h.shape[0]}x{h.shape[1]}")
    print(f"sun: azimuth {az:g}, elevation {el:g} (degrees; azimuth clockwise from north)")

    from oclshade.heightmap import Heightmap
    from oclshade.shadows import ShadowCaster
    hm = Heightmap.from_array(h, (d["dx"], d["dy"]))
    ShadowCaster(hm, cache=False).cast((az, el))        # kernel builds
    ocl_ms = []
    for _ in range(args.reps):
        t0 = time.perf_counter()
        res = ShadowCaster(hm, cache=False).cast((az, el), "exact")
        ocl_ms.append(1e3 * (time.perf_counter() - t0))

    with SagaPeer(h, (d["dx"], d["dy"]), shadow=args.shadow) as peer:
        runs = [peer.run((az, el)) for _ in range(args.reps)]
    best = min(runs, key=lambda r: r.module_seconds)
    print(f"SAGA {saga_version()} ta_lighting 0 (METHOD=3 shadows only, SHADOW={args.shadow}), "
          f"processors {best.processors}: module {1e3 * best.module_seconds:.0f} ms "
          f"(min of {len(runs)}; timed from {best.timing}); SAGA's own figure {best.reported_ms} ms "
          f"(1 s resolution); whole saga_cmd call {min(r.wall_seconds for r in runs):.2f} s")
    print(f"oclshade exact (fresh caster, pyramid included, caches off): {min(ocl_ms):.0f} ms "
          f"(min of {len(ocl_ms)}) on {hm.shape[0]}x{hm.shape[1]}")
    a = agreement(best.mask, res.mask, np.isfinite(h))
    print(f"agreement with oclshade exact: {a['agree_pct']:.2f} % of {a['valid_cells']} valid cells; "
          f"shadow {a['saga_shadow_pct']:.2f} % (SAGA) vs {a['oclshade_shadow_pct']:.2f} % (oclshade); "
          f"shadow in SAGA only {a['saga_only_shadow']}, in oclshade only {a['oclshade_only_shadow']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
