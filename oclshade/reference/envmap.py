"""Float64 twins of kernels/cubemap.h and kernels/envmap.cl: cube-map face selection, (s, t),
seam-continuous bilinear filtering, lat-long sampling and the two conversions.

Frames and tables (docs/reflections.md):

* **Cube-map frame** F: right-handed, +Y up (OpenEXR's direction frame; an environment
  map's own frame).  A cube map is ``faces[6, N, N, C]`` in the order +X, -X, +Y, -Y, +Z, -Z.
* **Face table** (the OpenGL major-axis rule, as paper 002 uses it): for a direction
  d = (x, y, z) the face is the axis of the largest |component| (ties: x before y before z)
  and its sign; with ma that |component|::

      face  sc    tc
      +X    -z    -y
      -X    +z    -y
      +Y    +x    +z
      -Y    +x    -z
      +Z    +x    -y
      -Z    -x    -y

  s = (sc / ma + 1) / 2 is the column coordinate (0 at the left edge of column 0), t = (tc /
  ma + 1) / 2 the row coordinate (0 at the top edge of row 0): texel (row i, col j) of an N x N
  face has its centre at s = (j + 0.5) / N, t = (i + 0.5) / N.
* **Seam-continuous bilinear filtering**: texel coordinates u = s N - 1/2, v = t N - 1/2,
  taps floor(u), floor(u) + 1 (and the same in v) with the usual weights.  A tap outside the
  face (index -1 or N) reads the texel of the neighbouring face nearest to the tap's centre
  direction (the direction of its centre on the face's plane, face selected by the rule
  above): exactly the texel across the seam, at the same place along it.  A tap outside on
  both axes (a cube corner) reads the mean of the face's corner texel and the two texels
  across its two seams (the three faces' texels at that corner).  The value is therefore
  continuous across seams: at a seam both faces blend the same two texels with weights 1/2.
* **Lat-long** (H rows x W columns): texel (r, c) has its centre at longitude
  lon = pi - 2 pi (c + 0.5) / W and latitude lat = pi/2 - pi (r + 0.5) / H, direction
  (sin lon cos lat, sin lat, cos lon cos lat) in F (OpenEXR's lat-long directions; its own
  pixel positions put the first and last column at lon = +pi and -pi exactly, ours at texel
  centres).  Bilinear filtering wraps in longitude and clamps rows at the poles.
"""
from __future__ import annotations

import numpy as np

FACE_NAMES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")


