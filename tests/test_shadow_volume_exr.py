"""The --gbuffer EXR's shadow channel and its view/projection header (issue 20), read back."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenEXR
import pytest

from oclshade.cli import GBUFFER_NAMES, CliError, GBufferExr, main
from oclshade.heightmap import Heightmap
from oclshade.reference.screen_shadows import pixel_shadows, surface_height
from oclshade.sun import Sun
from oclshade.synthetic import canyon_crater


@pytest.fixture()
def npy(tmp_path: Path) -> Path:
    path = tmp_path / "dem.npy"
    np.save(path, canyon_crater(40, 56, seed=3, relief=600.0))
    return path


def read(path: Path) -> tuple[dict[str, np.ndarray], dict]:
    with OpenEXR.File(str(path), separate_channels=True) as f:
        return {name: np.array(c.pixels) for name, c in f.channels().items()}, dict(f.header())


def test_gbuffer_exr_has_shadow_and_camera_matrices(tmp_path: Path, npy: Path) -> None:
    exr = tmp_path / "g.exr"
    assert main(["render", str(npy), str(tmp_path / "v.png"), "--cellsize", "30", "--size", "64x40",
                 "--gbuffer", str(exr), "--view", "150,35", "--sun", "100,12", "--quiet"]) == 0
    ch, header = read(exr)
    assert set(ch) == set(GBUFFER_NAMES) | {"shadow"}
    view, proj = header["view"], header["projection"]
    assert view.shape == proj.shape == (4, 4) and view.dtype == proj.dtype == np.float64
    hit = ch["position.w"] > 0.5
    pos = np.stack([ch["position.x"], ch["position.y"], ch["position.z"], np.ones(hit.shape)], -1)[hit]
    # world positions rebuilt from the header lie on the terrain at the pixel's uv
    world = pos @ np.linalg.inv(view).T
    hm = Heightmap.from_array(np.load(npy), 30.0)
    u, v = ch["uv.u"][hit].astype(np.float64), ch["uv.v"][hit].astype(np.float64)
    ground = surface_height(hm.relative32.astype(np.float64), u, v) + hm.offset
    assert np.allclose(world[:, 0], 30.0 * u, atol=0.05) and np.allclose(world[:, 1], -30.0 * v, atol=0.05)
    assert np.allclose(world[:, 2], ground, atol=0.05)
    # the projection takes each point to its pixel's centre
    clip = pos @ proj.T
    rows, cols = np.nonzero(hit)
    assert np.allclose(clip[:, 0] / clip[:, 3], (2 * cols + 1) / 64 - 1, atol=1e-4)
    assert np.allclose(clip[:, 1] / clip[:, 3], 1 - (2 * rows + 1) / 40, atol=1e-4)
    # shadow: 1 in cast shadow on hit pixels (the float64 twin of the per-pixel pass), 0 lit or empty
    shadow = ch["shadow"]
    assert set(np.unique(shadow)) <= {0.0, 1.0} and not shadow[~hit].any()
    ref = pixel_shadows(hm, Sun(100, 12), np.stack([ch["uv.u"], ch["uv.v"]], -1), hit)
    agree = (shadow == 1.0) == (ref.mask == 1)
    assert 0.05 < shadow[hit].mean() < 0.95
    assert agree[hit & ~ref.graze].mean() >= 0.995


def test_no_shadow_channel_without_shadows(tmp_path: Path, npy: Path) -> None:
    exr = tmp_path / "g.exr"
    assert main(["render", str(npy), str(exr), "--cellsize", "30", "--size", "32x20", "--no-shadows", "--quiet"]) == 0
    ch, header = read(exr)
    assert set(ch) == set(GBUFFER_NAMES) and header["view"].shape == (4, 4)


def test_gbuffer_writer_checks_its_destination_first(tmp_path: Path) -> None:
    with pytest.raises(CliError, match="is a directory"):
        GBufferExr(str(tmp_path))
    with pytest.raises(CliError, match="does not exist"):
        GBufferExr(str(tmp_path / "missing" / "g.exr"))


CUBE = "\n".join(["v 0 0 0", "v 1 0 0", "v 1 1 0", "v 0 1 0", "v 0 0 1", "v 1 0 1", "v 1 1 1", "v 0 1 1",
                  "f 1 3 2", "f 1 4 3", "f 5 6 7", "f 5 7 8", "f 1 2 6", "f 1 6 5", "f 2 3 7", "f 2 7 6",
                  "f 3 4 8", "f 3 8 7", "f 4 1 5", "f 4 5 8"]) + "\n"


def test_scene_gbuffer_exr_shadow_of_a_mesh(tmp_path: Path) -> None:
    """A scene file: a cube over flat ground; the EXR's shadow channel (read back, world points
    rebuilt from its view matrix) against the float64 twin's shadow rays to the cube."""
    from oclshade.meshes import TriangleMesh
    from oclshade.reference.mesh_shadows import shadow_mask

    (tmp_path / "cube.obj").write_text(CUBE)
    np.save(tmp_path / "d.npy", np.zeros((40, 40)))
    (tmp_path / "s.toml").write_text("""[terrain]
dem = "d.npy"
cellsize = 10
[camera]
position = [330, -230, 160]
look_at = [200, -200, 0]
size = [64, 48]
[sun]
azimuth = 150
elevation = 30
[[mesh]]
file = "cube.obj"
translate = [180, -200, 20]
scale = 30
""")
    exr = tmp_path / "g.exr"
    assert main(["render", str(tmp_path / "s.toml"), str(tmp_path / "f.png"), "--gbuffer", str(exr), "--quiet"]) == 0
    ch, header = read(exr)
    hit = ch["position.w"] > 0.5
    pos = np.stack([ch["position.x"], ch["position.y"], ch["position.z"], np.ones(hit.shape)], -1)
    world = (pos @ np.linalg.inv(header["view"]).T)[..., :3]
    eye = np.linalg.inv(header["view"])[:3, 3]
    v = np.array([[float(x) for x in line.split()[1:]] for line in CUBE.splitlines() if line.startswith("v ")])
    f = [[int(x) - 1 for x in line.split()[1:]] for line in CUBE.splitlines() if line.startswith("f ")]
    cube = TriangleMesh(30.0 * v + [180, -200, 20], f)
    band = 16 * 2.0 ** -24 * np.linalg.norm(world - eye, axis=-1)
    want, _ = shadow_mask([cube], Sun(150, 30), world, hit, eye - world, band)
    got = ch["shadow"] == 1.0
    edge = np.zeros(hit.shape, bool)
    for m in (want, hit):
        pad = np.pad(m, 1, mode="edge")
        windows = [pad[i:i + hit.shape[0], j:j + hit.shape[1]] for i in range(3) for j in range(3)]
        edge |= np.any(windows, axis=0) & ~np.all(windows, axis=0)
    assert want.sum() > 50 and not got[~hit].any()
    assert not ((got != want) & hit & ~edge).any()
