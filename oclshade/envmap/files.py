"""Environment-map files: images (EXR, Radiance HDR, PNG) in five layouts, to and from cube maps.

Layouts (docs/reflections.md has the pictures; F is the cube-map frame, +Y up):

==========  ===============  =================================================================
layout      image size       what it holds
==========  ===============  =================================================================
latlong     2N x N (W x H)   longitude across, latitude down (kernels/envmap.cl); OpenEXR's
                             ENVMAP_LATLONG directions: centre column F's +Z, a quarter from
                             the left +X
cube        N x 6N           OpenEXR's ENVMAP_CUBE: faces +X, -X, +Y, -Y, +Z, -Z top to
                             bottom, each as OpenEXR draws it (seen from inside, upright,
                             right-handed: the +X face has +Y up and +Z on the right)
hcross      4N x 3N          the usual unfolded cross, each face as its image in a
                             left-handed (DirectX / OpenGL texture) cube map, seen from inside:
                             row 1 = -X, +Z, +X, -Z; +Y above and -Y below +Z.  Its "+Z" is F's
                             -Z (the handedness flip), so its centre looks where a lat-long
                             map's edges do
vcross      3N x 4N          as hcross with -Z below -Y, turned 180 degrees
faces       six N x N files  the hcross's faces, one file each: a path with ``{face}``,
                             replaced by posx, negx, posy, negy, posz, negz
==========  ===============  =================================================================

A layout is taken from ``layout=``, else from an EXR's ``envmap`` header attribute, else
from the aspect ratio (2:1 latlong, 1:6 cube, 4:3 hcross, 3:4 vcross).

Images: ``.exr`` (float channels R, G, B, or the interleaved RGBA of OpenEXR's own
environment maps; half or float), ``.hdr`` / ``.pic`` (Radiance RGBE, :mod:`.hdr`), ``.png``
(sRGB, decoded to linear; Pillow reads a 16-bit RGB PNG at 8 bits, so it is 8-bit here).
Writing ``.png`` encodes linear values clamped to [0, 1] as 8-bit sRGB (lossy: use EXR or
HDR for radiance above 1).  Every file is written to a temporary name beside the target and
renamed into place.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import OpenEXR
from PIL import Image

from ..runtime import Runtime
from .cube import CubeMap, latlong_to_cube
from .hdr import read_hdr, write_hdr

LAYOUTS = ("latlong", "cube", "hcross", "vcross", "faces")
IMAGE_EXTENSIONS = (".exr", ".hdr", ".pic", ".png")
FACE_WORDS = ("posx", "negx", "posy", "negy", "posz", "negz")
#: OpenEXR's faces -> ours: the same face, mirrored left-right (sides) or top-bottom (+-Y)
_EXR_FLIP = ("lr", "lr", "tb", "tb", "lr", "lr")
#: a left-handed face set's face k -> our face and flip (its +-Z are our -+Z)
_LH_FACE = (0, 1, 2, 3, 5, 4)
_LH_FLIP = ("lr", "lr", "tb", "tb", "lr", "lr")
#: cross cells (row, col) of faces +X, -X, +Y, -Y, +Z, -Z in a left-handed face set's names
_HCROSS = ((1, 2), (1, 0), (0, 1), (2, 1), (1, 1), (1, 3))
_VCROSS = ((1, 2), (1, 0), (0, 1), (2, 1), (1, 1), (3, 1))


class EnvmapFileError(ValueError):
    """An environment-map file that cannot be read or written as asked; names the file."""


def _flip(face: np.ndarray, how: str) -> np.ndarray:
    return face[:, ::-1] if how == "lr" else face[::-1]


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """8-bit-style sRGB values in [0, 1] to linear light (IEC 61966-2-1)."""
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _linear_to_srgb(c: np.ndarray) -> np.ndarray:
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1.0 / 2.4) - 0.055)


def _extension(path: Path) -> str:
    ext = path.suffix.lower()
    if ext not in IMAGE_EXTENSIONS:
        raise EnvmapFileError(f"{path}: unknown image extension {path.suffix!r}; expected "
                              f"{', '.join(IMAGE_EXTENSIONS)}")
    return ext


def read_image(path: str | os.PathLike) -> tuple[np.ndarray, str | None]:
    """(float32 (rows, cols, 3) linear RGB, the EXR envmap layout or None) of an image file."""
    p = Path(path)
    ext = _extension(p)
    if not p.is_file():
        raise EnvmapFileError(f"{p}: no such file")
    try:
        if ext == ".exr":
            return _read_exr(p)
        if ext in (".hdr", ".pic"):
            return read_hdr(p), None
        return _read_png(p), None
    except (OSError, ValueError) as exc:
        if isinstance(exc, EnvmapFileError) or str(p) in str(exc):
            raise
        raise EnvmapFileError(f"{p}: {exc}") from None


def _read_exr(p: Path) -> tuple[np.ndarray, str | None]:
    with OpenEXR.File(str(p)) as exr:
        envmap = exr.header().get("envmap")
        channels = exr.channels()
        names = list(channels)
        rgb = next((np.array(channels[n].pixels, np.float32)[..., :3] for n in ("RGBA", "RGB") if n in channels),
                   None)
        if rgb is None and all(c in channels for c in "RGB"):
            rgb = np.stack([np.array(channels[c].pixels, np.float32) for c in "RGB"], -1)
    if rgb is None:
        raise EnvmapFileError(f"{p}: expected R, G, B channels, found {', '.join(names) or 'none'}")
    return rgb, {OpenEXR.ENVMAP_LATLONG: "latlong", OpenEXR.ENVMAP_CUBE: "cube"}.get(envmap)


def _read_png(p: Path) -> np.ndarray:
    with Image.open(p) as img:
        if img.mode.startswith("I;16") or img.mode == "I":
            raise EnvmapFileError(f"{p}: a 16-bit greyscale PNG is not an environment map; expected RGB")
        if img.mode not in ("RGB", "RGBA"):
            img = img.convert("RGBA" if "A" in img.mode else "RGB")
        arr = np.asarray(img)
    return srgb_to_linear(arr[..., :3].astype(np.float64) / 255.0).astype(np.float32)


def _write_image(path: Path, rgb: np.ndarray, envmap: str | None) -> None:
    ext = _extension(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=ext, dir=path.parent)
    os.close(fd)
    try:
        if ext == ".exr":
            header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
            if envmap is not None:
                header["envmap"] = {"latlong": OpenEXR.ENVMAP_LATLONG, "cube": OpenEXR.ENVMAP_CUBE}[envmap]
            with OpenEXR.File(header, {"RGB": np.ascontiguousarray(rgb, np.float32)}) as exr:
                exr.write(tmp)
        elif ext in (".hdr", ".pic"):
            write_hdr(tmp, np.maximum(rgb, 0.0))
        else:
            srgb = np.round(255.0 * _linear_to_srgb(np.asarray(rgb, np.float64))).astype(np.uint8)
            Image.fromarray(srgb, "RGB").save(tmp, format="PNG")
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _guess_layout(path: object, shape: tuple[int, ...]) -> str:
    h, w = shape[:2]
    for layout, (aw, ah) in (("latlong", (2, 1)), ("cube", (1, 6)), ("hcross", (4, 3)), ("vcross", (3, 4))):
        if w * ah == h * aw:
            return layout
    raise EnvmapFileError(f"{path}: cannot tell the layout of a {w}x{h} image (2:1 latlong, 1:6 cube, "
                          f"4:3 hcross, 3:4 vcross); give the layout")


def _check_layout(layout: str | None) -> None:
    if layout is not None and layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {', '.join(LAYOUTS)}, got {layout!r}")


def _cells(image: np.ndarray, cols: int, rows: int, path: object, layout: str) -> int:
    h, w = image.shape[:2]
    if w % cols or h % rows or w // cols != h // rows:
        raise EnvmapFileError(f"{path}: a {layout} image must be {cols}N x {rows}N pixels, got {w}x{h}")
    return w // cols


def _from_lh(faces_lh: list[np.ndarray]) -> np.ndarray:
    out = [None] * 6
    for k, face in enumerate(faces_lh):
        out[_LH_FACE[k]] = _flip(face, _LH_FLIP[k])
    return np.stack(out)


def _to_lh(faces: np.ndarray) -> list[np.ndarray]:
    return [_flip(faces[_LH_FACE[k]], _LH_FLIP[k]) for k in range(6)]


def cube_from_image(image: np.ndarray, layout: str, path: object = "image", size: int | None = None,
                    device: str | int | Runtime | None = None) -> CubeMap:
    """A cube map from one image in ``layout`` (not ``faces``); ``size`` resamples a latlong
    image (default: width / 4) and must match a cube layout's face size when given."""
    _check_layout(layout)
    if layout == "latlong":
        return CubeMap.from_latlong(image, size, device)
    if layout == "faces":
        raise ValueError("layout 'faces' takes six files: use load_cube with a path containing {face}")
    grid = {"cube": (1, 6), "hcross": (4, 3), "vcross": (3, 4)}[layout]
    n = _cells(image, *grid, path, layout)
    if layout == "cube":
        faces = np.stack([_flip(image[k * n:(k + 1) * n], _EXR_FLIP[k]) for k in range(6)])
    else:
        cells = _HCROSS if layout == "hcross" else _VCROSS
        lh = [image[r * n:(r + 1) * n, c * n:(c + 1) * n] for r, c in cells]
        if layout == "vcross":
            lh[5] = lh[5][::-1, ::-1]
        faces = _from_lh(lh)
    if size is not None and size != n:
        raise EnvmapFileError(f"{path}: its faces are {n}x{n}; --size {size} only resamples lat-long input")
    return CubeMap(faces)


