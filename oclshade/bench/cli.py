"""``oclshade bench``: the argument parser and the command.

Exit status: 0 all well; 1 a case failed on a device, the roofline probes
failed, or an exact case's outputs differ between devices (the results are
written all the same); 2 bad arguments; 3 ``--compare`` found a regression
(this takes precedence over 1).
"""
from __future__ import annotations

import argparse
import math
import shlex
import sys
from pathlib import Path

from ..runtime import DeviceInfo, device_index, list_devices, select_device
from .compare import comparison, format_comparison, load_report
from .portability import failures, mismatches
from .report import summary, write_json, write_markdown, write_plots
from .runner import run_benchmark
from .suite import SIZES

EXIT_REGRESSION = 3
DEFAULT_THRESHOLD_PCT = 10.0

EPILOG = """\
what it measures, per device (every OpenCL device, or those given with --device):
  roofline probes: float4 copy bandwidth (GB/s) and multiply-add rate (GFLOP/s);
  every kernel family through the Python API: extrema pyramid, heightmap shadow
  masks (each method), terrain render (each method), per-pixel shadows, SSAO
  (default and paper recipe), compose; min and median wall time after a warm-up
  (builds excluded), throughput, share of the roofline, sha256 of the outputs;
  then whether outputs agree across devices (pyramid and exact masks must) and
  Pennycook's performance portability per kernel family.

sizes: full (default; 4096^2 masks, 1920x1080 frames: many minutes per device),
  quick (--quick: 1024^2, 960x540, about a minute on a 2-core machine with two
  PoCL devices, first-time compiles included), tiny (a smoke test).

outputs: the summary table on stdout, one progress line per case on stderr;
  --out DIR writes bench.json, bench.md and bench.png (the plot needs matplotlib).

exit status: 0 ok; 1 a case or probe failed, or exact outputs differ between
  devices; 2 bad arguments; 3 --compare found a regression (a case's median time
  more than --threshold per cent above OLD's, its output digest changed, or it
  fails now).

examples:
  oclshade bench --quick --out bench-out
  oclshade bench --device 0 --out today --compare yesterday/bench.json --threshold 15
"""


def _reps(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if not 1 <= value <= 1000:
        raise argparse.ArgumentTypeError(f"--reps must be an integer 1..1000, got {text!r}")
    return value


def _threshold(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"--threshold must be a number of per cent >= 0, got {text!r}")
    return value


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``bench`` on the ``oclshade`` command's subparsers."""
    b = sub.add_parser("bench", help="compare OpenCL devices on every kernel family (roofline, timings, digests)",
                       description="Device-portability benchmark: roofline probes and every kernel family on "
                                   "each OpenCL device, with output digests and performance portability.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    b.add_argument("--device", dest="devices", action="append", metavar="SPEC",
                   help="an OpenCL device: index or name substring, as for the other commands; repeat for "
                        "several (default: every device)")
    size = b.add_mutually_exclusive_group()
    size.add_argument("--quick", dest="sizes", action="store_const", const="quick",
                      help="small inputs and fewer repetitions (same as --sizes quick)")
    size.add_argument("--sizes", choices=tuple(SIZES), default="full",
                      help="input sizes: full (default, the headline sizes), quick, tiny (smoke test)")
    b.add_argument("--reps", type=_reps, metavar="N",
                   help="timed repetitions per case (default: 5 full, 3 quick, 2 tiny)")
    b.add_argument("--out", metavar="DIR", help="write bench.json, bench.md and bench.png there")
    b.add_argument("--compare", metavar="OLD.json",
                   help="an earlier bench.json to compare with (exit 3 on a regression)")
    b.add_argument("--threshold", type=_threshold, metavar="PCT",
                   help=f"--compare: a median time more than PCT %% above OLD's is a regression "
                        f"(default {DEFAULT_THRESHOLD_PCT:g})")
    b.add_argument("--quiet", "-q", action="store_true", help="no progress lines")
    b.set_defaults(sizes="full")


def _devices(specs: list[str] | None) -> list[DeviceInfo]:
    infos = list_devices()
    if not specs:
        return infos
    chosen = dict.fromkeys(device_index(select_device(spec)) for spec in specs)
    return [infos[i] for i in chosen]


def run(args: argparse.Namespace) -> int:
    """The ``bench`` command; returns the exit status (see the module docstring)."""
    from ..cli import CliError, UsageError

    if args.threshold is not None and args.compare is None:
        raise UsageError("--threshold needs --compare")
    threshold = DEFAULT_THRESHOLD_PCT if args.threshold is None else args.threshold
    try:
        old = None if args.compare is None else load_report(args.compare)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if old is not None and old["sizes"] != args.sizes:
        raise UsageError(f"--compare {args.compare}: it was run with {old['sizes']!r} sizes, this run uses "
                         f"{args.sizes!r}; timings of different sizes are not comparable")
    out_dir = None if args.out is None else Path(args.out)
    if out_dir is not None:
        try:
            out_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UsageError(f"--out {args.out}: cannot create the folder: {exc}") from None
    infos = _devices(args.devices)
    if not infos:
        raise CliError("no OpenCL device found; install 'pocl-binary-distribution' (pip) or a GPU driver's ICD")
    sizes = SIZES[args.sizes]

    def progress(message: str) -> None:
        if not args.quiet:
            print(f"oclshade bench: {message}", file=sys.stderr, flush=True)

    command = shlex.join(["oclshade", *sys.argv[1:]]) if sys.argv[1:2] == ["bench"] else "oclshade bench"
    report = run_benchmark(infos, sizes, args.reps or sizes.reps, command, progress)
    if old is not None:
        report["compare"] = comparison(report, old, args.compare, threshold)
    print(summary(report))
    if out_dir is not None:
        write_json(out_dir / "bench.json", report)
        write_markdown(out_dir / "bench.md", report)
        plotted = write_plots(out_dir / "bench.png", report)
        if not plotted:
            print("oclshade bench: matplotlib is not installed: bench.png skipped (pip install matplotlib)",
                  file=sys.stderr)
        progress(f"wrote bench.json, bench.md{', bench.png' if plotted else ''} to {out_dir}")
    if old is not None:
        print()
        print(format_comparison(report["compare"]))
        if report["compare"]["regressions"]:
            return EXIT_REGRESSION
    return 1 if failures(report) or mismatches(report) else 0
