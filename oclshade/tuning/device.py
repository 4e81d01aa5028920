"""Who a device is, for the tuning database: what its entries are keyed on.

An OpenCL device name alone does not tell two CPUs apart (PoCL reports
``pthread-AMD EPYC`` for Zen 2, 3 and 4 EPYCs in a VM, and the PyPI PoCL
targets ``znver3`` on both Zen 3 and Zen 4), so a CPU device's key also
holds the host CPU's model, family/model numbers and vector ISA, read from
``/proc/cpuinfo``.  The driver version and the device version string (with
PoCL's LLVM target, ``HSTR: pthread-x86_64-unknown-linux-gnu-znver3``) are
part of the key too: a new driver is a new device as far as tuning goes.
"""
from __future__ import annotations

import functools
import hashlib
import pathlib
import re
from dataclasses import asdict, dataclass

import pyopencl as cl

ISA_FLAGS = ("avx512f", "avx2", "avx", "sse4_2", "neon", "asimd")


@functools.lru_cache(maxsize=1)
def host_cpu() -> str:
    """``"<model name> (family F model M; best ISA)"`` of this machine's CPU, or ``"unknown"``."""
    try:
        text = pathlib.Path("/proc/cpuinfo").read_text(errors="replace")
    except OSError:
        return "unknown"
    first = text.split("\n\n", 1)[0]
    fields = dict(
        (k.strip(), v.strip()) for k, _, v in (line.partition(":") for line in first.splitlines()) if k.strip()
    )
    flags = set(fields.get("flags", fields.get("Features", "")).split())
    isa = next((f for f in ISA_FLAGS if f in flags), "baseline")
    model = re.sub(r"\s+", " ", fields.get("model name", "unknown")).strip()
    return f"{model} (family {fields.get('cpu family', '?')} model {fields.get('model', '?')}; {isa})"


@dataclass(frozen=True)
class DeviceKey:
    platform: str
    device: str
    driver: str
    version: str      # CL_DEVICE_VERSION (PoCL: with the LLVM target)
    host_cpu: str     # CPU devices only ("" otherwise)

    @classmethod
    def of(cls, device: cl.Device) -> "DeviceKey":
        cpu = host_cpu() if device.type & cl.device_type.CPU else ""
        return cls(device.platform.name.strip(), device.name.strip(), device.driver_version.strip(),
                   device.version.strip(), cpu)

    def as_dict(self) -> dict[str, str]:
        return asdict(self)

    @property
    def slug(self) -> str:
        """A file-name-safe id: the device name and a digest of the whole key."""
        digest = hashlib.sha256(repr(sorted(self.as_dict().items())).encode()).hexdigest()[:12]
        name = re.sub(r"[^A-Za-z0-9]+", "-", self.device).strip("-")[:40] or "device"
        return f"{name}-{digest}"

    def describe(self) -> str:
        cpu = f", CPU {self.host_cpu}" if self.host_cpu else ""
        return f"{self.platform} / {self.device} (driver {self.driver}; {self.version}{cpu})"
