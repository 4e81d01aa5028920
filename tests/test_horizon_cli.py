"""``oclshade horizon`` and ``oclshade svf``, run in-process through ``oclshade.cli.main``."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import tifffile

from oclshade import Heightmap
from oclshade.cli import main
from oclshade.horizon import Curvature, HorizonCaster
from oclshade.io import Raster, write_raster
from oclshade.synthetic import canyon_crater

GEOREF = {33550: (30.0, 30.0, 0.0), 33922: (0.0, 0.0, 0.0, 500000.0, 4000000.0, 0.0),
          34735: (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32633)}


@pytest.fixture(scope="module")
def dem() -> np.ndarray:
    return canyon_crater(30, 41, seed=3, relief=600.0)


@pytest.fixture()
def npy(tmp_path: Path, dem: np.ndarray) -> Path:
    np.save(tmp_path / "dem.npy", dem)
    return tmp_path / "dem.npy"


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("oclshade: error: "), err
    return lines[0]


def test_horizon_npy_equals_the_api(tmp_path, npy, dem, capsys):
    assert main(["horizon", str(npy), str(tmp_path / "h.npy"), "--cellsize", "30", "--azimuths", "8"]) == 0
    err = capsys.readouterr().err
    assert "8/8 azimuths" in err and "horizons" in err      # progress bar and summary on stderr
    got = np.load(tmp_path / "h.npy")
    assert got.shape == (8, 30, 41) and got.dtype == np.float32
    assert np.array_equal(got, HorizonCaster(Heightmap.from_array(dem, 30.0)).horizons(8))


def test_horizon_tif_bands_are_named_by_azimuth_and_keep_the_georeferencing(tmp_path, dem, capsys):
    raw = dem.astype(np.float32)
    raw[2:4, 5:8] = -9999.0
    src = tmp_path / "dem.tif"
    write_raster(src, raw, like=Raster(raw.astype(np.float64), 30.0, 30.0, georef=GEOREF), nodata=-9999.0)
    assert main(["horizon", str(src), str(tmp_path / "h.tif"), "--azimuths", "16", "-q"]) == 0
    assert capsys.readouterr().err == ""
    with tifffile.TiffFile(tmp_path / "h.tif") as tif:
        tags = {t.code: t.value for t in tif.pages[0].tags.values()}
        bands = tif.asarray()
    assert ">horizon_az0<" in tags[42112] and ">horizon_az22p5<" in tags[42112] and ">horizon_az337p5<" in tags[42112]
    assert tags[33550][:2] == (30.0, 30.0) and tags[42113] == "nan"
    assert bands.shape == (16, 30, 41) and np.all(np.isnan(bands[:, 2:4, 5:8]))


def test_svf_and_its_definitions(tmp_path, npy, dem):
    caster = HorizonCaster(Heightmap.from_array(dem, 30.0))
    for definition in ("cosine", "solid-angle"):
        out = tmp_path / f"{definition}.npy"
        assert main(["svf", str(npy), str(out), "--cellsize", "30", "--azimuths", "12", "--definition", definition,
                     "-q"]) == 0
        assert np.array_equal(np.load(out), caster.sky_view_factor(12, definition))
    assert main(["svf", str(npy), str(tmp_path / "default.npy"), "--cellsize", "30", "--azimuths", "12", "-q"]) == 0
    assert np.array_equal(np.load(tmp_path / "default.npy"), np.load(tmp_path / "cosine.npy"))


def test_curvature_options(tmp_path, npy, dem):
    assert main(["horizon", str(npy), str(tmp_path / "c.npy"), "--cellsize", "30", "--azimuths", "4",
                 "--curvature", "--radius", "20000", "--refraction", "0.13", "-q"]) == 0
    expected = HorizonCaster(Heightmap.from_array(dem, 30.0), curvature=Curvature(20000.0, 0.13)).horizons(4)
    got = np.load(tmp_path / "c.npy")
    assert np.array_equal(got, expected)
    flat = HorizonCaster(Heightmap.from_array(dem, 30.0)).horizons(4)
    assert np.nanmax(flat - got) > 0.1       # the curvature lowers distant terrain


def test_max_distance(tmp_path, npy, dem, capsys):
    hm = Heightmap.from_array(dem, 30.0)
    assert main(["horizon", str(npy), str(tmp_path / "r.npy"), "--cellsize", "30", "--azimuths", "4",
                 "--max-distance", "150"]) == 0
    assert "within 150 m" in capsys.readouterr().err
    got = np.load(tmp_path / "r.npy")
    assert np.array_equal(got, HorizonCaster(hm, max_distance=150.0).horizons(4), equal_nan=True)
    assert np.nanmax(HorizonCaster(hm).horizons(4) - got) > 1.0     # farther terrain is not seen
    assert main(["svf", str(npy), str(tmp_path / "s.npy"), "--cellsize", "30", "--azimuths", "8",
                 "--max-distance", "150", "--definition", "solid-angle", "-q"]) == 0
    want = HorizonCaster(hm, max_distance=150.0).sky_view_factor(8, "solid-angle")
    assert np.array_equal(np.load(tmp_path / "s.npy"), want, equal_nan=True)


@pytest.mark.parametrize("args, message", [
    (["horizon", "{npy}", "{out}.png", "--cellsize", "30"], "expected .tif"),
    (["horizon", "{npy}", "{out}.npy", "--cellsize", "30", "--max-distance", "0"], "positive number of metres"),
    (["svf", "{npy}", "{out}.npy", "--cellsize", "30", "--max-distance", "-5"], "positive number of metres"),
    (["horizon", "{npy}", "{out}.npy", "--cellsize", "30", "--max-distance", "far"], "max distance must be a number"),
    (["horizon", "{npy}", "{out}.npy", "--cellsize", "30", "--radius", "1000"], "go with --curvature"),
    (["horizon", "{npy}", "{out}.npy", "--cellsize", "30", "--refraction", "0.2"], "go with --curvature"),
    (["horizon", "{npy}", "{out}.npy", "--cellsize", "30", "--curvature", "--refraction", "1"], "refraction"),
    (["horizon", "{npy}", "{out}.npy", "--cellsize", "30", "--azimuths", "2"], "azimuths"),
    (["svf", "{npy}", "{out}.npy", "--cellsize", "30", "--definition", "hemisphere"], "definition"),
    (["svf", "{npy}", "{out}.npy", "--cellsize", "30", "1", "2", "3"], "cellsize"),
    (["svf", "{npy}", "{out}.npy"], "cell size"),
    (["svf", "{npy}", "{out}.npy", "--cellsize", "30", "--co", "COMPRESS=ZSTD"], "GeoTIFF"),
])
def test_usage_errors_exit_2_with_one_line(tmp_path, npy, capsys, args, message):
    argv = [a.format(npy=npy, out=tmp_path / "out") for a in args]
    assert main(argv) == 2
    assert message in one_error_line(capsys.readouterr().err)
    assert not list(tmp_path.glob("out*"))


def test_refuses_to_overwrite_the_input(tmp_path, npy, capsys):
    assert main(["horizon", str(npy), str(npy), "--cellsize", "30"]) == 1
    assert "refusing to overwrite" in one_error_line(capsys.readouterr().err)
