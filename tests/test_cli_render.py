"""``oclshade render``, run in-process through ``oclshade.cli.main``."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from PIL import Image

from oclshade.camera import frame_heightmap
from oclshade.cli import GBUFFER_CHANNELS, main
from oclshade.heightmap import Heightmap
from oclshade.synthetic import canyon_crater
from oclshade.terrain import Heightfield, TerrainRenderer


@pytest.fixture()
def npy(tmp_path: Path) -> Path:
    path = tmp_path / "dem.npy"
    np.save(path, canyon_crater(40, 56, seed=3, relief=600.0))
    return path


def test_render_png_and_gbuffer(tmp_path: Path, npy: Path, capsys) -> None:
    png, exr = tmp_path / "out" / "view.png", tmp_path / "out" / "view.exr"
    assert main(["render", str(npy), str(png), "--cellsize", "30", "--size", "64x40", "--gbuffer", str(exr),
                 "--view", "150,35", "--sun", "100,30"]) == 0
    assert "64x40 pixels" in capsys.readouterr().err
    img = np.asarray(Image.open(png))
    assert img.shape == (40, 64, 3) and img.dtype == np.uint8
    with OpenEXR.File(str(exr), separate_channels=True) as f:
        channels = {name: np.array(c.pixels) for name, c in f.channels().items()}
    want = {n for names in GBUFFER_CHANNELS.values() for n in names if n is not None}
    assert set(channels) == want | {"shadow"}
    # the EXR holds what the Python API renders for the same camera
    hm = Heightmap.from_array(np.load(npy), 30.0)
    cam = frame_heightmap(hm, 64, 40, azimuth=150.0, elevation=35.0)
    g = TerrainRenderer(Heightfield(hm)).render(cam)
    assert np.array_equal(channels["Z"], g.depth)
    assert np.array_equal(channels["position.w"], g.position[..., 3])
    assert np.array_equal(channels["uv_grad.dvdr"], g.uv_grad[..., 3])
    sky = img[~g.hit]
    assert len(np.unique(sky.reshape(-1, 3), axis=0)) == 1                # empty pixels: one sky colour


def test_render_exr_only_with_explicit_camera_and_methods(tmp_path: Path, npy: Path) -> None:
    outs = {}
    for method in ("bisect", "dda"):
        out = tmp_path / f"{method}.exr"
        assert main(["render", str(npy), str(out), "--cellsize", "30", "--size", "32x24", "--method", method,
                     "--camera", "800,-2500,1500,800,-600,0", "-q"]) == 0
        with OpenEXR.File(str(out), separate_channels=True) as f:
            outs[method] = np.array(f.channels()["Z"].pixels)
    assert np.isfinite(outs["bisect"]).mean() > 0.2
    assert np.array_equal(np.isfinite(outs["bisect"]), np.isfinite(outs["dda"]))


def test_render_z_factor_and_scale_change_the_frame(tmp_path: Path, npy: Path) -> None:
    frames = []
    for extra in ([], ["-z", "3"], ["-s", "2"]):
        out = tmp_path / f"f{len(frames)}.exr"
        assert main(["render", str(npy), str(out), "--cellsize", "30", "--size", "24x16", "-q", "--ortho",
                     "--view", "180,90", *extra]) == 0
        with OpenEXR.File(str(out), separate_channels=True) as f:
            frames.append(np.array(f.channels()["normal.z"].pixels))
    assert not np.array_equal(frames[0], frames[1]) and not np.array_equal(frames[0], frames[2])


@pytest.mark.parametrize("argv,message", [
    (["--size", "12"], "WIDTHxHEIGHT"),
    (["--camera", "1,2,3"], "6 comma-separated"),
    (["--fov", "180"], "fov"),
    (["--method", "ray"], "invalid choice"),
    (["--ssaa", "9"], "1..8"),
    (["--ssaa", "two"], "1..8"),
    (["--crop", "1"], "[0, 1)"),
    (["--ssaa", "2", "--ao", "--ao-map", "a.exr"], "--ssaa 2 makes the PNG frame only"),
])
def test_render_bad_arguments(tmp_path: Path, npy: Path, capsys, argv, message) -> None:
    assert main(["render", str(npy), str(tmp_path / "x.png"), "--cellsize", "30", *argv]) == 2
    assert message in capsys.readouterr().err


def test_render_refuses_bad_outputs(tmp_path: Path, npy: Path, capsys) -> None:
    assert main(["render", str(npy), str(tmp_path / "x.tif"), "--cellsize", "30"]) == 2
    assert "expected .png" in capsys.readouterr().err
    assert main(["render", str(npy), str(tmp_path / "x.exr"), "--cellsize", "30", "--gbuffer",
                 str(tmp_path / "g.exr")]) == 2
    before = npy.read_bytes()
    assert main(["render", str(npy), str(npy), "--cellsize", "30"]) == 2          # .npy is not an output kind
    png = tmp_path / "dem.png"
    Image.fromarray(np.full((20, 30), 100, np.uint8)).save(png)
    assert main(["render", str(png), str(png), "--cellsize", "30"]) == 1
    assert "refusing to overwrite" in capsys.readouterr().err
    assert npy.read_bytes() == before and np.asarray(Image.open(png)).shape == (20, 30)


def test_render_needs_a_cell_size(tmp_path: Path, npy: Path, capsys) -> None:
    assert main(["render", str(npy), str(tmp_path / "x.png")]) == 2
    assert "--cellsize" in capsys.readouterr().err


def test_render_shadows_on_by_default_and_ao(tmp_path: Path, npy: Path) -> None:
    """The default frame carries per-pixel cast shadows; --ao adds the AO pass and its map."""
    from oclshade.frames import AOSettings, FrameSettings, TerrainScene
    from oclshade.compose import Lighting
    from oclshade.io import read_dem

    base = ["--cellsize", "30", "--size", "64x40", "--view", "150,35", "--sun", "120,8", "-q"]
    paths = {k: tmp_path / f"{k}.png" for k in ("default", "flat", "ao")}
    aomap = tmp_path / "ao.exr"
    assert main(["render", str(npy), str(paths["default"]), *base]) == 0
    assert main(["render", str(npy), str(paths["flat"]), *base, "--no-shadows"]) == 0
    assert main(["render", str(npy), str(paths["ao"]), *base, "--ao", "3", "--ao-map", str(aomap)]) == 0
    img = {k: np.asarray(Image.open(p)).astype(int) for k, p in paths.items()}
    hm = Heightmap.from_array(np.load(npy), 30.0)
    cam = frame_heightmap(hm, 64, 40, azimuth=150.0, elevation=35.0)
    scene = TerrainScene(Heightfield(hm))
    want = scene.frame(cam, (120.0, 8.0), FrameSettings(lighting=Lighting(sun=(120.0, 8.0))))
    assert np.array_equal(img["default"], want.image[..., :3])
    shadowed = np.abs(img["default"] - img["flat"]).sum(-1) > 0
    assert 0.0 < shadowed.mean() < 0.9                                  # cast shadows darken part of the frame
    assert (img["default"] <= img["flat"]).all()
    ao = read_dem(str(aomap), cellsize=1.0).heights
    want_ao = scene.frame(cam, (120.0, 8.0), FrameSettings(ao=AOSettings(radius=90.0),
                                                          lighting=Lighting(sun=(120.0, 8.0)))).ao_factor()
    assert np.array_equal(ao, want_ao) and ao.min() < 1.0 and ao.max() <= 1.0
    assert (img["ao"] <= img["default"]).all() and (img["ao"] < img["default"]).any()


def test_render_ao_arguments(tmp_path: Path, npy: Path, capsys) -> None:
    out = tmp_path / "v.png"
    assert main(["render", str(npy), str(out), "--cellsize", "30", "--ao-map", str(tmp_path / "a.exr")]) == 2
    assert "--ao-map" in capsys.readouterr().err
    assert main(["render", str(npy), str(out), "--cellsize", "30", "--ao", "--ao-samples", "3"]) == 2
    assert "4..256" in capsys.readouterr().err


def test_render_ssaa_and_crop(tmp_path: Path, npy: Path, capsys) -> None:
    """--ssaa N: the frame FrameSettings(ssaa=N) makes, at the requested size; --crop: the
    automatic camera's crop (0: the whole map in view)."""
    from oclshade.frames import FrameSettings, TerrainScene
    from oclshade.compose import Lighting

    base = ["--cellsize", "30", "--size", "48x30", "--view", "150,35", "--sun", "120,20"]
    out = {k: tmp_path / f"{k}.png" for k in ("ssaa", "whole")}
    assert main(["render", str(npy), str(out["ssaa"]), *base, "--ssaa", "3"]) == 0
    assert "(3x3 samples each)" in capsys.readouterr().err
    assert main(["render", str(npy), str(out["whole"]), *base, "--crop", "0", "-q"]) == 0
    img = {k: np.asarray(Image.open(p)) for k, p in out.items()}
    assert img["ssaa"].shape == img["whole"].shape == (30, 48, 3)
    hm = Heightmap.from_array(np.load(npy), 30.0)
    scene = TerrainScene(Heightfield(hm))
    light = Lighting(sun=(120.0, 20.0))
    cam = frame_heightmap(hm, 48, 30, azimuth=150.0, elevation=35.0)
    assert np.array_equal(img["ssaa"], scene.frame(cam, (120.0, 20.0), FrameSettings(lighting=light, ssaa=3)).image[..., :3])
    whole = frame_heightmap(hm, 48, 30, azimuth=150.0, elevation=35.0, crop=0.0)
    frame = scene.frame(whole, (120.0, 20.0), FrameSettings(lighting=light))
    assert np.array_equal(img["whole"], frame.image[..., :3])
    assert frame.gbuffer.to_host().hit.mean() < TerrainRenderer(Heightfield(hm)).render(cam).hit.mean()
