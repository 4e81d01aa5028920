"""The command line, run in-process through ``oclshade.cli.main``."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import tifffile
from PIL import Image

from oclshade import Heightmap, ShadowCaster, Sun
from oclshade.cli import main
from oclshade.io import Raster, read_dem, write_raster
from oclshade.synthetic import canyon_crater

ROWS, COLS = 40, 56
GEOREF = {33550: (30.0, 30.0, 0.0), 33922: (0.0, 0.0, 0.0, 500000.0, 4000000.0, 0.0),
          34735: (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32633)}


@pytest.fixture(scope="module")
def dem() -> np.ndarray:
    return canyon_crater(ROWS, COLS, seed=7, relief=800.0)


@pytest.fixture()
def npy(tmp_path: Path, dem: np.ndarray) -> Path:
    path = tmp_path / "dem.npy"
    np.save(path, dem)
    return path


@pytest.fixture()
def tif(tmp_path: Path, dem: np.ndarray) -> Path:
    """int16 GeoTIFF (EPSG:32633, 30 m cells) with nodata -32768 in a few cells."""
    raw = np.round(dem).astype(np.int16)
    raw[3:6, 10:14] = -32768
    path = tmp_path / "dem.tif"
    write_raster(path, raw, like=Raster(raw.astype(np.float64), 30.0, 30.0, georef=GEOREF), nodata=-32768)
    return path


def api_masks(heights: np.ndarray, cellsize: tuple[float, float], suns: list[tuple[float, float]],
              z_factor: float = 1.0) -> list[np.ndarray]:
    caster = ShadowCaster(Heightmap.from_array(heights, cellsize, z_factor=z_factor))
    return [r.mask for r in caster.cast_many([Sun(*s) for s in suns])]


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("oclshade: error: "), err
    return lines[0]


def test_devices_lists_a_device(capsys):
    assert main(["devices"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:3] == ["index", "platform", "device"]
    assert len(out) >= 2 and out[1].split()[0] == "0"


def test_npy_mask_equals_api(tmp_path, npy, dem, capsys):
    out = tmp_path / "mask.npy"
    assert main(["shadow", str(npy), str(out), "--cellsize", "30", "-az", "135", "-alt", "15"]) == 0
    mask = np.load(out)
    assert mask.dtype == np.uint8 and mask.shape == (ROWS, COLS)
    np.testing.assert_array_equal(mask, api_masks(dem, (30.0, 30.0), [(135, 15)])[0])
    summary = capsys.readouterr().err.strip().splitlines()
    assert len(summary) == 1 and "in cast shadow" in summary[0] and "method exact" in summary[0]


def test_cellsize_z_and_scale(tmp_path, npy, dem):
    out = tmp_path / "mask.npy"
    args = ["shadow", str(npy), str(out), "--cellsize", "10", "20", "-z", "2", "-s", "3", "-alt", "10", "-q"]
    assert main(args) == 0
    np.testing.assert_array_equal(np.load(out), api_masks(dem, (30.0, 60.0), [(315, 10)], z_factor=2.0)[0])


def test_npy_without_cellsize_is_refused(tmp_path, npy, capsys):
    assert main(["shadow", str(npy), str(tmp_path / "m.npy")]) == 2
    assert "--cellsize" in one_error_line(capsys.readouterr().err)


def test_tif_keeps_georef_and_nodata(tmp_path, tif):
    out = tmp_path / "out" / "mask.tif"  # the output folder is created
    assert main(["shadow", str(tif), str(out), "-az", "200", "-alt", "25", "-q"]) == 0
    with tifffile.TiffFile(out) as f:
        page = f.pages[0]
        mask = page.asarray()
        tags = {t.code: t.value for t in page.tags.values()}
    for code, value in GEOREF.items():
        assert tuple(tags[code]) == pytest.approx(value)
    assert float(tags[42113]) == 255.0
    assert mask.dtype == np.uint8
    assert (mask[3:6, 10:14] == 255).all() and set(np.unique(mask)) <= {0, 1, 255}
    source = read_dem(tif)
    np.testing.assert_array_equal(mask, api_masks(source.heights, (30.0, 30.0), [(200, 25)])[0])


def test_output_all_to_tif_is_float32(tmp_path, tif):
    out = tmp_path / "all.tif"
    assert main(["shadow", str(tif), str(out), "--output", "all", "-q"]) == 0
    bands = tifffile.imread(out)
    assert bands.shape == (3, ROWS, COLS) and bands.dtype == np.float32
    assert np.isnan(bands[:, 3:6, 10:14]).all()
    assert set(np.unique(bands[0][~np.isnan(bands[0])])) <= {0.0, 1.0}


def test_refuses_to_overwrite_the_input(tmp_path, tif, capsys):
    before = tif.read_bytes()
    assert main(["shadow", str(tif), str(tif), "-q"]) == 1
    assert "refusing to overwrite" in one_error_line(capsys.readouterr().err)
    link = tmp_path / "link.tif"
    link.symlink_to(tif)
    for alias in (f"{tmp_path}/./dem.tif", str(link)):
        assert main(["shadow", str(tif), alias, "-q"]) == 1
        one_error_line(capsys.readouterr().err)
    assert tif.read_bytes() == before and link.is_symlink()


def test_refuses_preview_over_the_input(tmp_path, capsys, dem):
    png = tmp_path / "dem.png"
    write_raster(png, np.round(dem).astype(np.uint16))
    before = png.read_bytes()
    assert main(["shadow", str(png), str(tmp_path / "m.npy"), "--cellsize", "30", "--preview", str(png)]) == 1
    one_error_line(capsys.readouterr().err)
    assert png.read_bytes() == before


@pytest.mark.parametrize("args", [["-alt", "95"], ["--method", "fastest"], ["-az", "north"],
                                  ["--sun", "10"], ["--k-dark", "2"], ["--output", "everything"]])
def test_bad_arguments_exit_2_with_one_line(tmp_path, npy, capsys, args):
    assert main(["shadow", str(npy), str(tmp_path / "m.npy"), "--cellsize", "30", *args]) == 2
    one_error_line(capsys.readouterr().err)
    assert not (tmp_path / "m.npy").exists()


def test_unreadable_input_exits_1(tmp_path, capsys):
    bad = tmp_path / "bad.tif"
    bad.write_bytes(b"not a tiff")
    assert main(["shadow", str(bad), str(tmp_path / "m.tif")]) == 1
    one_error_line(capsys.readouterr().err)
    assert main(["shadow", str(tmp_path / "missing.tif"), str(tmp_path / "m.tif")]) == 1
    one_error_line(capsys.readouterr().err)


def test_repeated_sun_gives_one_band_each(tmp_path, npy, dem, capsys):
    out = tmp_path / "suns.npy"
    suns = [(37, 5), (135, 20), (270, 45)]
    args = ["shadow", str(npy), str(out), "--cellsize", "30"]
    for az, alt in suns:
        args += ["--sun", f"{az},{alt}"]
    assert main(args) == 0
    masks = np.load(out)
    assert masks.shape == (3, ROWS, COLS) and masks.dtype == np.uint8
    for got, want in zip(masks, api_masks(dem, (30.0, 30.0), suns)):
        np.testing.assert_array_equal(got, want)
    assert "3/3 suns" in capsys.readouterr().err  # the progress bar


@pytest.mark.parametrize("text", ["azimuth,elevation\n37,5\n135,20\n",
                                  "# sun positions\n37, 5\n\n135, 20\n",
                                  "elevation,azimuth\n5,37\n20,135\n"])
def test_suns_csv(tmp_path, npy, dem, text):
    csv = tmp_path / "suns.csv"
    csv.write_text(text)
    out = tmp_path / "suns.npy"
    assert main(["shadow", str(npy), str(out), "--cellsize", "30", "--suns", str(csv), "-q"]) == 0
    masks = np.load(out)
    for got, want in zip(masks, api_masks(dem, (30.0, 30.0), [(37, 5), (135, 20)])):
        np.testing.assert_array_equal(got, want)


def test_suns_csv_bad_row(tmp_path, npy, capsys):
    csv = tmp_path / "suns.csv"
    csv.write_text("37,5\n135,120\n")
    assert main(["shadow", str(npy), str(tmp_path / "m.npy"), "--cellsize", "30", "--suns", str(csv)]) == 2
    assert "line 2" in one_error_line(capsys.readouterr().err)


def test_preview_png(tmp_path, npy):
    png = tmp_path / "preview.png"
    assert main(["shadow", str(npy), str(tmp_path / "m.tif"), "--cellsize", "30", "-alt", "10",
                 "--preview", str(png), "-q"]) == 0
    with Image.open(png) as img:
        assert img.format == "PNG" and img.size == (COLS, ROWS) and img.mode == "RGB"


def test_python_dash_m(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "oclshade", "shadow", "--help"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and "--suns" in proc.stdout


def test_bundled_terrain_is_the_generators_output():
    bundled = read_dem(Path(__file__).resolve().parents[1] / "data" / "canyon_512.tif")
    assert (bundled.dx, bundled.dy, bundled.geographic) == (30.0, 30.0, False)
    np.testing.assert_array_equal(bundled.heights, canyon_crater(512).astype(np.float64))
