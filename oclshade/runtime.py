"""OpenCL runtime: device choice, context and queue, program builds and their cache.

Device choice, in order of precedence: the ``device=`` argument (or the CLI's
``--device``), the ``OCLSHADE_DEVICE`` environment variable, then the first
PoCL CPU device, then the first device of any platform.  A device spec is
either an index into :func:`list_devices` (``"0"``) or a case-insensitive
substring matched against ``"<platform> <device>"`` (``"pocl"``, ``"nvidia"``,
``"cuda:1"`` style specs are not special: ``"nvidia"`` picks the first match).

Programs are built from ``kernels/`` (package data ``oclshade.kernels``),
with ``#include`` resolved by the host so that the cache key covers the full
source text.  The in-process cache is keyed on (sha256 of the expanded
source, build options, device); on disk, PoCL's and pyopencl's binary caches
keep builds across processes, in a folder oclshade owns and versions
(:mod:`oclshade.cachedir`; ``POCL_CACHE_DIR`` is set there unless the user
set it).  A cached program that lacks a kernel it must have (left by a
build that crashed) is detected, the caches are purged and the program
rebuilt from source.

Builds are quiet: the compilers' output (warnings on stderr, pyopencl's
``CompilerWarning``) is captured and shown only with ``OCLSHADE_DEBUG=1``
or in the error of a failed build.  The first build of a program on a
device says so in one line on stderr (:data:`NOTICES` turns that off).
"""
from __future__ import annotations

import atexit
import contextlib
import functools
import hashlib
import importlib.resources
import os
import pathlib
import re
import sys
import threading
import warnings
from dataclasses import dataclass
from typing import Iterator, Mapping

from . import cachedir

# PoCL reads its cache location when the platform loads: point it at ours (versioned, purgeable)
# before pyopencl loads it, unless the user chose one.
os.environ.setdefault("POCL_KERNEL_CACHE", "1")
if "POCL_CACHE_DIR" not in os.environ:
    try:
        os.environ["POCL_CACHE_DIR"] = str(cachedir.kernel_cache("pocl"))
    except OSError:
        pass  # no writable cache anywhere: PoCL's own default

import numpy as np  # noqa: E402
import pyopencl as cl  # noqa: E402

DEVICE_ENV = "OCLSHADE_DEVICE"
DEBUG_ENV = "OCLSHADE_DEBUG"
#: print the one-line notice before a program's first build on a device (the CLI's --quiet clears it)
NOTICES = True
_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$', re.MULTILINE)


class OclshadeError(RuntimeError):
    """Base class of the library's runtime errors."""


class DeviceNotFoundError(OclshadeError):
    pass


class ProgramBuildError(OclshadeError):
    """A kernel failed to compile; carries the compiler log and the options."""

    def __init__(self, kernel_file: str, options: tuple[str, ...], log: str):
        self.kernel_file = kernel_file
        self.options = options
        self.log = log
        super().__init__(
            f"OpenCL build of {kernel_file} failed with options {' '.join(options) or '(none)'}\n"
            f"--- compiler log ---\n{log.strip()}"
        )


class AllocationError(OclshadeError):
    pass


@dataclass(frozen=True)
class DeviceInfo:
    index: int
    platform: str
    name: str
    driver_version: str
    opencl_version: str
    device_type: str
    compute_units: int
    max_alloc_bytes: int
    global_mem_bytes: int

    @property
    def label(self) -> str:
        return f"{self.platform.strip()} / {self.name.strip()}"


def _all_devices() -> list[tuple[cl.Platform, cl.Device]]:
    out = []
    try:
        platforms = cl.get_platforms()
    except cl.Error:
        platforms = []
    for p in platforms:
        try:
            devs = p.get_devices()
        except cl.Error:
            continue
        out.extend((p, d) for d in devs)
    return out


def _type_name(device: cl.Device) -> str:
    t = device.type
    for flag, name in ((cl.device_type.GPU, "GPU"), (cl.device_type.CPU, "CPU"),
                       (cl.device_type.ACCELERATOR, "ACCELERATOR")):
        if t & flag:
            return name
    return "OTHER"


