"""Tuning entries on disk: the user's (written by ``oclshade tune`` and by probes) and the
database shipped with the package (``oclshade/tuning/devices.json``).

A user entry is one JSON file per device under ``<cache>/tuning/<slug>.json``::

    {"device": {platform, device, driver, version, host_cpu},
     "families": {"shadow": {"kernel_digest": "...", "values": {...},
                             "measured": {...}, "date": "..."}},
     "probes": {"<kernel_digest>": {"shadow": {"<values json>": "ok" | "failed: ..."}}}}

The shipped database is a list of such entries (without probes) for the
devices we measured.  Entries may lack knobs added after they were written:
those take the rule's values.  A user entry counts only while its kernel digest is
the current one (the kernels changed: re-tune); a shipped entry counts for
its exact device key whatever the digest (its values stay legal; the
``devices`` command says which kernels it was measured with).
"""
from __future__ import annotations

import datetime
import functools
import hashlib
import importlib.resources
import json
import os
import pathlib
import tempfile
import threading
from typing import Any, Callable

from ..cachedir import tuning_dir
from ..runtime import kernel_source
from .device import DeviceKey
from .params import Family, Values

_lock = threading.Lock()


def kernel_digest(family: Family) -> str:
    """sha256 of the family's kernel sources (includes expanded): a tuning entry's validity."""
    h = hashlib.sha256()
    for name in family.kernel_files:
        h.update(name.encode() + b"\0" + kernel_source(name).encode() + b"\0")
    return h.hexdigest()[:16]


def values_id(values: Values) -> str:
    return json.dumps(values, sort_keys=True, separators=(",", ":"))


def user_path(key: DeviceKey) -> pathlib.Path:
    return tuning_dir() / f"{key.slug}.json"


def read_user(key: DeviceKey) -> dict[str, Any]:
    """The user entry of a device ({} if none, unreadable, or another device's)."""
    try:
        data = json.loads(user_path(key).read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) and data.get("device") == key.as_dict() else {}


def _write_user(key: DeviceKey, data: dict[str, Any]) -> None:
    """Atomic write (a crash mid-write never leaves half a file)."""
    path = user_path(key)
    data["device"] = key.as_dict()
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(data, f, indent=1, sort_keys=True)
        os.replace(tmp, path)
    except BaseException:
        pathlib.Path(tmp).unlink(missing_ok=True)
        raise


def update_user(key: DeviceKey, change: Callable[[dict[str, Any]], None]) -> None:
    """Read-modify-write the user entry under a lock (``change(data)`` edits it in place);
    an unwritable cache only loses the record."""
    with _lock:
        data = read_user(key)
        change(data)
        try:
            _write_user(key, data)
        except OSError:
            pass


def user_values(key: DeviceKey, family: Family) -> Values | None:
    entry = read_user(key).get("families", {}).get(family.name)
    if not entry or entry.get("kernel_digest") != kernel_digest(family):
        return None
    try:
        return family.check(entry["values"], partial=True)
    except (KeyError, ValueError):
        return None


def save_user_values(key: DeviceKey, family: Family, values: Values, measured: dict[str, Any]) -> None:
    entry = {"kernel_digest": kernel_digest(family), "values": family.check(values), "measured": measured,
             "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")}
    update_user(key, lambda data: data.setdefault("families", {}).__setitem__(family.name, entry))


def probe_record(key: DeviceKey, family: Family, values: Values) -> str | None:
    probes = read_user(key).get("probes", {}).get(kernel_digest(family), {})
    return probes.get(family.name, {}).get(values_id(values))


def save_probe(key: DeviceKey, family: Family, values: Values, outcome: str) -> None:
    digest = kernel_digest(family)

    def change(data: dict[str, Any]) -> None:
        probes = data.setdefault("probes", {})
        for stale in [d for d in probes if d != digest and family.name in probes[d]]:
            del probes[stale][family.name]          # records of older kernels of this family
        probes.setdefault(digest, {}).setdefault(family.name, {})[values_id(values)] = outcome

    update_user(key, change)


@functools.lru_cache(maxsize=1)
def shipped_entries() -> tuple[dict[str, Any], ...]:
    text = importlib.resources.files("oclshade.tuning").joinpath("devices.json").read_text()
    return tuple(json.loads(text)["entries"])


def shipped_entry(key: DeviceKey) -> dict[str, Any] | None:
    want = key.as_dict()
    return next((e for e in shipped_entries() if e.get("device") == want), None)


def shipped_values(key: DeviceKey, family: Family) -> tuple[Values, str] | None:
    """(values, kernel digest they were measured with) of the shipped entry, if any."""
    entry = shipped_entry(key)
    fam = (entry or {}).get("families", {}).get(family.name)
    if not fam:
        return None
    try:
        return family.check(fam["values"], partial=True), str(fam.get("kernel_digest", "?"))
    except (KeyError, ValueError):
        return None
