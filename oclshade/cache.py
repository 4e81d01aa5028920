"""Process-wide result caches (paper 003: keep what is still valid while its inputs are unchanged).

Three bounded LRU caches, each with hit / miss / eviction counters:

* ``PYRAMIDS``: device-resident extrema pyramids, keyed on (heights digest,
  device).  Every :class:`~oclshade.shadows.ShadowCaster` over the same
  heights on the same device shares one, whoever built it, so a second caster
  or a second :func:`~oclshade.shadows.cast_shadows` call does not rebuild.
* ``ANALYSES``: per-map data of the scene analysis (:mod:`oclshade.analysis`).
* ``RESULTS``: shadow outputs keyed on everything they depend on: heights
  digest, cell sizes, sun, method, outputs, k_dark, k_bright, device.  The
  stored arrays are read-only and callers always get copies, so no caller can
  corrupt the cache.

The heights digest is BLAKE2b-256 (twice sha256's speed here) over the shape and the float32 relative heights
(what kernels read) and is taken once per :class:`~oclshade.heightmap.Heightmap`
object (its arrays are read-only): changing heights means a new Heightmap,
hence a new digest, hence a miss; nothing else needs invalidating.

Switches: :func:`set_enabled` (process-wide; the environment variable
``OCLSHADE_CACHE=0`` turns caching off at import), ``ShadowCaster(cache=False)``
per caster, :func:`clear` to drop everything.  Bounds (bytes, host or device
memory the entries hold) are attributes of each cache (``max_bytes``).
"""
from __future__ import annotations

import hashlib
import os
import threading
import weakref
from collections import OrderedDict
from typing import Any, Hashable

from .heightmap import Heightmap


class LRUCache:
    """A byte-bounded least-recently-used mapping with counters."""

    def __init__(self, name: str, max_bytes: int):
        self.name = name
        self.max_bytes = int(max_bytes)
        self._items: OrderedDict[Hashable, tuple[Any, int]] = OrderedDict()
        self._lock = threading.Lock()
        self.nbytes = 0
        self.hits = self.misses = self.evictions = 0

    def __len__(self) -> int:
        return len(self._items)

    def get(self, key: Hashable) -> Any | None:
        with self._lock:
            entry = self._items.get(key)
            if entry is None:
                self.misses += 1
                return None
            self._items.move_to_end(key)
            self.hits += 1
            return entry[0]

    def put(self, key: Hashable, value: Any, nbytes: int) -> None:
        """Store an entry (one larger than max_bytes is not stored), evicting the oldest."""
        with self._lock:
            old = self._items.pop(key, None)
            if old is not None:
                self.nbytes -= old[1]
            if nbytes > self.max_bytes:
                return
            self._items[key] = (value, int(nbytes))
            self.nbytes += int(nbytes)
            while self.nbytes > self.max_bytes:
                _, (_, n) = self._items.popitem(last=False)
                self.nbytes -= n
                self.evictions += 1

    def clear(self) -> None:
        """Drop every entry and zero the counters."""
        with self._lock:
            self._items.clear()
            self.nbytes = 0
            self.hits = self.misses = self.evictions = 0

    def stats(self) -> dict[str, int]:
        return {"entries": len(self._items), "bytes": self.nbytes, "max_bytes": self.max_bytes,
                "hits": self.hits, "misses": self.misses, "evictions": self.evictions}


PYRAMIDS = LRUCache("extrema pyramids", 1 << 30)
ANALYSES = LRUCache("scene analyses", 64 << 20)
RESULTS = LRUCache("shadow results", 512 << 20)
_CACHES = (PYRAMIDS, ANALYSES, RESULTS)
_enabled = os.environ.get("OCLSHADE_CACHE", "1").strip().lower() not in ("0", "off", "false", "no")
_digests: dict[int, tuple[weakref.ref, str]] = {}
_digest_lock = threading.Lock()


def enabled() -> bool:
    """Whether the process-wide caches are in use."""
    return _enabled


def set_enabled(flag: bool) -> None:
    """Turn the process-wide caches on or off (off also clears them)."""
    global _enabled
    _enabled = bool(flag)
    if not _enabled:
        clear()


def clear() -> None:
    """Drop every entry of every cache and zero the counters."""
    for c in _CACHES:
        c.clear()


def stats() -> dict[str, dict[str, int]]:
    """Counters and sizes of every cache, by cache name."""
    return {c.name: c.stats() for c in _CACHES}


def heights_digest(hm: Heightmap) -> str:
    """BLAKE2b-256 of a heightmap's shape and float32 relative heights, once per Heightmap object."""
    key = id(hm)
    with _digest_lock:
        entry = _digests.get(key)
        if entry is not None and entry[0]() is hm:
            return entry[1]
    h = hm.relative32
    hasher = hashlib.blake2b(f"{h.shape}{h.dtype.str}".encode(), digest_size=32)
    hasher.update(memoryview(h).cast("B"))
    digest = hasher.hexdigest()
    with _digest_lock:
        _digests[key] = (weakref.ref(hm, lambda _ref, k=key: _digests.pop(k, None)), digest)
    return digest