def list_devices() -> list[DeviceInfo]:
    """All OpenCL devices visible to this process, in selection-index order."""
    return [
        DeviceInfo(i, p.name, d.name, d.driver_version, d.version, _type_name(d),
                   d.max_compute_units, d.max_mem_alloc_size, d.global_mem_size)
        for i, (p, d) in enumerate(_all_devices())
    ]


def select_device(spec: str | int | None = None) -> cl.Device:
    """Pick a device by index or name substring (see the module docstring)."""
    devices = _all_devices()
    if not devices:
        raise DeviceNotFoundError(
            "no OpenCL device found: install 'pocl-binary-distribution' (pip) or a GPU driver's ICD")
    if spec is None:
        spec = os.environ.get(DEVICE_ENV) or None
    if spec is None:
        for p, d in devices:
            if "portable computing language" in p.name.lower() or "pocl" in p.name.lower():
                return d
        return devices[0][1]
    text = str(spec).strip()
    if text.isdigit():
        i = int(text)
        if i >= len(devices):
            raise DeviceNotFoundError(
                f"device={spec!r}: index out of range, expected 0..{len(devices) - 1} (see 'oclshade devices')")
        return devices[i][1]
    key = text.lower()
    for p, d in devices:
        if key in f"{p.name} {d.name}".lower():
            return d
    names = "; ".join(f"{i}: {p.name.strip()} / {d.name.strip()}" for i, (p, d) in enumerate(devices))
    raise DeviceNotFoundError(f"device={spec!r}: no platform or device name contains it; available: {names}")


def device_index(device: cl.Device) -> int:
    """The index of a device in :func:`list_devices` (what ``OCLSHADE_DEVICE`` takes)."""
    for i, (_, d) in enumerate(_all_devices()):
        if d.int_ptr == device.int_ptr:
            return i
    raise DeviceNotFoundError(f"device {device.name!r} is not among this process's OpenCL devices")


def debug() -> bool:
    return os.environ.get(DEBUG_ENV, "") not in ("", "0")


@contextlib.contextmanager
def quiet_compiler() -> Iterator[None]:
    """Keep the compiler's output from the user: what it writes to the process's stderr (fd 2:
    PoCL's clang prints "N warnings generated" there) goes to the null device and pyopencl's
    CompilerWarning is ignored; a failed build still carries its log (ProgramBuildError).
    With OCLSHADE_DEBUG=1 both are shown."""
    if debug():
        yield
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cl.CompilerWarning)
        if sys.stderr is not None:
            sys.stderr.flush()
        try:
            saved = os.dup(2)
        except OSError:          # no stderr at all: nothing to keep quiet
            yield
            return
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 2)
        os.close(null)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)


def _built_marker(digest: str, options: tuple[str, ...], device: cl.Device) -> pathlib.Path | None:
    """A file whose presence says this program was built on this device before (for the notice)."""
    try:
        key = hashlib.sha256(f"{digest} {options} {device.platform.name} {device.name} "
                             f"{device.driver_version} {device.version}".encode()).hexdigest()[:24]
        return cachedir.kernel_cache("built") / key
    except OSError:
        return None


_noticed: set[int] = set()


def _kernel_root():
    """From a source checkout, ../kernels (so that a checkout on PYTHONPATH uses its own kernels
    even when another copy is installed in editable mode); else the package data ``oclshade.kernels``."""
    checkout = pathlib.Path(__file__).resolve().parent.parent / "kernels"
    if (checkout / "common.h").is_file():
        return checkout
    return importlib.resources.files("oclshade.kernels")


@functools.lru_cache(maxsize=None)
def kernel_source(filename: str) -> str:
    """The text of a kernel file with its local ``#include "..."`` lines expanded (read once per
    process: every kernel lookup digests it, and reading took 1.4 ms of a cached lookup's 2 ms)."""
    root = _kernel_root()
    seen: set[str] = set()

    def expand(name: str) -> str:
        if name in seen:
            return ""  # include guard: each file once
        seen.add(name)
        text = root.joinpath(name).read_text(encoding="utf-8")
        return _INCLUDE.sub(lambda m: expand(m.group(1)), text)

    return expand(filename)


