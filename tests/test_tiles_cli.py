"""oclshade shadow --tile / --max-memory / --workers, and the Dask API: the whole-map results."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import tifffile

from oclshade import ShadowCaster, Sun
from oclshade.cli import main
from oclshade.heightmap import Heightmap
from oclshade.sun import SunBlock, SunField
from oclshade.synthetic import canyon_crater
from oclshade.tiles.cli import memory_size
from oclshade.tiles.stream import rss_bytes

REPO = Path(__file__).resolve().parents[1]
TAGS = [(42113, "s", 0, "-9999", True), (33550, "d", 3, (30.0, 30.0, 0.0), True),
        (33922, "d", 6, (0.0, 0.0, 0.0, 500000.0, 4000000.0, 0.0), True)]


def make_dem(path: Path, rows: int, cols: int, tile: int = 128) -> np.ndarray:
    h = canyon_crater(rows, cols, seed=5, relief=1500.0)
    h[rows // 3:rows // 3 + 9, cols // 2:cols // 2 + 40] = -9999.0
    tifffile.imwrite(path, h, tile=(tile, tile), compression="zlib", extratags=TAGS)
    return h


@pytest.fixture(scope="module")
def dem(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("dem") / "dem.tif"
    make_dem(path, 300, 410)
    return path


SUNS = ["--sun", "37,5", "--sun", "135,20", "--sun=-90,45"]


@pytest.mark.parametrize("extra", [["--tile", "64"], ["--tile", "100", "--of", "COG", "--co", "BLOCKSIZE=64"],
                                   ["--max-memory", "+512M"]], ids=str)
def test_tiled_cli_writes_the_whole_maps_file_byte_for_byte(tmp_path, dem, extra):
    # the budget bounds this whole pytest process, whose size depends on the tests run before:
    # "+512M" is 512 MiB above what it holds now
    extra = [f"{rss_bytes() // 2**20 + 512}M" if o == "+512M" else o for o in extra]
    options = [o for o in extra if o in ("--of", "COG", "--co", "BLOCKSIZE=64")]
    assert main(["shadow", str(dem), str(tmp_path / "whole.tif"), *SUNS, "--output", "all", "-q", *options]) == 0
    assert main(["shadow", str(dem), str(tmp_path / "tiled.tif"), *SUNS, "--output", "all", "-q", *extra]) == 0
    assert (tmp_path / "whole.tif").read_bytes() == (tmp_path / "tiled.tif").read_bytes()


def test_tiled_cli_npy_output_and_summary(tmp_path, dem, capsys):
    assert main(["shadow", str(dem), str(tmp_path / "whole.npy"), "-az", "200", "-alt", "12", "-q"]) == 0
    assert main(["shadow", str(dem), str(tmp_path / "tiled.npy"), "-az", "200", "-alt", "12", "--tile", "96"]) == 0
    assert np.array_equal(np.load(tmp_path / "whole.npy"), np.load(tmp_path / "tiled.npy"))
    err = capsys.readouterr().err
    assert "tile job(s) of 96^2 cells" in err and "peak memory" in err


@pytest.mark.parametrize("args,message", [
    (["--tile", "64", "--preview", "p.png"], "--preview draws the whole map"),
    (["--max-memory", "256M", "o.exr"], "--max-memory writes .tif or .npy"),
    (["--max-memory", "lots"], "a memory size is a positive number"),
    (["--tile", "8"], "--tile must be an integer >= 16"),
    (["--workers", "0"], "--workers must be an integer >= 1"),
    (["--max-memory", "2M"], "leaves no room for a tile"),
])
def test_tiled_cli_usage_errors(tmp_path, dem, capsys, args, message):
    out = [a for a in args if a.endswith(".exr")]
    rest = [a if a != "p.png" else str(tmp_path / "p.png") for a in args if not a.endswith(".exr")]
    target = str(tmp_path / (out[0] if out else "o.tif"))
    assert main(["shadow", str(dem), target, *rest]) in (1, 2)
    assert message in capsys.readouterr().err
    assert not Path(target).exists()


def test_memory_sizes():
    assert memory_size("256M") == 256 << 20 and memory_size("1.5G") == 3 << 29 and memory_size("4096") == 4096
    assert memory_size("2gib") == 2 << 30


def test_max_memory_bounds_the_peak_of_the_whole_run(tmp_path):
    """A 1536^2 map traced with --max-memory stays under the budget, the whole run: with 200 MiB
    (one tile on PoCL; an NVIDIA driver holds 181 MiB itself, and then the run names the budget
    it needs, which is used instead), and with a budget just above what the process holds before
    any tile (many small tiles).  The whole-map run of the same map needs more."""
    make_dem(tmp_path / "big.tif", 1536, 1536, tile=256)
    code = ("import sys; from oclshade.cli import main; from oclshade.tiles.stream import peak_rss_bytes; "
            "rc = main(sys.argv[1:]); print(peak_rss_bytes()); sys.exit(rc)")

    def run(*extra: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-c", code, "shadow", str(tmp_path / "big.tif"),
                               str(tmp_path / "out.tif"), "-az", "135", "-alt", "20", "-q", *extra],
                              cwd=REPO, capture_output=True, text=True, timeout=300)

    def peak(*extra: str) -> int:
        done = run(*extra)
        assert done.returncode == 0, done.stderr
        return int(done.stdout.split()[-1])

    budget = 200 << 20
    first = run("--max-memory", "200M")
    if first.returncode != 0:
        needed = re.search(r"give at least (\d+) MiB", first.stderr)
        assert needed, first.stderr
        budget = (int(needed[1]) + 8) << 20
        tiled = peak("--max-memory", f"{budget >> 20}M")
    else:
        tiled = int(first.stdout.split()[-1])
    assert tiled < budget, f"peak {tiled / 2**20:.0f} MiB over --max-memory {budget >> 20}M"
    assert peak() > tiled

    refused = run("--max-memory", "1M")
    held = re.search(r"the process holds (\d+) MiB before any tile", refused.stderr)
    assert refused.returncode == 1 and held, refused.stderr
    small = int(held[1]) + 24
    many = peak("--max-memory", f"{small}M")
    assert many < small << 20, f"peak {many / 2**20:.0f} MiB over --max-memory {small}M"


def test_workers_write_the_whole_maps_file(tmp_path, dem):
    pytest.importorskip("distributed")
    assert main(["shadow", str(dem), str(tmp_path / "whole.tif"), *SUNS, "-q"]) == 0
    assert main(["shadow", str(dem), str(tmp_path / "workers.tif"), *SUNS, "--workers", "2", "--tile", "128",
                 "-q"]) == 0
    assert (tmp_path / "whole.tif").read_bytes() == (tmp_path / "workers.tif").read_bytes()


# ----------------------------------------------------------------------------- the Dask API

def test_shadow_dask_is_lazy_and_equals_the_caster():
    da = pytest.importorskip("dask.array")
    import dask
    from oclshade.tiles.dask_adapter import shadow_dask

    h = canyon_crater(150, 170, seed=8, relief=1200.0).astype(np.float64)
    h[40:44, 50:90] = -32768.0
    heights = da.from_array(h, chunks=(64, 64))
    suns = [Sun(135.0, 10.0), Sun(300.0, 30.0)]
    lazy = shadow_dask(heights, suns, 30.0, nodata=-32768.0, tile_size=48, block=16)
    assert isinstance(lazy, da.Array) and lazy.shape == (2, 150, 170) and lazy.dtype == np.uint8
    with dask.config.set(scheduler="threads"):
        got = lazy.compute()
    hm = Heightmap.from_array(h, 30.0, nodata=-32768.0)
    for k, res in enumerate(ShadowCaster(hm, cache=False).cast_many(suns)):
        assert np.array_equal(got[k], res.mask)
    coef = shadow_dask(heights, suns[0], 30.0, nodata=-32768.0, output="coefficient").compute(scheduler="sync")
    expected = ShadowCaster(hm, cache=False).cast(suns[0], outputs="coefficient").coefficient
    assert np.array_equal(coef, expected, equal_nan=True)


def test_shadow_dask_traces_a_sun_field_per_block():
    """Each cell's own sun: a field's blocks, lazily, the caster's field masks bit for bit."""
    da = pytest.importorskip("dask.array")
    from oclshade.tiles.dask_adapter import shadow_dask

    h = canyon_crater(150, 170, seed=8, relief=1200.0).astype(np.float64)
    hm = Heightmap.from_array(h, 30.0)
    field = SunField(hm.shape, tuple(SunBlock(r, min(r + 64, 150), c, min(c + 96, 170), Sun(120.0 + r / 10 + c / 20, 8.0))
                                     for r in range(0, 150, 64) for c in range(0, 170, 96)), Sun(125.0, 8.0), 4.0, 0.01)
    got = shadow_dask(da.from_array(h, chunks=(64, 64)), [field, Sun(300.0, 30.0)], 30.0, tile_size=48,
                      block=16).compute(scheduler="sync")
    want = ShadowCaster(hm, cache=False).cast_many([field, Sun(300.0, 30.0)])
    assert np.array_equal(got[0], want[0].mask) and np.array_equal(got[1], want[1].mask)
    one_sun = ShadowCaster(hm, cache=False).cast(Sun(125.0, 8.0)).mask
    assert not np.array_equal(got[0], one_sun)     # the blocks' suns, not the centre's
    with pytest.raises(ValueError, match="sun field"):
        shadow_dask(da.from_array(h[:, :100], chunks=64), field, 30.0)


