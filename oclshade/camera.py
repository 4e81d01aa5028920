"""Cameras: pinhole (perspective) and orthographic, in the frames of :mod:`oclshade.gbuffer`.

World space: x east, y north, z up (metres); heightmap sample (i, j) sits at
``(j*dx, -i*dy, height)``.  View space: right-handed, camera at the origin
looking down -Z, +Y up.  ``view`` and ``projection`` are numpy 4x4 matrices on
column vectors (OpenGL-style clip space).

Pixel rays (what the terrain kernel and the float64 reference both use):
pixel (row r, col c) has NDC ``x = (2c+1)/W - 1``, ``y = 1 - (2r+1)/H``;

* pinhole: origin 0, direction ``(x * sx, y * sy, -1)`` with
  ``sy = tan(fov_y/2)``, ``sx = sy * W/H``;
* orthographic: origin ``(x * sx, y * sy, 0)``, direction ``(0, 0, -1)`` with
  ``sx, sy`` the half extents of the view volume;

and the ray parameter ``t`` is the linear depth ``-z_view``, so the visible
segment is ``near <= t <= far`` (the paper 004 "voxel").
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .heightmap import Heightmap, positive_finite

PROJECTIONS = ("perspective", "orthographic")


def _vec3(name: str, value: object) -> np.ndarray:
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be 3 finite numbers (x east, y north, z up), got {value!r}")
    return v


@dataclass(frozen=True)
class Camera:
    """A pinhole (``projection="perspective"``, vertical field of view ``fov`` in degrees)
    or orthographic camera (``ortho_height``: the view volume's height in metres)."""

    position: np.ndarray
    look_at: np.ndarray
    width: int
    height: int
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    fov: float = 45.0
    near: float = 1.0
    far: float = 1e6
    projection: str = "perspective"
    ortho_height: float = 1.0

    def __post_init__(self) -> None:
        for name in ("position", "look_at", "up"):
            object.__setattr__(self, name, _vec3(name, getattr(self, name)))
        for name in ("width", "height"):
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or not 1 <= v <= 1 << 15:
                raise ValueError(f"{name} must be an integer pixel count in 1..32768, got {v!r}")
            object.__setattr__(self, name, int(v))
        if self.projection not in PROJECTIONS:
            raise ValueError(f"projection must be one of {', '.join(PROJECTIONS)}, got {self.projection!r}")
        if not (0.0 < float(self.fov) < 180.0):
            raise ValueError(f"fov must be in (0, 180) degrees (vertical field of view), got {self.fov!r}")
        positive_finite("ortho_height", self.ortho_height)
        near = float(self.near)
        far = float(self.far)
        if self.projection == "perspective":
            positive_finite("near", near)
        elif not math.isfinite(near) or near < 0.0:
            raise ValueError(f"near must be >= 0 for an orthographic camera, got {self.near!r}")
        if not math.isfinite(far) or far <= near:
            raise ValueError(f"far must be finite and > near ({near}), got {self.far!r}")
        if np.linalg.norm(self.look_at - self.position) == 0.0:
            raise ValueError("look_at must differ from position")
        if np.linalg.norm(self.up) == 0.0:
            raise ValueError("up must be a non-zero vector")

    # --- frames --------------------------------------------------------------------
    @property
    def rotation(self) -> np.ndarray:
        """3x3 world-to-view rotation: rows right, up, back (-forward).

        When ``up`` is parallel to the viewing direction (looking straight
        down with up = +z), north (+y) is used instead, then east."""
        fwd = self.look_at - self.position
        fwd = fwd / np.linalg.norm(fwd)
        for up in (self.up, np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0])):
            right = np.cross(fwd, up / np.linalg.norm(up))
            if np.linalg.norm(right) > 1e-9:
                break
        right /= np.linalg.norm(right)
        true_up = np.cross(right, fwd)
        return np.stack([right, true_up, -fwd])

    @property
    def view(self) -> np.ndarray:
        """4x4 world -> view matrix."""
        m = np.eye(4)
        rot = self.rotation
        m[:3, :3] = rot
        m[:3, 3] = -rot @ self.position
        return m

    @property
    def scale(self) -> tuple[float, float]:
        """(sx, sy): the pixel-ray slopes (perspective) or half extents (orthographic), see the module doc."""
        aspect = self.width / self.height
        if self.projection == "perspective":
            sy = math.tan(math.radians(float(self.fov)) / 2.0)
        else:
            sy = float(self.ortho_height) / 2.0
        return sy * aspect, sy

    @property
    def projection_matrix(self) -> np.ndarray:
        """4x4 view -> clip matrix (OpenGL conventions, NDC z in [-1, 1])."""
        sx, sy = self.scale
        n, f = float(self.near), float(self.far)
        m = np.zeros((4, 4))
        if self.projection == "perspective":
            m[0, 0], m[1, 1] = 1.0 / sx, 1.0 / sy
            m[2, 2], m[2, 3] = -(f + n) / (f - n), -2.0 * f * n / (f - n)
            m[3, 2] = -1.0
        else:
            m[0, 0], m[1, 1] = 1.0 / sx, 1.0 / sy
            m[2, 2], m[2, 3] = -2.0 / (f - n), -(f + n) / (f - n)
            m[3, 3] = 1.0
        return m

    def view_rays(self, rows: np.ndarray | None = None, cols: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
        """View-space (origins, directions), float64 arrays (..., 3), of the given pixels
        (default: every pixel, shape (height, width, 3)); ``t`` along them is the depth."""
        if rows is None or cols is None:
            rows, cols = np.mgrid[0:self.height, 0:self.width]
        rows = np.asarray(rows, dtype=np.float64)
        cols = np.asarray(cols, dtype=np.float64)
        x = (2.0 * cols + 1.0) / self.width - 1.0
        y = 1.0 - (2.0 * rows + 1.0) / self.height
        sx, sy = self.scale
        zero, one = np.zeros_like(x), np.ones_like(x)
        if self.projection == "perspective":
            return np.stack([zero, zero, zero], -1), np.stack([x * sx, y * sy, -one], -1)
        return np.stack([x * sx, y * sy, zero], -1), np.stack([zero, zero, -one], -1)


def heightmap_from_world(hm: Heightmap, centre: tuple[int, int] = (0, 0)) -> np.ndarray:
    """4x4 affine map world -> heightmap coordinates (u - centre_col, v - centre_row, z - offset)."""
    m = np.zeros((4, 4))
    m[0, 0] = 1.0 / hm.dx
    m[1, 1] = -1.0 / hm.dy
    m[2, 2] = 1.0
    m[0, 3] = -float(centre[1])
    m[1, 3] = -float(centre[0])
    m[2, 3] = -hm.offset
    m[3, 3] = 1.0
    return m


def map_bounds(hm: Heightmap) -> tuple[np.ndarray, np.ndarray]:
    """World-space (lower, upper) corners of the map's bounding box (finite heights)."""
    rows, cols = hm.shape
    finite = hm.heights[np.isfinite(hm.heights)]
    lo_z, hi_z = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 0.0)
    return (np.array([0.0, -(rows - 1) * hm.dy, lo_z]), np.array([(cols - 1) * hm.dx, 0.0, hi_z]))