#: asked of every device that can: a float32 divide and sqrt as IEEE 754 rounds them, as numpy and
#: PoCL's CPU devices do.  OpenCL's default allows 2.5 ulp (divide) and 3 ulp (sqrt), and NVIDIA's
#: driver uses that room: the mean of 3 heights in the MIP pyramid came out 1 ulp from the float64
#: twin's rounding on an H200 without it (docs/gpu.md).  Not part of the printed options or the
#: cache keys (a device property, like the device itself); host/src/core.c does the same.
CORRECT_ROUNDING_OPTION = "-cl-fp32-correctly-rounded-divide-sqrt"


def rounding_options(device: cl.Device) -> tuple[str, ...]:
    """``(CORRECT_ROUNDING_OPTION,)`` where the device supports it, else ``()``."""
    config = int(getattr(device, "single_fp_config", 0) or 0)
    return (CORRECT_ROUNDING_OPTION,) if config & int(cl.device_fp_config.CORRECTLY_ROUNDED_DIVIDE_SQRT) else ()


def define_options(defines: Mapping[str, object]) -> tuple[str, ...]:
    """``-D`` options from a mapping; ``True`` gives a bare define, ``False``/``None`` omits it."""
    opts = []
    for key in sorted(defines):
        value = defines[key]
        if value is None or value is False:
            continue
        opts.append(f"-D{key}" if value is True else f"-D{key}={value}")
    return tuple(opts)


