"""Probes: does a family's variant build and run on this device?  Asked in a child process.

A compiler can abort the whole process (PoCL 3.0 from PyPI on an AVX-512
Zen 4: ``LLVM ERROR: Do not know how to scalarize...`` or a segfault on
16-wide vectors) or hang (``select`` / ``isnan`` on float16 past two
minutes), so a variant other than the safe one is first built and run on a
tiny case (the family's ``smoke``) in a child process with a time limit.
The child uses the same kernel caches, so the parent's own build of a
variant that passed is a cache hit.  Outcomes are remembered per device and
kernel digest in the user entry (:mod:`oclshade.tuning.store`).

A time-out is a verdict only when the child was busy: a compiler that hangs
spins (LLVM in a loop), while a child starved by a loaded machine (or run at
low priority) merely waits.  A child that used less than a quarter of the time
limit in CPU time is "unchecked": that run falls back, nothing is remembered,
and the next run probes again (a probe starved behind a benchmark once left
a variant marked broken for good).

Environment: ``OCLSHADE_PROBE_TIMEOUT`` (seconds, default 90);
``OCLSHADE_PROBE_FAULT=abort|hang|stall|fail[:knob=value]`` makes the child
misbehave for variants (with that knob value), to test the fallbacks: hang
spins on the CPU like a hung compiler, stall sleeps like a starved child.
The child runs :func:`main` with ``FAMILY VALUES_JSON`` and ``OCLSHADE_DEVICE``
set to the device index.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time

try:
    import resource
except ImportError:          # not on Windows: there every time-out is a verdict
    resource = None

from ..runtime import DEVICE_ENV, Runtime, device_index, get_runtime
from .params import Values, family

TIMEOUT_ENV = "OCLSHADE_PROBE_TIMEOUT"
FAULT_ENV = "OCLSHADE_PROBE_FAULT"
CHILD_ENV = "OCLSHADE_PROBE_CHILD"
DEFAULT_TIMEOUT = 90.0
#: outcome prefix of a probe that timed out without using the CPU (not remembered)
UNCHECKED = "unchecked"
#: the least share of the time limit a timed-out child must have spent on the CPU to count as hung
HUNG_CPU_SHARE = 0.25


def probe_timeout() -> float:
    text = os.environ.get(TIMEOUT_ENV, "")
    try:
        return float(text) if text else DEFAULT_TIMEOUT
    except ValueError:
        raise ValueError(f"{TIMEOUT_ENV} must be a number of seconds, got {text!r}") from None


def run_probe(runtime: Runtime, family_name: str, values: Values) -> str:
    """"ok", "failed: <why>" (crash, hang, error) or "unchecked: <why>" (a time-out of a child
    that hardly ran: not a verdict) for these values in a child process."""
    env = dict(os.environ, **{DEVICE_ENV: str(device_index(runtime.device)), CHILD_ENV: "1"})
    cmd = [sys.executable, "-c", "import sys; from oclshade.tuning.probe import main; sys.exit(main(sys.argv[1:]))",
           family_name, json.dumps(values, sort_keys=True)]
    timeout = probe_timeout()
    t0 = time.perf_counter()
    cpu0 = _children_cpu_seconds()
    try:
        done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:       # run() has killed and reaped the child
        cpu = _children_cpu_seconds() - cpu0
        if resource is not None and cpu < HUNG_CPU_SHARE * timeout:
            return f"{UNCHECKED}: the probe got {cpu:.1f} s of CPU in {timeout:g} s (a busy machine?)"
        return f"failed: no answer within {timeout:g} s (a hung build?)"
    if done.returncode == 0:
        return "ok"
    tail = " | ".join(line.strip() for line in (done.stderr or "").strip().splitlines()[-3:])
    how = f"signal {-done.returncode}" if done.returncode < 0 else f"exit {done.returncode}"
    return f"failed: {how} after {time.perf_counter() - t0:.1f} s: {tail[:400]}"


def _children_cpu_seconds() -> float:
    """User + system CPU seconds of this process's reaped children so far (0 without resource)."""
    if resource is None:
        return 0.0
    use = resource.getrusage(resource.RUSAGE_CHILDREN)
    return use.ru_utime + use.ru_stime


def _fault(values: Values) -> None:
    spec = os.environ.get(FAULT_ENV, "")
    if not spec:
        return
    mode, _, cond = spec.partition(":")
    if cond:
        name, _, value = cond.partition("=")
        if values.get(name) != int(value):
            return
    if mode == "abort":
        os.abort()
    if mode == "hang":
        end = time.monotonic() + 3600
        while time.monotonic() < end:
            pass
    if mode == "stall":
        time.sleep(3600)
    raise RuntimeError(f"{FAULT_ENV}={spec}: simulated failure")


def main(argv: list[str]) -> int:
    fam = family(argv[0])
    values = fam.check(json.loads(argv[1]))
    _fault(values)
    fam.smoke(get_runtime(), values)
    return 0