def test_shadow_dask_takes_an_xarray_dataarray():
    xr = pytest.importorskip("xarray")
    pytest.importorskip("dask.array")
    from oclshade.tiles.dask_adapter import shadow_dask

    h = canyon_crater(90, 120, seed=9, relief=900.0).astype(np.float64)
    x = 500000.0 + 25.0 * (np.arange(120) + 0.5)
    y = 4000000.0 - 20.0 * (np.arange(90) + 0.5)
    arr = xr.DataArray(h, dims=("y", "x"), coords={"y": y, "x": x}).chunk({"y": 40, "x": 50})
    out = shadow_dask(arr, [(80.0, 15.0), (250.0, 25.0)], block=16)
    assert out.dims == ("sun", "y", "x") and np.array_equal(out["x"], x)
    masks = out.compute(scheduler="sync")
    hm = Heightmap.from_array(h, (25.0, 20.0))
    assert np.array_equal(masks.values[1], ShadowCaster(hm, cache=False).cast((250.0, 25.0)).mask)
    with pytest.raises(ValueError, match="y decrease"):
        shadow_dask(arr.isel(y=slice(None, None, -1)), (80.0, 15.0))
    with pytest.raises(ValueError, match="cellsize is needed"):
        shadow_dask(h, (80.0, 15.0))