class Runtime:
    """A device with its context and in-order queue, plus the program cache."""

    def __init__(self, device: cl.Device):
        self.device = device
        self.context = cl.Context([device])
        self.queue = cl.CommandQueue(self.context, device)
        self._programs: dict[tuple[str, tuple[str, ...]], cl.Program] = {}
        self._kernels: dict[tuple[int, str], cl.Kernel] = {}
        self._local_sizes: dict[tuple[cl.Kernel, int], int] = {}   # the key keeps its kernel alive
        self._lock = threading.Lock()
        self.build_hits = 0
        self.build_misses = 0

    @property
    def label(self) -> str:
        return f"{self.device.platform.name.strip()} / {self.device.name.strip()}"

    def program(self, filename: str, defines: Mapping[str, object] | None = None,
                rebuild: bool = False) -> cl.Program:
        """Build (or fetch from the cache) ``kernels/<filename>`` with the given defines;
        ``rebuild``: from source, past every cache (after a bad cached binary)."""
        source = kernel_source(filename)
        options = define_options(defines or {}) + ("-cl-std=CL1.2",)
        digest = hashlib.sha256(source.encode()).hexdigest()
        key = (digest, options)
        with self._lock:
            if rebuild:
                self._programs[key] = self._build(filename, source, options, use_cache=False)
                return self._programs[key]
            prog = self._programs.get(key)
            if prog is not None:
                self.build_hits += 1
                return prog
            self.build_misses += 1
            marker = _built_marker(digest, options, self.device)
            if marker is not None and not marker.exists():
                self.first_build_notice()
            prog = self._build(filename, source, options)
            if marker is not None:
                with contextlib.suppress(OSError):
                    marker.parent.mkdir(parents=True, exist_ok=True)
                    marker.touch()
            self._programs[key] = prog
            return prog

    def first_build_notice(self) -> None:
        """Say once per process and device, on stderr, that kernels are being compiled (the
        wait of a first run); quiet with ``NOTICES = False`` and in probe child processes."""
        if NOTICES and self.device.int_ptr not in _noticed and not os.environ.get("OCLSHADE_PROBE_CHILD"):
            _noticed.add(self.device.int_ptr)
            print(f"oclshade: compiling OpenCL kernels for {self.label} (first run on this device; "
                  f"later runs use the cache)", file=sys.stderr)

    def _build(self, filename: str, source: str, options: tuple[str, ...], use_cache: bool = True) -> cl.Program:
        cache = None
        if use_cache:
            with contextlib.suppress(OSError):
                cache = str(cachedir.kernel_cache("pyopencl"))
        with quiet_compiler():
            try:
                return cl.Program(self.context, source).build(
                    options=[*options, *rounding_options(self.device)], cache_dir=cache)
            except cl.RuntimeError as exc:  # compile error: pyopencl raises RuntimeError subclasses
                log = getattr(exc, "build_log", None) or str(exc)
                if isinstance(log, list):
                    log = "\n".join(str(entry[1]) for entry in log)
                failure = ProgramBuildError(filename, options, log)
        raise failure from None

    def kernel(self, filename: str, name: str, defines: Mapping[str, object] | None = None) -> cl.Kernel:
        """A kernel object of a cached program (one kernel object per program and name)."""
        prog = self.program(filename, defines)
        key = (id(prog), name)
        k = self._kernels.get(key)
        if k is None:
            try:
                k = cl.Kernel(prog, name)
            except cl.LogicError as exc:
                if exc.code != cl.status_code.INVALID_KERNEL_NAME:
                    raise
                # a cached binary that lacks the kernel (left by a build that crashed half-way):
                # purge the caches and rebuild this program from source, once
                cachedir.purge_kernel_caches()
                prog = self.program(filename, defines, rebuild=True)
                k = cl.Kernel(prog, name)   # still missing: a real error, raised
                key = (id(prog), name)
            self._kernels[key] = k
        return k

    # --- resources -----------------------------------------------------------------
    def check_alloc(self, nbytes: int, what: str) -> None:
        limit = self.device.max_mem_alloc_size
        if nbytes > limit:
            raise AllocationError(
                f"{what} needs {nbytes / 2**20:.1f} MiB in one buffer but {self.label} allows at most "
                f"{limit / 2**20:.1f} MiB per allocation (CL_DEVICE_MAX_MEM_ALLOC_SIZE); use a smaller map")

    def to_device(self, array: np.ndarray, what: str) -> cl.Buffer:
        array = np.ascontiguousarray(array)
        self.check_alloc(array.nbytes, what)
        mf = cl.mem_flags
        return cl.Buffer(self.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=array)

    def share(self, array: np.ndarray, what: str, in_place: bool) -> cl.Buffer:
        """A read-only buffer of a read-only array: with ``in_place`` (a tuning knob, for devices
        that share the host's memory) the kernels read the array in place (no copy; the buffer
        keeps it alive), else, or for a writable array, a copy (:meth:`to_device`)."""
        if not in_place or array.flags.writeable or not array.flags.c_contiguous:
            return self.to_device(array, what)
        self.check_alloc(array.nbytes, what)
        return cl.Buffer(self.context, cl.mem_flags.READ_ONLY | cl.mem_flags.USE_HOST_PTR, hostbuf=array)

    def empty(self, nbytes: int, what: str) -> cl.Buffer:
        self.check_alloc(nbytes, what)
        return cl.Buffer(self.context, cl.mem_flags.READ_WRITE, size=max(int(nbytes), 1))

    def local_size(self, kernel: cl.Kernel, wanted: int) -> int:
        """Largest power of two <= wanted that the device and this kernel accept (asked of the
        driver once per kernel: loops of launches ask it many times)."""
        size = self._local_sizes.get((kernel, wanted))
        if size is None:
            limit = min(
                kernel.get_work_group_info(cl.kernel_work_group_info.WORK_GROUP_SIZE, self.device),
                self.device.max_work_group_size,
                self.device.max_work_item_sizes[0],
            )
            size = 1
            while size * 2 <= min(wanted, limit):
                size *= 2
            self._local_sizes[(kernel, wanted)] = size
        return size

    def grid_2d(self, kernel: cl.Kernel, cols: int, rows: int, wanted: int = 64,
                max_x: int = 16) -> tuple[tuple[int, int], tuple[int, int]]:
        """(global, local) sizes for one work-item per (col, row): a local size of at most
        ``wanted`` items, ``max_x`` wide, and the global size rounded up to it."""
        ls = self.local_size(kernel, wanted)
        lx = min(ls, max_x)
        ly = max(1, ls // lx)
        return (-(-cols // lx) * lx, -(-rows // ly) * ly), (lx, ly)

    def count_in_bands(self, kernel: cl.Kernel, args: tuple, n_counters: int, cols: int, rows: int,
                       band_items: int) -> np.ndarray:
        """Run a profiling kernel whose last argument is ``n_counters`` uint32 counters
        (atomically incremented) after ``args``, one work-item per (col, row), in bands of
        rows of at most ``band_items`` items; each band starts from zero and the bands
        are summed here in int64, so the uint32 counters cannot wrap over a large launch."""
        zero = np.zeros(n_counters, np.uint32)
        counters = cl.Buffer(self.context, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR, hostbuf=zero)
        kernel.set_args(*args, counters)
        (gx, gy), (lx, ly) = self.grid_2d(kernel, cols, rows)
        band = max(ly, band_items // gx // ly * ly)
        total = np.zeros(n_counters, np.int64)
        part = np.empty_like(zero)
        for r0 in range(0, gy, band):
            cl.enqueue_copy(self.queue, counters, zero)
            cl.enqueue_nd_range_kernel(self.queue, kernel, (gx, min(band, gy - r0)), (lx, ly),
                                       global_work_offset=(0, r0))
            cl.enqueue_copy(self.queue, part, counters)
            self.queue.finish()
            total += part
        return total


#: pyopencl's own fast path for an argument given as bytes (what its generated invokers call)
_SET_ARG_BUF = getattr(cl.Kernel, "_set_arg_buf", None)


def set_arg(kernel: cl.Kernel, index: int, value: object) -> None:
    """``kernel.set_arg(index, value)``; a contiguous numpy value through pyopencl's
    ``_set_arg_buf`` (0.2 us against 6.6 us for ``set_arg``'s type dispatch, pyopencl 2026.1.4 on
    a model-167 Xeon: a sun field's blocks set three arguments per launch, thousands of
    launches per step), where this pyopencl has it."""
    if _SET_ARG_BUF is not None and isinstance(value, (np.ndarray, np.generic)) and \
            (isinstance(value, np.generic) or value.flags.c_contiguous):
        _SET_ARG_BUF(kernel, index, value)
    else:
        kernel.set_arg(index, value)


class ArgBinder:
    """Sets a kernel's arguments, skipping those equal to the last call's: for launches in a
    loop that change a few (pyopencl's set_args costs about 60 us for 14 arguments).  One
    binder per loop over a kernel object that nothing else sets meanwhile."""

    def __init__(self, kernel: cl.Kernel):
        self.kernel = kernel
        self.last: tuple | None = None

    def __call__(self, *args: object) -> None:
        last = self.last
        if last is None or len(last) != len(args):
            self.kernel.set_args(*args)
        else:
            for index, (new, old) in enumerate(zip(args, last)):
                if not _same_argument(new, old):
                    set_arg(self.kernel, index, new)
        self.last = args


def _same_argument(a: object, b: object) -> bool:
    if a is b:
        return True
    if isinstance(a, (np.ndarray, np.generic)) and isinstance(b, (np.ndarray, np.generic)):
        return a.dtype == b.dtype and np.shape(a) == np.shape(b) and a.tobytes() == b.tobytes()
    return False


_default_lock = threading.Lock()
_runtimes: dict[int, Runtime] = {}


@atexit.register
def _finish_queued_work() -> None:
    """At exit, wait for the kernels still queued (e.g. ``HorizonCaster.angles_on_device``
    returns without waiting): PoCL 3.0 and 3.1 end the process with SIGSEGV when it exits
    while a kernel runs.  Registered after pyopencl's import, so it runs before pyopencl's
    own exit handlers.  A queue in error is left as it is: the call that failed has said so."""
    for rt in list(_runtimes.values()):
        with contextlib.suppress(cl.Error):
            rt.queue.finish()


def get_runtime(device: str | int | Runtime | cl.Device | None = None) -> Runtime:
    """The shared :class:`Runtime` for a device spec (one per device per process)."""
    if isinstance(device, Runtime):
        return device
    dev = device if isinstance(device, cl.Device) else select_device(device)
    key = dev.int_ptr
    with _default_lock:
        rt = _runtimes.get(key)
        if rt is None:
            rt = _runtimes[key] = Runtime(dev)
        return rt
