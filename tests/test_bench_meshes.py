"""The ``meshes`` cases of ``oclshade bench`` (oclshade/bench/suite.py) on the tiny sizes: the
generated sheet is what the work model says, it is in the frame and shades it, and the two
shadow methods timed side by side answer the same question."""
from __future__ import annotations

import numpy as np
import pytest

from oclshade.bench.suite import MESH_QUADS, SIZES, SPECS, Workload, bench_mesh
from oclshade.camera import map_bounds
from oclshade.runtime import get_runtime


@pytest.fixture(scope="module")
def outputs() -> dict[str, list[np.ndarray]]:
    w = Workload(get_runtime(0), SIZES["tiny"])
    out = {}
    for spec in SPECS:
        if spec.family == "meshes":
            case = spec.prepare(w)
            case.run()
            out[spec.id] = case.outputs()
            assert case.nbytes > 0 and case.flops > 0 and case.items == w.pixels
    return out


def test_the_sheet_lies_over_the_middle_of_the_map() -> None:
    from oclshade.bench.suite import terrain
    hm = terrain(48)
    mesh = bench_mesh(hm)
    assert len(mesh.faces) == 2 * MESH_QUADS ** 2 and len(mesh.vertices) == (MESH_QUADS + 1) ** 2
    lo, hi = map_bounds(hm)
    mlo, mhi = mesh.bounds
    assert np.all(mlo[:2] >= lo[:2] + 0.24 * (hi - lo)[:2]) and np.all(mhi[:2] <= hi[:2] - 0.24 * (hi - lo)[:2])
    assert lo[2] < mlo[2] and mhi[2] < hi[2]


def test_mesh_cases_see_the_sheet_and_its_shadow(outputs) -> None:
    ids = outputs["meshes/cast"][-1]
    assert (ids == -1).sum() > 0.05 * ids.size and set(np.unique(ids)) <= {-1, 0}
    rays = outputs["meshes/shadow_rays"][0] > 0
    volumes = outputs["meshes/shadow_volumes"][0] > 0
    assert rays.sum() > 0.01 * rays.size
    # the two methods agree off the shadow's boundary (pixels with a neighbour of the other
    # kind in either answer: float32 rays and crossing counts may round apart there)
    edge = np.zeros_like(rays)
    for m in (rays, volumes):
        p = np.pad(m, 1, mode="edge")
        edge |= (p[1:-1, 1:-1] != p[:-2, 1:-1]) | (p[1:-1, 1:-1] != p[2:, 1:-1]) | \
            (p[1:-1, 1:-1] != p[1:-1, :-2]) | (p[1:-1, 1:-1] != p[1:-1, 2:])
    assert np.array_equal(rays[~edge], volumes[~edge])
