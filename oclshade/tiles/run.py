"""Running tiles: each job's window traced by a :class:`~oclshade.shadows.ShadowCaster`, in a pipeline.

Same answers as the whole map, bit for bit.  The kernel decides a cell from
float32 patch tests on the relative heights, the sun's float32 ray constants
and the cell coordinates: a window gets the whole map's relative heights bit
for bit (:class:`TileHeightmap`: the same float64 heights minus the same base,
:attr:`ReliefGrid.base`), the same constants (``Sun.ray`` of the same cell
sizes) and its origin in the map (``ShadowCaster(origin=...)``), so the kernel
forms the whole map's coordinates (x0 + ux t with x0 the map's column) and
every float32 value of a cell's patch tests is the whole map's; the halo holds
every patch that can rise above a ray of the tile (:mod:`oclshade.tiles.halo`).
docs/scale.md ("Exactness") says how that was checked.

The pipeline (:func:`run_jobs`): a reader thread reads and converts the next
window while the caller's thread traces the current one (upload, pyramid,
kernels, download) and a writer thread writes the previous results, each
handing over through a queue of one; ``overlap=False`` runs the same steps one
after another (the serial order, for comparisons).  Memory holds at most one
window being read, one traced and one tile's results being written.
"""
from __future__ import annotations

import queue
import threading
from dataclasses import dataclass
from typing import Callable, Iterator, Mapping, Sequence

import numpy as np

from ..heightmap import Heightmap
from ..runtime import Runtime
from ..shadows import DEFAULT_K_BRIGHT, DEFAULT_K_DARK, ShadowCaster, ShadowResult, check_coefficients, \
    check_method, check_outputs
from ..sun import SunBlock, SunField, SunLike, Traced, as_traced
from .halo import Window
from .plan import ALIGN, TileJob, plan_tiles
from .relief import DEFAULT_BLOCK, ReliefGrid

#: one lock per process around the device work of a tile: callers on several threads (Dask
#: workers with more than one thread) share the process's runtime, whose kernels are not re-entrant
DEVICE_LOCK = threading.Lock()


@dataclass(frozen=True)
class TileHeightmap(Heightmap):
    """A window of a map's heights whose float32 relative heights use the whole map's ``base``
    (so they are the whole map's, bit for bit), not the window's own midpoint."""

    base: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "offset", self.base)
        rel = np.empty(self.heights.shape, np.float32)
        np.subtract(self.heights, self.base, out=rel, casting="same_kind")   # float64, rounded once
        rel.setflags(write=False)
        object.__setattr__(self, "relative32", rel)


@dataclass(frozen=True)
class Tracing:
    """What every tile of a run traces: the suns (all of the run's), method, outputs, eq. (1)
    constants, the map's cell sizes and base, the device, and the shadow family's tuning knobs
    (``ShadowCaster(knobs=...)``; None: the device's tuning entry; results never depend on them)."""

    suns: tuple[Traced, ...]     # suns, or sun fields of the whole map
    method: str = "exact"
    outputs: tuple[str, ...] = ("mask",)
    k_dark: float = DEFAULT_K_DARK
    k_bright: float = DEFAULT_K_BRIGHT
    dx: float = 1.0
    dy: float = 1.0
    base: float = 0.0
    device: str | int | Runtime | None = None
    knobs: Mapping[str, int] | None = None

    def __post_init__(self) -> None:
        check_method(self.method)
        object.__setattr__(self, "outputs", check_outputs(self.outputs))
        check_coefficients(self.k_dark, self.k_bright)

    def trace(self, job: TileJob, heights: TileHeightmap) -> list[ShadowResult]:
        """The job's suns over its window, cropped to its tile (in ``job.suns`` order)."""
        inner = job.tile.inside(job.window)
        with DEVICE_LOCK:
            caster = ShadowCaster(heights, self.device, cache=False, knobs=self.knobs,
                                  origin=(job.window.r0, job.window.c0))
            results = []
            for res in caster.iter_many([_in_window(self.suns[k], job.window) for k in job.suns], self.method,
                                        self.outputs, self.k_dark, self.k_bright):
                results.append(ShadowResult(res.sun, *(None if a is None else np.ascontiguousarray(a[inner])
                                                       for a in (res.mask, res.self_shadow, res.coefficient))))
        return results

    def heightmap(self, heights: np.ndarray) -> TileHeightmap:
        """A window's float64 heights (NaN = nodata) as the kernels will read them."""
        return TileHeightmap(heights, self.dx, self.dy, self.base)


def _in_window(sun: Traced, window: Window) -> Traced:
    """A sun, or the part of a whole-map sun field over the window, in the window's cells."""
    if not isinstance(sun, SunField):
        return sun
    blocks = tuple(SunBlock(max(b.row0, window.r0) - window.r0, min(b.row1, window.r1) - window.r0,
                            max(b.col0, window.c0) - window.c0, min(b.col1, window.c1) - window.c0, b.sun)
                   for b in sun.blocks
                   if b.row0 < window.r1 and b.row1 > window.r0 and b.col0 < window.c1 and b.col1 > window.c0)
    return SunField(window.shape, blocks, sun.centre, sun.deviation, sun.tolerance)