def load_cube(path: str | os.PathLike, layout: str | None = None, size: int | None = None,
              device: str | int | Runtime | None = None) -> CubeMap:
    """Read an environment map file (or six, ``layout="faces"`` or a path with ``{face}``)."""
    _check_layout(layout)
    text = os.fspath(path)
    if layout == "faces" or "{face}" in text:
        if "{face}" not in text:
            raise EnvmapFileError(f"{text}: layout 'faces' needs a path with {{face}} (posx, negx, ...)")
        faces = [read_image(text.replace("{face}", w))[0] for w in FACE_WORDS]
        shapes = {f.shape for f in faces}
        if len(shapes) != 1 or faces[0].shape[0] != faces[0].shape[1]:
            raise EnvmapFileError(f"{text}: the six faces must be square and of one size, got "
                                  f"{sorted(s[:2] for s in shapes)}")
        cube = CubeMap(_from_lh(faces))
        if size is not None and size != cube.size:
            raise EnvmapFileError(f"{text}: its faces are {cube.size}x{cube.size}; a size only resamples lat-long input")
        return cube
    image, exr_layout = read_image(path)
    return cube_from_image(image, layout or exr_layout or _guess_layout(path, image.shape), path, size, device)


def save_cube(path: str | os.PathLike, cube: CubeMap, layout: str | None = None,
              latlong_height: int | None = None, device: str | int | Runtime | None = None) -> None:
    """Write a cube map in ``layout`` (default: by the target, ``faces`` for a path with
    ``{face}``, else ``cube``); ``latlong`` resamples it to 2H x H (H default 2 N)."""
    _check_layout(layout)
    text = os.fspath(path)
    layout = layout or ("faces" if "{face}" in text else "cube")
    if layout == "faces":
        if "{face}" not in text:
            raise EnvmapFileError(f"{text}: layout 'faces' needs a path with {{face}} (posx, negx, ...)")
        for word, face in zip(FACE_WORDS, _to_lh(cube.faces)):
            _write_image(Path(text.replace("{face}", word)), face, None)
        return
    n, f = cube.size, cube.faces
    if layout == "latlong":
        h = latlong_height or 2 * n
        _write_image(Path(text), cube.to_latlong(h, 2 * h, device), "latlong")
        return
    if layout == "cube":
        _write_image(Path(text), np.concatenate([_flip(f[k], _EXR_FLIP[k]) for k in range(6)]), "cube")
        return
    cols, rows = (4, 3) if layout == "hcross" else (3, 4)
    image = np.zeros((rows * n, cols * n, 3), np.float32)
    lh = _to_lh(f)
    if layout == "vcross":
        lh[5] = lh[5][::-1, ::-1]
    for (r, c), face in zip(_HCROSS if layout == "hcross" else _VCROSS, lh):
        image[r * n:(r + 1) * n, c * n:(c + 1) * n] = face
    _write_image(Path(text), image, None)


def convert(source: str | os.PathLike, target: str | os.PathLike, size: int | None = None,
            layout_in: str | None = None, layout_out: str | None = None,
            device: str | int | Runtime | None = None) -> CubeMap:
    """Read ``source`` and write ``target`` (``oclshade envmap convert``).  The output layout
    defaults to ``cube`` for a lat-long input and ``latlong`` for any cube layout; ``size``
    is the cube's face size (from lat-long input) or the lat-long height (to lat-long)."""
    text = os.fspath(source)
    if layout_in is None and "{face}" not in text:
        image, exr_layout = read_image(source)
        layout_in = exr_layout or _guess_layout(source, image.shape)
        cube = cube_from_image(image, layout_in, source, size if layout_in == "latlong" else None, device)
    else:
        cube = load_cube(source, layout_in, size if layout_in == "latlong" else None, device)
        layout_in = layout_in or "faces"
    layout_out = layout_out or ("faces" if "{face}" in os.fspath(target) else
                                "cube" if layout_in == "latlong" else "latlong")
    if layout_out == "latlong":
        save_cube(target, cube, "latlong", size if layout_in != "latlong" else None, device)
    else:
        save_cube(target, cube, layout_out, device=device)
    return cube
