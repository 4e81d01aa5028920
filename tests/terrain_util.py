"""Shared checks of rendered G-buffers against the float64 reference caster (tests only)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from oclshade.camera import Camera
from oclshade.gbuffer import GBuffer
from oclshade.reference import ReferenceTerrain, cast_terrain
from oclshade.terrain import Heightfield

POSITION_TOL = 1e-3        # cells: the must-show bound on hit positions


@dataclass
class Agreement:
    pixels: int
    hit_mismatch: int          # hit in one, empty in the other
    off_silhouette: int        # ... of those, not on a silhouette pixel of the reference
    cell_mismatch: int         # both hit, not in the reference's patch within POSITION_TOL
    uv_error: float            # max |uv - uv_ref| (cells) over pixels hitting the reference's patch
    depth_error: float         # max relative depth error over agreeing pixels
    same_cell_fraction: float  # pixels that agree (both empty, or both hit within POSITION_TOL)

    def assert_exact(self, what: str = "") -> None:
        assert self.off_silhouette == 0, f"{what}: {self.off_silhouette} hit/miss disagreements off the silhouette"
        bad = self.hit_mismatch + self.cell_mismatch
        assert bad <= max(2, self.pixels // 1000), f"{what}: {bad} of {self.pixels} pixels disagree"


def silhouette(hit: np.ndarray) -> np.ndarray:
    """Pixels whose 3x3 neighbourhood holds both hit and empty pixels (of the reference)."""
    pad = np.pad(hit, 1, mode="edge")
    rows, cols = hit.shape
    windows = [pad[i:i + rows, j:j + cols] for i in range(3) for j in range(3)]
    return np.any(windows, axis=0) & ~np.all(windows, axis=0)


def agreement(gbuf: GBuffer, ref: ReferenceTerrain) -> Agreement:
    shape = gbuf.shape
    hit, ref_hit = gbuf.hit, ref.hit.reshape(shape)
    mismatch = hit != ref_hit
    both = hit & ref_hit
    uv, ref_uv = gbuf.uv[both].astype(np.float64), ref.uv.reshape(shape + (2,))[both]
    ref_cell = ref.cell.reshape(shape + (2,))[both][:, ::-1]          # (col, row) like uv
    uv_err = np.abs(uv - ref_uv).max(axis=1) if uv.size else np.zeros(0)
    in_patch = np.all((uv >= ref_cell) & (uv <= ref_cell + 1), axis=1)
    close = uv_err <= POSITION_TOL
    depth = gbuf.depth[both].astype(np.float64)
    ref_depth = ref.depth.reshape(shape)[both]
    rel = np.abs(depth - ref_depth) / np.maximum(ref_depth, 1e-300)
    agree = int((~hit & ~ref_hit).sum() + (in_patch & close).sum())
    return Agreement(
        pixels=hit.size,
        hit_mismatch=int(mismatch.sum()),
        off_silhouette=int((mismatch & ~silhouette(ref_hit)).sum()),
        cell_mismatch=int((~(in_patch & close)).sum()),
        uv_error=float(uv_err[in_patch].max()) if in_patch.any() else 0.0,
        depth_error=float(rel[in_patch & close].max()) if (in_patch & close).any() else 0.0,
        same_cell_fraction=agree / hit.size,
    )


def compare(field: Heightfield, camera: Camera, renderer, method: str = "bisect") -> Agreement:
    return agreement(renderer.render(camera, method), cast_terrain(field, camera))
