"""A bounding volume hierarchy over a mesh's triangles, built on the host (numpy) and
flattened for kernels/mesh.cl.

>>> bvh = build_bvh(triangles)      # float32 (M, 3, 3): the vertices of each triangle
>>> bvh.lo, bvh.hi, bvh.info, bvh.order

Build: top-down, each node split where the surface area heuristic is lowest over every
prefix of its triangles sorted by centroid along x, y and z (a full sweep, not binned:
exact); nodes of at most ``leaf_size`` triangles are leaves.  Nodes of at most
:data:`SAH_MIN` triangles, and every node below depth :data:`SAH_DEPTH`, are split at the
median along the longest centroid extent instead: numpy's per-call cost made the sweep of
every small node the bulk of the build time, and the median bounds the tree's depth to
within MAX_DEPTH (the kernel's traversal stack).

Layout (depth-first, preorder): node ``i`` has bounds ``lo[i]``, ``hi[i]`` (float32,
exact min / max of its triangles' float32 vertices, so a box always holds its triangles)
and ``info[i] = (a, count)``: a leaf (count > 0) holds the triangles in slots a .. a +
count - 1; an interior node (count == 0) has children i + 1 and a.  ``order[slot]`` is
the triangle (face index) in that slot.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: the traversal stack of kernels/mesh.cl (OCLS_STACK)
MAX_DEPTH = 64
#: depth after which nodes are split at the median (bounds the tree's depth)
SAH_DEPTH = 32
#: nodes of at most this many triangles are split at the median
SAH_MIN = 64


@dataclass(frozen=True)
class BVH:
    lo: np.ndarray        # float32 (N, 3)
    hi: np.ndarray        # float32 (N, 3)
    info: np.ndarray      # int32 (N, 2)
    order: np.ndarray     # int32 (M,)
    depth: int


def _area(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    e = np.maximum(hi - lo, 0.0)
    return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0]


def _sweep(idx: np.ndarray, centroid: np.ndarray, tlo: np.ndarray, thi: np.ndarray) -> tuple[float, np.ndarray]:
    """(cut, idx reordered): the SAH-cheapest split over the three centroid orders; the first
    ``cut`` triangles of the reordered idx go left."""
    best, best_order, best_cut = np.inf, None, 0
    n = len(idx)
    for axis in range(3):
        order = idx[np.argsort(centroid[idx, axis], kind="stable")]
        lo, hi = tlo[order], thi[order]
        left = _area(np.minimum.accumulate(lo), np.maximum.accumulate(hi))[:-1]
        right = _area(np.minimum.accumulate(lo[::-1])[::-1], np.maximum.accumulate(hi[::-1])[::-1])[1:]
        counts = np.arange(1, n)
        cost = left * counts + right * (n - counts)
        k = int(np.argmin(cost))
        if cost[k] < best:
            best, best_order, best_cut = float(cost[k]), order, k + 1
    return best_cut, best_order


def build_bvh(triangles: np.ndarray, leaf_size: int = 4) -> BVH:
    """The BVH of float32 triangles (M, 3, 3) (module doc)."""
    tri = np.asarray(triangles, np.float32)
    if tri.ndim != 3 or tri.shape[1:] != (3, 3) or len(tri) == 0:
        raise ValueError(f"triangles must be float32 of shape (M, 3, 3) with M >= 1, got {tri.shape}")
    if not 1 <= leaf_size <= 16:
        raise ValueError(f"leaf_size must be in 1..16 triangles, got {leaf_size!r}")
    tlo, thi = tri.min(axis=1), tri.max(axis=1)
    centroid = tri.astype(np.float64).mean(axis=1)
    lo, hi, info, slots = [], [], [], []
    deepest = placed = 0

    def node(idx: np.ndarray, depth: int) -> None:
        nonlocal deepest, placed
        deepest = max(deepest, depth)
        i = len(info)
        lo.append(tlo[idx].min(axis=0))
        hi.append(thi[idx].max(axis=0))
        if len(idx) <= leaf_size:
            info.append((placed, len(idx)))
            slots.append(idx)
            placed += len(idx)
            return
        info.append(None)
        if depth < SAH_DEPTH and len(idx) > SAH_MIN:
            cut, idx = _sweep(idx, centroid, tlo, thi)
        else:
            axis = int(np.argmax(np.ptp(centroid[idx], axis=0)))
            idx, cut = idx[np.argsort(centroid[idx, axis], kind="stable")], len(idx) // 2
        node(idx[:cut], depth + 1)
        info[i] = (len(info), 0)
        node(idx[cut:], depth + 1)

    node(np.arange(len(tri)), 1)
    if deepest > MAX_DEPTH:                                 # pragma: no cover - bounded by SAH_DEPTH
        raise RuntimeError(f"BVH depth {deepest} exceeds the traversal stack {MAX_DEPTH}")
    return BVH(np.array(lo, np.float32), np.array(hi, np.float32), np.array(info, np.int32),
               np.concatenate(slots).astype(np.int32), deepest)
