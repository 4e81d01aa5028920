"""Probes: does a family's variant build and run on this device?  Asked in a child process.

A compiler can abort the whole process (PoCL 3.0 from PyPI on an AVX-512
Zen 4: ``LLVM ERROR: Do not know how to scalarize...`` or a segfault on
16-wide vectors) or hang (``select`` / ``isnan`` on float16 past two
minutes), so a variant other than the safe one is first built and run on a
tiny case (the family's ``smoke``) in a child process with a time limit.
The child uses the same kernel caches, so the parent's own build of a
variant that passed is a cache hit.  Outcomes are remembered per device and
kernel digest in the user entry (:mod:`oclshade.tuning.store`).

Environment: ``OCLSHADE_PROBE_TIMEOUT`` (seconds, default 90);
``OCLSHADE_PROBE_FAULT=abort|hang|fail[:knob=value]`` makes the child
misbehave for variants (with that knob value), to test the fallbacks.
The child runs :func:`main` with ``FAMILY VALUES_JSON`` and ``OCLSHADE_DEVICE``
set to the device index.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time

from ..runtime import DEVICE_ENV, Runtime, device_index, get_runtime
from .params import Values, family

TIMEOUT_ENV = "OCLSHADE_PROBE_TIMEOUT"
FAULT_ENV = "OCLSHADE_PROBE_FAULT"
CHILD_ENV = "OCLSHADE_PROBE_CHILD"
DEFAULT_TIMEOUT = 90.0


def probe_timeout() -> float:
    text = os.environ.get(TIMEOUT_ENV, "")
    try:
        return float(text) if text else DEFAULT_TIMEOUT
    except ValueError:
        raise ValueError(f"{TIMEOUT_ENV} must be a number of seconds, got {text!r}") from None


def run_probe(runtime: Runtime, family_name: str, values: Values) -> str:
    """"ok", or "failed: <why>" (crash, time-out, error) for these values in a child process."""
    env = dict(os.environ, **{DEVICE_ENV: str(device_index(runtime.device)), CHILD_ENV: "1"})
    cmd = [sys.executable, "-c", "import sys; from oclshade.tuning.probe import main; sys.exit(main(sys.argv[1:]))",
           family_name, json.dumps(values, sort_keys=True)]
    timeout = probe_timeout()
    t0 = time.perf_counter()
    try:
        done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return f"failed: no answer within {timeout:g} s (a hung build?)"
    if done.returncode == 0:
        return "ok"
    tail = " | ".join(line.strip() for line in (done.stderr or "").strip().splitlines()[-3:])
    how = f"signal {-done.returncode}" if done.returncode < 0 else f"exit {done.returncode}"
    return f"failed: {how} after {time.perf_counter() - t0:.1f} s: {tail[:400]}"


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
        time.sleep(3600)
    raise RuntimeError(f"{FAULT_ENV}={spec}: simulated failure")


def main(argv: list[str]) -> int:
    fam = family(argv[0])
    values = fam.check(json.loads(argv[1]))
    _fault(values)
    fam.smoke(get_runtime(), values)
    return 0
