"""Facts about the machine and its OpenCL devices, recorded with every benchmark run."""
from __future__ import annotations

import datetime as _dt
import os
import platform

import numpy as np
import pyopencl as cl

from .._version import __version__
from ..runtime import DeviceInfo, Runtime
from ..tuning.device import host_cpu


def cpu_model() -> str:
    """The host CPU as the tuning database names it, "<model name> (family F model M; best ISA)"
    (cloud CPUs share one model name; oclshade.tuning.device.host_cpu), else what the platform
    module knows."""
    cpu = host_cpu()
    return cpu if cpu != "unknown" else (platform.processor() or platform.machine())


def machine_facts() -> dict[str, object]:
    """CPU, OS, versions of Python and the libraries, and the date (UTC)."""
    return {
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "cpu": cpu_model(),
        "cores": os.cpu_count(),
        "os": platform.platform(),
        "python": platform.python_version(),
        "pyopencl": cl.VERSION_TEXT,
        "numpy": np.__version__,
        "oclshade": __version__,
    }


def device_key(info: DeviceInfo, infos: list[DeviceInfo]) -> str:
    """The name a device goes by in reports and in ``--compare``: "platform / device", with
    " #index" appended when another device of this run has the same name."""
    twins = [d for d in infos if d.label == info.label]
    return info.label if len(twins) == 1 else f"{info.label} #{info.index}"


def device_facts(rt: Runtime, info: DeviceInfo, key: str) -> dict[str, object]:
    """Platform, device and driver strings of one device (PoCL's device version names its
    LLVM target, e.g. 'HSTR: pthread-x86_64-unknown-linux-gnu-znver3')."""
    dev = rt.device
    return {
        "key": key,
        "index": info.index,
        "platform": dev.platform.name.strip(),
        "platform_version": dev.platform.version.strip(),
        "name": dev.name.strip(),
        "version": dev.version.strip(),
        "driver_version": dev.driver_version.strip(),
        "type": info.device_type,
        "compute_units": dev.max_compute_units,
        "max_clock_mhz": dev.max_clock_frequency,
        "global_mem_bytes": dev.global_mem_size,
        "max_alloc_bytes": dev.max_mem_alloc_size,
    }
