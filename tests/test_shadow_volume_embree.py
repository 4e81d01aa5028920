"""Shadow volumes against Embree (embreex: its own BVH, float32 occlusion rays) on a shared
mesh: the bunny over a ground quad, G-buffer by the device's MeshCaster."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from oclshade.camera import Camera
from oclshade.meshes import MeshCaster, MeshShadows, PointLight, TriangleMesh, load_mesh
from oclshade.reference.mesh_shadows import world_points
from oclshade.sun import Sun

BUNNY = Path("/work/shared/data/meshes/bunny_oded.obj")


def near_boundary(mask: np.ndarray) -> np.ndarray:
    """Pixels within 1 px (3 x 3) of a change of ``mask``."""
    pad = np.pad(mask, 1, mode="edge")
    rows, cols = mask.shape
    windows = [pad[i:i + rows, j:j + cols] for i in range(3) for j in range(3)]
    return np.any(windows, axis=0) & ~np.all(windows, axis=0)


@pytest.mark.skipif(not BUNNY.is_file(), reason="needs /work/shared/data/meshes/bunny_oded.obj")
@pytest.mark.parametrize("light", [Sun(120, 35), PointLight([8.0, -6.0, 14.0])])
def test_embree_agrees_on_the_bunny(light):
    rtcore = pytest.importorskip("embreex.rtcore_scene")
    construction = pytest.importorskip("embreex.mesh_construction")
    bunny = load_mesh(BUNNY)
    lo, hi = bunny.bounds
    bunny = bunny.placed(translate=(0.0, 0.0, -10.0 * lo[2] + 1.0), scale=10.0)
    ground = TriangleMesh([[-40, -40, 0], [40, -40, 0], [40, 40, 0], [-40, 40, 0]], [[0, 1, 2], [0, 2, 3]],
                          cast_shadows=False, name="ground")
    camera = Camera((18, -22, 14), (0, 0, 2), 128, 96, fov=45, near=0.5, far=200)
    caster = MeshCaster([bunny, ground])
    gbuf = caster.cast(camera)[0]
    got = MeshShadows([bunny], caster.runtime).mask_to_host(camera, gbuf, light)
    host = gbuf.to_host()
    hit = host.hit
    p = world_points(camera, host.position)[hit]
    to = light.position - p if isinstance(light, PointLight) else np.broadcast_to(light.vector(), p.shape)
    length = np.linalg.norm(to, axis=1)
    unit = to / length[:, None]
    scene = rtcore.EmbreeScene()
    construction.TriangleMesh(scene, bunny.vertices[bunny.faces].astype(np.float32))
    eps = 1e-4 * float(np.linalg.norm(hi - lo) * 10.0)
    dists = (length - eps if isinstance(light, PointLight) else np.full(len(p), 1e30)).astype(np.float32)
    res = scene.run((p + eps * unit).astype(np.float32), unit.astype(np.float32), dists=dists, output=1)
    want = np.zeros(hit.shape, bool)
    want[hit] = res["geomID"] >= 0
    assert 0.02 * hit.sum() < want.sum() < 0.9 * hit.sum()
    apart = near_boundary(want) | near_boundary(hit)
    differ = (got != want) & hit & ~apart
    assert differ.sum() <= 0.001 * hit.sum(), f"{int(differ.sum())} of {int(hit.sum())} hit pixels differ"