def face_st(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(face, s, t) of directions ``d`` (..., 3) by the major-axis rule (module doc)."""
    d = np.asarray(d, np.float64)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    ax, ay, az = np.abs(x), np.abs(y), np.abs(z)
    on_x = (ax >= ay) & (ax >= az)
    on_y = ~on_x & (ay >= az)
    face = np.where(on_x, np.where(x > 0, 0, 1), np.where(on_y, np.where(y > 0, 2, 3), np.where(z > 0, 4, 5)))
    ma = np.where(on_x, ax, np.where(on_y, ay, az))
    sc = np.choose(face, [-z, z, x, x, x, -x])
    tc = np.choose(face, [-y, -y, z, -z, -y, -y])
    with np.errstate(invalid="ignore", divide="ignore"):
        s = 0.5 * (sc / ma + 1.0)
        t = 0.5 * (tc / ma + 1.0)
    return face.astype(np.int64), s, t


def face_direction(face: np.ndarray, s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The direction (on the cube, not normalised) of (face, s, t); s, t may leave [0, 1]
    (the face's plane extended)."""
    face = np.asarray(face)
    sc, tc = 2.0 * np.asarray(s, np.float64) - 1.0, 2.0 * np.asarray(t, np.float64) - 1.0
    one = np.ones_like(sc)
    x = np.choose(face, [one, -one, sc, sc, sc, -sc])
    y = np.choose(face, [-tc, -tc, one, -one, -tc, -tc])
    z = np.choose(face, [-sc, sc, tc, -tc, one, -one])
    return np.stack([x, y, z], -1)


def texel_directions(n: int) -> np.ndarray:
    """Unit directions (6, n, n, 3) of the texel centres of an n x n cube map."""
    i, j = np.mgrid[0:n, 0:n]
    f = np.arange(6)[:, None, None]
    d = face_direction(f, (j[None] + 0.5) / n, (i[None] + 0.5) / n)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _tap(faces: np.ndarray, f: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Texel (i, j) of face f, with i or j one step outside the face resolved across the seam."""
    n = faces.shape[1]
    out_i, out_j = (i < 0) | (i >= n), (j < 0) | (j >= n)
    ci, cj = np.clip(i, 0, n - 1), np.clip(j, 0, n - 1)
    value = faces[f, ci, cj].astype(np.float64)
    for mask_fn in ("edge", "corner"):
        mask = (out_i ^ out_j) if mask_fn == "edge" else (out_i & out_j)
        if not mask.any():
            continue
        if mask_fn == "edge":
            value[mask] = _across(faces, f[mask], i[mask], j[mask])
        else:
            fm, im, jm = f[mask], i[mask], j[mask]
            value[mask] = (faces[fm, ci[mask], cj[mask]] + _across(faces, fm, im, cj[mask])
                           + _across(faces, fm, ci[mask], jm)) / 3.0
    return value


def _across(faces: np.ndarray, f: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """The texel across the seam from tap (i, j) of face f (one index outside the face): the
    nearest texel of the face its centre direction falls on."""
    n = faces.shape[1]
    g, s, t = face_st(face_direction(f, (j + 0.5) / n, (i + 0.5) / n))
    gi = np.clip(np.floor(t * n).astype(np.int64), 0, n - 1)
    gj = np.clip(np.floor(s * n).astype(np.int64), 0, n - 1)
    return faces[g, gi, gj].astype(np.float64)


def sample_cube(faces: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Seam-continuous bilinear sample (..., C) of a cube map ``faces`` (6, N, N, C) in the
    directions ``d`` (..., 3) (module doc)."""
    f, s, t = face_st(d)
    return sample_face(np.asarray(faces), f, s, t)


def sample_face(faces: np.ndarray, f: np.ndarray, s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Bilinear sample of face ``f`` at (s, t) with the seam rule (the face given, not chosen
    by the major axis: how a seam is read from either side)."""
    n = faces.shape[1]
    u, v = np.asarray(s) * n - 0.5, np.asarray(t) * n - 0.5
    j0, i0 = np.clip(np.floor(u), -1, n - 1).astype(np.int64), np.clip(np.floor(v), -1, n - 1).astype(np.int64)
    fu, fv = (u - j0)[..., None], (v - i0)[..., None]
    f = np.asarray(f, np.int64)
    c00, c01 = _tap(faces, f, i0, j0), _tap(faces, f, i0, j0 + 1)
    c10, c11 = _tap(faces, f, i0 + 1, j0), _tap(faces, f, i0 + 1, j0 + 1)
    return (c00 * (1 - fu) + c01 * fu) * (1 - fv) + (c10 * (1 - fu) + c11 * fu) * fv


def latlong_directions(height: int, width: int) -> np.ndarray:
    """Unit directions (height, width, 3) of the texel centres of a lat-long map (module doc)."""
    r, c = np.mgrid[0:height, 0:width]
    lon = np.pi - 2.0 * np.pi * (c + 0.5) / width
    lat = 0.5 * np.pi - np.pi * (r + 0.5) / height
    return np.stack([np.sin(lon) * np.cos(lat), np.sin(lat), np.cos(lon) * np.cos(lat)], -1)


def sample_latlong(image: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Bilinear sample (..., C) of a lat-long map (H, W, C) in the directions ``d`` (..., 3):
    wrapped in longitude, rows clamped at the poles."""
    image = np.asarray(image)
    h, w = image.shape[:2]
    d = np.asarray(d, np.float64)
    lon = np.arctan2(d[..., 0], d[..., 2])
    lat = np.arctan2(d[..., 1], np.hypot(d[..., 0], d[..., 2]))
    u = (np.pi - lon) / (2.0 * np.pi) * w - 0.5
    v = (0.5 * np.pi - lat) / np.pi * h - 0.5
    j0, i0 = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
    fu, fv = (u - j0)[..., None], (v - i0)[..., None]
    ja, jb = j0 % w, (j0 + 1) % w
    ia, ib = np.clip(i0, 0, h - 1), np.clip(i0 + 1, 0, h - 1)
    img = image.astype(np.float64)
    return (img[ia, ja] * (1 - fu) + img[ia, jb] * fu) * (1 - fv) + (img[ib, ja] * (1 - fu) + img[ib, jb] * fu) * fv


def latlong_to_cube(image: np.ndarray, n: int) -> np.ndarray:
    """An n x n cube map (6, n, n, C) sampled from a lat-long map at its texel centres."""
    return sample_latlong(image, texel_directions(n))


def cube_to_latlong(faces: np.ndarray, height: int, width: int) -> np.ndarray:
    """A lat-long map (height, width, C) sampled from a cube map at its texel centres."""
    return sample_cube(faces, latlong_directions(height, width))


def seam_jump(faces: np.ndarray, samples: int = 64) -> float:
    """The largest difference between the two faces' filtered values at the same points of
    the 12 seams (each seam sampled at ``samples`` points, each point read from both faces
    that share it, :func:`sample_face`); 0 for a filter continuous across seams."""
    faces = np.asarray(faces)
    k = (np.arange(samples) + 0.5) / samples
    edge0, edge1 = np.zeros_like(k), np.ones_like(k)
    worst = 0.0
    for f in range(6):
        for s, t in ((edge0, k), (edge1, k), (k, edge0), (k, edge1)):
            face = np.full(samples, f)
            here = sample_face(faces, face, s, t)
            g, s2, t2 = _across_seam(face_direction(face, s, t), f)
            worst = max(worst, float(np.max(np.abs(here - sample_face(faces, g, s2, t2)))))
    return worst


def _across_seam(d: np.ndarray, f: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(face, s, t) of directions d on a seam of face f, read on the other face of the seam
    (the axis of the largest component other than f's own)."""
    rows = np.arange(len(d))
    a = np.abs(d)
    a[:, f // 2] = -1.0
    other = np.argmax(a, axis=1)
    g = 2 * other + (d[rows, other] < 0)
    ma = np.abs(d[rows, other])
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    sc = np.choose(g, [-z, z, x, x, x, -x])
    tc = np.choose(g, [-y, -y, z, -z, -y, -y])
    return g, 0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0)


# --- reflections (kernels/reflect.cl) -----------------------------------------------------------

#: kernels/reflect.cl: OCLS_CONE_SAMPLES and the golden angle of its spiral
CONE_SAMPLES = 16
GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))


def reflect(u: np.ndarray, n: np.ndarray) -> np.ndarray:
    """R = U - 2 (N . U) N (paper 002), row-wise over (..., 3)."""
    return u - 2.0 * np.sum(n * u, -1, keepdims=True) * n


def schlick(f0: np.ndarray | float, cosine: np.ndarray) -> np.ndarray:
    """Schlick's Fresnel factor F0 + (1 - F0)(1 - cos)^5, cos clamped to [0, 1]."""
    return f0 + (1.0 - f0) * (1.0 - np.clip(cosine, 0.0, 1.0)) ** 5


def cone_directions(d: np.ndarray, cone: float) -> np.ndarray:
    """(..., CONE_SAMPLES, 3): the blur cone's directions around unit d (..., 3): d + rad_k
    (cos phi_k T + sin phi_k B), rad_k = cone sqrt((k + 0.5) / K), phi_k = k x golden angle,
    (T, B) the tangent frame of Duff et al. 2017 ("Building an orthonormal basis, revisited")."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    sgn = np.where(z >= 0.0, 1.0, -1.0)
    a = -1.0 / (sgn + z)
    b = x * y * a
    t1 = np.stack([1.0 + sgn * x * x * a, sgn * b, -sgn * x], -1)
    t2 = np.stack([b, sgn + y * y * a, -y], -1)
    k = np.arange(CONE_SAMPLES)
    rad = cone * np.sqrt((k + 0.5) / CONE_SAMPLES)
    phi = k * GOLDEN_ANGLE
    off = (rad * np.cos(phi))[:, None] * t1[..., None, :] + (rad * np.sin(phi))[:, None] * t2[..., None, :]
    return d[..., None, :] + off


def reflect_frame(position: np.ndarray, normal: np.ndarray, albedo: np.ndarray, objects: np.ndarray,
                  materials, camera, faces: np.ndarray, world_to_cube: np.ndarray, ssaa: int = 1,
                  intensity: float = 1.0, background: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(albedo compose reads (Hs, Ws, 4), reflection added in linear light (H, W, 3)) of a
    G-buffer (Hs = H ssaa rows of samples; ``objects`` index + 1 into ``materials``, 0 none)
    seen by ``camera`` (its size: the samples), as kernels/reflect.cl computes them:
    U from the eye, R = U - 2 (N.U) N in view space, to the world by the transpose of the
    view rotation, to the cube-map frame by ``world_to_cube``, filtered seam-continuously."""
    hs, ws = objects.shape
    _, d = camera.view_rays()
    p = position[..., :3].astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):           # empty samples: no direction, unused
        u = d / np.linalg.norm(d, axis=-1, keepdims=True) if camera.projection == "orthographic" else \
            p / np.linalg.norm(p, axis=-1, keepdims=True)
    n = normal[..., :3].astype(np.float64)
    r = reflect(u, n)
    to_cube = np.asarray(world_to_cube, float) @ camera.rotation.T           # view -> world -> cube
    rc = r @ to_cube.T
    out_albedo = albedo.astype(np.float64).copy()
    contrib = np.zeros((hs, ws, 3))
    for k, m in enumerate(materials):
        mask = objects == k + 1
        if not mask.any() or m.kind == "diffuse":
            continue
        cos = -np.sum(u[mask] * n[mask], -1)
        f = schlick(m.fresnel, cos) if m.kind == "glossy" else np.ones(mask.sum())
        tint = np.asarray(m.colour) if m.kind == "mirror" else np.ones(3)
        out_albedo[mask, :3] *= (1.0 - f)[:, None]
        if m.roughness > 0.0:
            dirs = rc[mask] / np.linalg.norm(rc[mask], axis=-1, keepdims=True)
            env = sample_cube(faces, cone_directions(dirs, m.cone)).mean(-2)
        else:
            env = sample_cube(faces, rc[mask])
        contrib[mask] = f[:, None] * tint * env
    if background:
        empty = position[..., 3] <= 0.5
        contrib[empty] = sample_cube(faces, d[empty] @ to_cube.T)
    acc = intensity * contrib.reshape(hs // ssaa, ssaa, ws // ssaa, ssaa, 3).mean(axis=(1, 3))
    return out_albedo, acc
