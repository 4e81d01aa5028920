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
#: a camera's largest width or height in pixels
MAX_SIDE = 1 << 15


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
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or not 1 <= v <= MAX_SIDE:
                raise ValueError(f"{name} must be an integer pixel count in 1..{MAX_SIDE}, got {v!r}")
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


#: frame_heightmap's default: at most this fraction of the map may leave the frame so that the
#: map fills more of it
DEFAULT_CROP = 0.2
#: the camera stops moving in once the map covers this fraction of the frame
FULL = 0.98


def _block_boxes(hm: Heightmap, blocks: int = 128) -> np.ndarray:
    """World-space corners (n, 3) of boxes that hold the map's surface: the samples cut into at
    most ``blocks`` x ``blocks`` blocks of k x k, each box spanning its block and the next row
    and column of samples (so the patches between blocks too) and the height range of the
    2 x 2 blocks it touches; blocks without a finite sample are left out."""
    rows, cols = hm.shape
    k = max(1, math.ceil(max(rows, cols) / blocks))
    nr, nc = -(-rows // k), -(-cols // k)
    pad = np.full((nr * k, nc * k), np.nan)
    pad[:rows, :cols] = hm.heights
    blocks4 = pad.reshape(nr, k, nc, k)
    hi = np.pad(np.fmax.reduce(np.fmax.reduce(blocks4, axis=3), axis=1), ((0, 1), (0, 1)), constant_values=np.nan)
    lo = np.pad(np.fmin.reduce(np.fmin.reduce(blocks4, axis=3), axis=1), ((0, 1), (0, 1)), constant_values=np.nan)
    zmax = np.fmax(np.fmax(hi[:-1, :-1], hi[1:, :-1]), np.fmax(hi[:-1, 1:], hi[1:, 1:]))   # fmax: NaN = none
    zmin = np.fmin(np.fmin(lo[:-1, :-1], lo[1:, :-1]), np.fmin(lo[:-1, 1:], lo[1:, 1:]))
    r, c = np.nonzero(np.isfinite(hi[:-1, :-1]))
    zmin, zmax = zmin[r, c], zmax[r, c]
    i0, j0 = r * k, c * k
    i1, j1 = np.minimum(i0 + k, rows - 1), np.minimum(j0 + k, cols - 1)
    return np.concatenate([np.stack([j * hm.dx, -i * hm.dy, z], -1) for i in (i0, i1) for j in (j0, j1)
                           for z in (zmin, zmax)])


def _samples(hm: Heightmap, count: int = 160) -> np.ndarray:
    """World-space points (n, 3) of the finite samples on a lattice of at most count x count."""
    rows, cols = hm.shape
    k = max(1, math.ceil(max(rows, cols) / count))
    i, j = np.mgrid[0:rows:k, 0:cols:k]
    z = hm.heights[i, j]
    ok = np.isfinite(z)
    return np.stack([j[ok] * hm.dx, -i[ok] * hm.dy, z[ok]], -1)


def _ndc(view: np.ndarray, scale: tuple[float, float], perspective: bool) -> np.ndarray:
    """Normalised image coordinates (n, 2) of view-space points (x right, y up, depth); points
    not in front of a pinhole get +inf."""
    if not perspective:
        return view[:, :2] / np.array(scale)
    front = view[:, 2:3] > 0.0
    return np.where(front, view[:, :2] / (np.array(scale) * np.where(front, view[:, 2:3], 1.0)), np.inf)


def _framing(view: np.ndarray, scale: tuple[float, float], perspective: bool, bins: tuple[int, int]
             ) -> tuple[float, float]:
    """(fraction of the frame covered, fraction of the points in it) for view-space points (n, 3)
    of the map's samples: the frame cut into ``bins`` (columns, rows), a bin covered when a
    point falls in it (the lattice is dense against the bins wherever most of the map is in
    the frame; holes in the map stay uncovered)."""
    ndc = _ndc(view, scale, perspective)
    inside = (np.abs(ndc) <= 1.0).all(axis=1)
    if not inside.any():
        return 0.0, 0.0
    cell = np.minimum(((ndc[inside] + 1.0) * 0.5 * np.array(bins)).astype(np.int64), np.array(bins) - 1)
    hit = np.zeros(bins[0] * bins[1], bool)
    hit[cell[:, 1] * bins[0] + cell[:, 0]] = True
    return float(hit.mean()), float(inside.mean())


def _vertical(top: float, bottom: float) -> float:
    """The camera's offset along its up axis: ``top`` puts the map's top at the frame's top,
    ``bottom`` its bottom at the frame's bottom; centred while the map fits, else its top held."""
    return 0.5 * (top + bottom) if top <= bottom else top


def _last_before(stop, steps: int = 32, refine: int = 20) -> float:
    """The largest t in [0, 1] before ``stop(t)`` first holds (scanning ``steps`` steps, then
    bisecting); 0 if stop(0), 1 if never."""
    ts = np.linspace(0.0, 1.0, steps + 1)
    k = next((k for k, t in enumerate(ts) if stop(t)), None)
    if k is None:
        return 1.0
    if k == 0:
        return 0.0
    lo, hi = ts[k - 1], ts[k]
    for _ in range(refine):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if stop(mid) else (mid, hi)
    return float(lo)


def frame_heightmap(hm: Heightmap, width: int = 1280, height: int = 720, azimuth: float = 200.0,
                    elevation: float = 35.0, fov: float = 45.0, projection: str = "perspective",
                    margin: float = 1.02, crop: float = DEFAULT_CROP) -> Camera:
    """A camera on the map from the compass direction ``azimuth`` (degrees clockwise from north:
    200 = from the south-south-west, looking north-north-east), ``elevation`` degrees above the
    horizon (the view's pitch), that fills the frame with the map.

    Fit: the view direction fixed, the camera placed (across the view as well as along it) where
    the whole map just fits, centred, with ``margin`` (1.02: 2 % spare on the tight side): the
    boxes of :func:`_block_boxes` inside the frustum.  Fill: an oblique map is a trapezoid that
    leaves the frame's corners empty, so the camera moves in along its axis (an orthographic
    one zooms), the map centred across and, once what is in the frame across is taller than
    the frame, its top held at the frame's top (its near part leaves the frame at the bottom), until the map covers
    :data:`FULL` of the frame or a fraction ``crop`` of the map has left it, whichever comes
    first (both measured with the map's samples on a lattice, :func:`_framing`); a pinhole
    does not move in below 0.02 radius above the map's highest point (lower, it would look into
    the terrain or at the map's missing sides), so low views fill less.  ``crop=0``: the whole
    map, centred.  Near and far enclose what the camera sees."""
    if not -90.0 <= float(elevation) <= 90.0:
        raise ValueError(f"elevation must be in [-90, 90] degrees, got {elevation!r}")
    if not 0.0 <= float(crop) < 1.0:
        raise ValueError(f"crop must be in [0, 1) (the fraction of the map that may leave the frame), got {crop!r}")
    margin = positive_finite("margin", margin)
    if projection not in PROJECTIONS:
        raise ValueError(f"projection must be one of {', '.join(PROJECTIONS)}, got {projection!r}")
    lo, hi = map_bounds(hm)
    centre = 0.5 * (lo + hi)
    radius = max(0.5 * float(np.linalg.norm(hi - lo)), min(hm.dx, hm.dy))
    az, el = math.radians(float(azimuth)), math.radians(float(elevation))
    towards_camera = np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), math.sin(el)])
    probe = Camera(centre + radius * towards_camera, centre, width, height, fov=fov)
    rot = probe.rotation                                 # rows: right, up, back
    flip = np.array([1.0, 1.0, -1.0])                    # view coordinates: right, up, depth
    boxes = _block_boxes(hm)
    if len(boxes) == 0:                                  # no finite sample: the bounding box
        boxes = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    a, b, f = ((boxes - centre) @ rot.T * flip).T        # right, up, forward of the centre
    sx, sy = probe.scale
    perspective = projection == "perspective"
    if perspective:     # every box corner inside the frustum: |a - X| <= tx (D + f), |b - Y| <= ty (D + f)
        tx, ty = sx / margin, sy / margin
        ap, am = np.max(a - tx * f), np.max(-a - tx * f)
        bp, bm = np.max(b - ty * f), np.max(-b - ty * f)
        x0, y0 = 0.5 * (ap - am), 0.5 * (bp - bm)
        distance = max((ap + am) / (2.0 * tx), (bp + bm) / (2.0 * ty), float(np.max(-f)) + 0.05 * radius)
        scale = (sx, sy)
    else:
        x0, y0 = 0.5 * (a.max() + a.min()), 0.5 * (b.max() + b.min())
        half_h = max(0.5 * (b.max() - b.min()), 0.5 * (a.max() - a.min()) * height / width, 1e-9 * radius) * margin
        distance = float(np.max(-f)) + radius
        scale = (half_h * width / height, half_h)
    samples = _samples(hm)
    sa, sb, sf = ((samples - centre) @ rot.T * flip).T  # the surface's own points place the camera
    bins = (32, max(4, round(32 * height / width)))
    if perspective:     # t: the fraction of the way to the centre plane (0.95 of it at most)
        def place(t: float) -> tuple[np.ndarray, tuple[float, float]]:
            d = distance * (1.0 - 0.95 * t)
            x = 0.5 * (np.max(sa - tx * (d + sf)) - np.max(-sa - tx * (d + sf)))
            across = np.abs(sa - x) <= tx * (d + sf)     # the vertical fit of what is in the frame across
            vb, vf = (sb[across], sf[across]) if across.any() else (sb, sf)
            top, bottom = np.max(vb - ty * (d + vf)), -np.max(-vb - ty * (d + vf))
            return centre + rot.T @ np.array([x, _vertical(top, bottom), d]), scale
    else:               # t: zoom up to 64
        def place(t: float) -> tuple[np.ndarray, tuple[float, float]]:
            sc = (scale[0] * 64.0 ** -t, scale[1] * 64.0 ** -t)
            x = 0.5 * (sa.max() + sa.min())
            across = np.abs(sa - x) <= sc[0] / margin
            vb = sb[across] if across.any() else sb
            y = _vertical(vb.max() - sc[1] / margin, vb.min() + sc[1] / margin)
            return centre + rot.T @ np.array([x, y, distance]), sc

    def stop(t: float) -> bool:
        position, sc = place(t)
        if perspective and position[2] < hi[2] + 0.02 * radius:
            return True
        covered, kept = _framing((samples - position) @ rot.T * flip, sc, perspective, bins)
        return kept < 1.0 - crop or covered >= FULL

    if crop > 0.0 and len(samples):
        position, scale = place(_last_before(stop))
    else:
        position = centre + rot.T @ np.array([x0, y0, distance])
    depth = (boxes - position) @ -rot[2]
    far = 1.02 * float(depth.max()) + 1e-6 * radius
    near = 0.9 * float(depth.min()) if depth.min() > 0.0 else 1e-4 * far
    return Camera(position, position - rot[2] * radius, width, height, fov=fov,
                  near=max(near, 1e-4 * far), far=far, projection=projection, ortho_height=2.0 * scale[1])