def frame_heightmap(hm: Heightmap, width: int = 1280, height: int = 720, azimuth: float = 200.0,
                    elevation: float = 35.0, fov: float = 45.0, projection: str = "perspective",
                    margin: float = 1.05) -> Camera:
    """A camera that sees the whole map: looking at the centre of its bounding box from the
    compass direction ``azimuth`` (degrees clockwise from north: 200 = from the south-south-west,
    looking north-north-east), ``elevation`` degrees above the horizon, at the distance where the
    corners of the map's bounding box (times ``margin``) just fit in the view (at least 1.05 times
    the bounding sphere's radius away); near and far enclose the bounding sphere."""
    if not -90.0 <= float(elevation) <= 90.0:
        raise ValueError(f"elevation must be in [-90, 90] degrees, got {elevation!r}")
    lo, hi = map_bounds(hm)
    centre = 0.5 * (lo + hi)
    radius = max(0.5 * float(np.linalg.norm(hi - lo)), min(hm.dx, hm.dy))
    az, el = math.radians(float(azimuth)), math.radians(float(elevation))
    towards_camera = np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), math.sin(el)])
    probe = Camera(centre + radius * towards_camera, centre, width, height, fov=fov)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    local = (corners - centre) @ probe.rotation.T           # view axes, camera not yet placed
    sx, sy = probe.scale
    if projection == "perspective":     # every corner inside the frustum: |x| <= sx (D - z), |y| <= sy (D - z)
        distance = float(np.max(local[:, 2] + np.maximum(np.abs(local[:, 0]) / sx, np.abs(local[:, 1]) / sy)))
        distance = max(distance * float(margin), 1.05 * radius)
    else:
        distance = 2.0 * radius
    half_h = float(np.max(np.maximum(np.abs(local[:, 1]), np.abs(local[:, 0]) * height / width))) * float(margin)
    position = centre + distance * towards_camera
    return Camera(position, centre, width, height, fov=fov, near=max(distance - radius, 1e-3 * distance),
                  far=distance + radius, projection=projection,
                  ortho_height=2.0 * max(half_h, 1e-9 * radius))
