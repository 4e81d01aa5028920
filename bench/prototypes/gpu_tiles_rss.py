"""Diagnostic (device run): where the resident memory of a --max-memory 200M tiled run goes."""
import sys
import tempfile
from pathlib import Path

import oclshade.tiles.stream as st  # noqa: E402
from oclshade.cli import main  # noqa: E402

MiB = 2 ** 20
orig_plan, orig_jobs, orig_tiles = st.memory_plan, st.run_jobs, st.plan_tiles


def tiles(*a, **k):
    plan = orig_tiles(*a, **k)
    print(f"tile size {plan.tile_size}, largest window {plan.largest_window} cells", flush=True)
    return plan


def plan(budget, baseline, *a, **k):
    cells = orig_plan(budget, baseline, *a, **k)
    print(f"plan: budget {budget / MiB:.0f} baseline {baseline / MiB:.1f} MiB, cells {cells}, args {a}", flush=True)
    return cells


def jobs(jobs, read, write, tracing, **kw):
    print(f"jobs {len(jobs)} rss {st.rss_bytes() / MiB:.1f} peak {st.peak_rss_bytes() / MiB:.1f}", flush=True)

    def w(job, results):
        write(job, results)
        from oclshade.runtime import get_runtime
        rt = get_runtime()
        print(f"tile {job.tile.r0},{job.tile.c0} builds {rt.build_misses} kernels {len(rt._kernels)} rss {st.rss_bytes() / MiB:.1f} peak {st.peak_rss_bytes() / MiB:.1f}",
              flush=True)
    return orig_jobs(jobs, read, w, tracing, **kw)


st.memory_plan, st.run_jobs, st.plan_tiles = plan, jobs, tiles
tmp = Path(tempfile.mkdtemp())
import subprocess  # noqa: E402
subprocess.run([sys.executable, "-c", f"import sys; sys.path.insert(0, 'tests'); from test_tiles_cli import make_dem; "
                f"from pathlib import Path; make_dem(Path({str(tmp / 'big.tif')!r}), 1536, 1536, tile=256)"], check=True)
print(f"start rss {st.rss_bytes() / MiB:.1f}", flush=True)
rc = main(["shadow", str(tmp / "big.tif"), str(tmp / "out.tif"), "-az", "135", "-alt", "20", "-q",
           "--max-memory", sys.argv[1] if len(sys.argv) > 1 else "200M"])
print(f"rc {rc} end rss {st.rss_bytes() / MiB:.1f} peak {st.peak_rss_bytes() / MiB:.1f}")