Reader = Callable[[Window], np.ndarray]
Writer = Callable[[TileJob, list[ShadowResult]], None]


def run_jobs(jobs: Sequence[TileJob], read: Reader, write: Writer, tracing: Tracing, *, overlap: bool = True,
             progress: Callable[[int, int], None] | None = None) -> None:
    """Read, trace and write every job (see the module docstring); ``read`` gives a window's
    float64 heights, ``write`` takes a job's cropped results.  An exception in any stage stops
    the others and is raised here."""
    if not overlap:
        for k, job in enumerate(jobs):
            write(job, tracing.trace(job, tracing.heightmap(read(job.window))))
            if progress is not None:
                progress(k + 1, len(jobs))
        return
    stop = threading.Event()
    read_q: queue.Queue = queue.Queue(maxsize=1)
    write_q: queue.Queue = queue.Queue(maxsize=1)
    errors: list[BaseException] = []

    def put(q: queue.Queue, item: object) -> bool:
        while not stop.is_set():
            try:
                q.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def items(q: queue.Queue) -> Iterator:
        while True:
            try:
                item = q.get(timeout=0.1)
            except queue.Empty:
                if stop.is_set():
                    return
                continue
            if item is None:
                return
            yield item

    # one window read ahead at most: the reader takes the slot before a read and the tracer frees
    # it when it takes that window (a queue of one alone let a third window be read meanwhile)
    slot = threading.Semaphore(1)

    def reader() -> None:
        try:
            for job in jobs:
                while not slot.acquire(timeout=0.1):
                    if stop.is_set():
                        return
                if not put(read_q, (job, tracing.heightmap(read(job.window)))):
                    return
            put(read_q, None)
        except BaseException as exc:   # noqa: BLE001 - handed to the caller's thread
            errors.append(exc)
            stop.set()

    def writer() -> None:
        try:
            for job, results in items(write_q):
                write(job, results)
        except BaseException as exc:   # noqa: BLE001
            errors.append(exc)
            stop.set()

    threads = [threading.Thread(target=reader, name="oclshade-tile-reader", daemon=True),
               threading.Thread(target=writer, name="oclshade-tile-writer", daemon=True)]
    for t in threads:
        t.start()
    try:
        done = 0
        for job, heights in items(read_q):
            slot.release()
            results = tracing.trace(job, heights)
            del heights
            if not put(write_q, (job, results)):
                break
            done += 1
            if progress is not None:
                progress(done, len(jobs))
        if put(write_q, None):
            threads[1].join()              # the writer drains its queue
    except BaseException as exc:           # noqa: BLE001 - re-raised below, after the threads end
        errors.append(exc)
    finally:
        stop.set()
        for t in threads:
            t.join()
    if errors:
        raise errors[0]


def cast_tiled(heightmap: Heightmap, suns: SunLike | SunField | Sequence[SunLike | SunField], method: str = "exact",
               outputs: str | Sequence[str] = ("mask",), k_dark: float = DEFAULT_K_DARK,
               k_bright: float = DEFAULT_K_BRIGHT, *, tile_size: int = 1024,
               max_window_cells: int | None = None, align: int = ALIGN, block: int = DEFAULT_BLOCK,
               device: str | int | Runtime | None = None, overlap: bool = True,
               knobs: Mapping[str, int] | None = None) -> list[ShadowResult]:
    """:meth:`ShadowCaster.cast_many` of a heightmap in memory, tile by tile (each tile's window
    on the device, never the whole map): the same results (see the module docstring).
    ``tile_size``, ``max_window_cells``, ``align``: as :func:`~oclshade.tiles.plan_tiles`;
    ``block``: the relief grid's block size (smaller: tighter halos, more work planning);
    ``knobs``: as :class:`Tracing`."""
    sun_list = as_traced(suns)
    rows, cols = heightmap.shape
    relief = ReliefGrid.of(heightmap.heights, block)
    tracing = Tracing(tuple(sun_list), method, check_outputs(outputs), k_dark, k_bright, heightmap.dx,
                      heightmap.dy, heightmap.offset, device, knobs)
    plan = plan_tiles(relief, sun_list, heightmap.dx, heightmap.dy, tile_size, max_window_cells, align)
    out = [ShadowResult(sun.centre if isinstance(sun, SunField) else sun,
                        np.empty((rows, cols), np.uint8) if "mask" in tracing.outputs else None,
                        np.empty((rows, cols), np.uint8) if "self" in tracing.outputs else None,
                        np.empty((rows, cols), np.float32) if "coefficient" in tracing.outputs else None)
           for sun in sun_list]

    def read(window: Window) -> np.ndarray:
        return heightmap.heights[window.r0:window.r1, window.c0:window.c1]

    def write(job: TileJob, results: list[ShadowResult]) -> None:
        where = (slice(job.tile.r0, job.tile.r1), slice(job.tile.c0, job.tile.c1))
        for k, res in zip(job.suns, results):
            for name in ("mask", "self_shadow", "coefficient"):
                if getattr(res, name) is not None:
                    getattr(out[k], name)[where] = getattr(res, name)

    run_jobs(plan.jobs, read, write, tracing, overlap=overlap)
    return out

