"""The user cache directory oclshade owns: tuning entries, probe records and the kernel
compilers' binary caches (PoCL's and pyopencl's).

``$OCLSHADE_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/oclshade``, else
``~/.cache/oclshade``; when that cannot be created or written (a read-only or
missing HOME), a per-user folder under the system temporary directory.  The
compiler caches live under ``kernels-<oclshade version>/`` so that an upgrade
never loads binaries built from older kernels, and so that deleting one
folder (:func:`purge_kernel_caches`) recovers from a broken entry without
touching the tuning entries.
"""
from __future__ import annotations

import functools
import os
import pathlib
import shutil
import tempfile

from ._version import __version__ as VERSION

CACHE_ENV = "OCLSHADE_CACHE_DIR"


def _writable(path: pathlib.Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
        return True
    except OSError:
        return False


@functools.lru_cache(maxsize=None)
def cache_root() -> pathlib.Path:
    """The root of oclshade's cache (created on first use)."""
    explicit = os.environ.get(CACHE_ENV)
    if explicit:
        candidates = [pathlib.Path(explicit)]
    else:
        xdg = os.environ.get("XDG_CACHE_HOME")
        base = pathlib.Path(xdg) if xdg else pathlib.Path.home() / ".cache"
        candidates = [base / "oclshade"]
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    candidates.append(pathlib.Path(tempfile.gettempdir()) / f"oclshade-cache-{uid}")
    for path in candidates:
        if _writable(path):
            return path
    raise OSError(f"no writable cache directory: tried {', '.join(map(str, candidates))} "
                  f"(set {CACHE_ENV} to a writable folder)")


def kernel_cache(compiler: str) -> pathlib.Path:
    """The binary cache folder of one kernel compiler (``"pocl"`` or ``"pyopencl"``)."""
    path = cache_root() / f"kernels-{VERSION}" / compiler
    path.mkdir(parents=True, exist_ok=True)
    return path


def tuning_dir() -> pathlib.Path:
    path = cache_root() / "tuning"
    path.mkdir(parents=True, exist_ok=True)
    return path


def purge_kernel_caches() -> None:
    """Delete every compiled kernel binary of this version (PoCL's and pyopencl's); the next
    build compiles afresh.  Used to recover from an entry a crashed build left behind."""
    root = cache_root() / f"kernels-{VERSION}"
    for folder in root.glob("*"):     # the folders stay: PoCL keeps using the one it was given
        for entry in folder.iterdir() if folder.is_dir() else ():
            if entry.is_dir():
                shutil.rmtree(entry, ignore_errors=True)
            else:
                entry.unlink(missing_ok=True)
