"""Radiance RGBE (.hdr / .pic) images: a small reader and writer.

The format (Greg Ward, "Real Pixels", Graphics Gems II, and Radiance's ``color.c``): a text
header starting ``#?RADIANCE`` (or ``#?RGBE``) of ``NAME=value`` lines and comments, ended by
an empty line; a resolution line; then scanlines of 4-byte pixels (r, g, b, e), each either
flat, old-style run-length encoded (a pixel (1, 1, 1, n) repeats the previous one n << shift
times) or new-style (a scanline starting 2, 2, width >> 8, width & 255, then each of the four
components run-length coded: a count byte c > 128 repeats the next byte c - 128 times, else c
literal bytes follow).  A pixel decodes to ((r, g, b) + 0.5) * 2^(e - 136), 0 when e = 0
(Radiance's ``colr_color``), divided by the header's EXPOSURE values.

Read: ``FORMAT=32-bit_rle_rgbe`` (or no FORMAT line); resolution ``-Y H +X W`` (rows top
down) or ``+Y H +X W`` (bottom up).  XYZE files and the transposed or mirrored resolution
orders are refused with a message naming them.  Write: new-style scanlines of literal runs
(widths 8..32767), flat scanlines otherwise.
"""
from __future__ import annotations

import os
import re

import numpy as np

_RESOLUTION = re.compile(rb"^([-+])Y (\d+) ([-+])X (\d+)$")


class HDRFormatError(ValueError):
    """A Radiance file this reader cannot decode; the message names the file and the reason."""


def _fail(path: object, why: str) -> HDRFormatError:
    return HDRFormatError(f"{path}: not a readable Radiance .hdr image: {why}")


def read_hdr(path: str | os.PathLike) -> np.ndarray:
    """float32 (rows, cols, 3) linear RGB of a Radiance RGBE file, row 0 at the top."""
    data = open(path, "rb").read()
    if not (data.startswith(b"#?RADIANCE") or data.startswith(b"#?RGBE")):
        raise _fail(path, "it does not start with '#?RADIANCE' or '#?RGBE'")
    end = data.find(b"\n\n")
    if end < 0:
        raise _fail(path, "the header has no terminating empty line")
    exposure = 1.0
    for line in data[:end].split(b"\n")[1:]:
        if line.startswith(b"FORMAT="):
            fmt = line[7:].strip()
            if fmt != b"32-bit_rle_rgbe":
                raise _fail(path, f"FORMAT={fmt.decode(errors='replace')} (only 32-bit_rle_rgbe is read)")
        elif line.startswith(b"EXPOSURE="):
            try:
                exposure *= float(line[9:])
            except ValueError:
                raise _fail(path, f"bad EXPOSURE line {line.decode(errors='replace')!r}") from None
    nl = data.find(b"\n", end + 2)
    res = _RESOLUTION.match(data[end + 2:nl if nl >= 0 else len(data)].strip())
    if res is None:
        raise _fail(path, "expected a resolution line '-Y H +X W' (or '+Y H +X W') after the header")
    if res.group(3) != b"+":
        raise _fail(path, "mirrored scanlines (-X) are not supported")
    rows, cols = int(res.group(2)), int(res.group(4))
    if rows < 1 or cols < 1 or not np.isfinite(exposure) or exposure <= 0:
        raise _fail(path, f"size {rows}x{cols} or EXPOSURE {exposure} out of range")
    body = memoryview(data)[nl + 1:]
    rgbe = np.empty((rows, cols, 4), np.uint8)
    pos = 0
    for r in range(rows):
        pos = _scanline(body, pos, rgbe[r], path)
    if res.group(1) == b"+":
        rgbe = rgbe[::-1]
    return _decode(rgbe) / np.float32(exposure)


def _scanline(body: memoryview, pos: int, out: np.ndarray, path: object) -> int:
    cols = out.shape[0]
    head = bytes(body[pos:pos + 4])
    if len(head) < 4:
        raise _fail(path, "the file ends before the last scanline")
    if 8 <= cols <= 0x7FFF and head[0] == 2 and head[1] == 2 and not head[2] & 0x80:
        if (head[2] << 8) | head[3] != cols:
            raise _fail(path, f"a scanline says width {(head[2] << 8) | head[3]}, the image {cols}")
        pos += 4
        for k in range(4):
            x = 0
            while x < cols:
                if pos >= len(body):
                    raise _fail(path, "the file ends inside a scanline")
                count = body[pos]
                if count > 128:
                    count -= 128
                    if x + count > cols or pos + 1 >= len(body):
                        raise _fail(path, "a run overruns its scanline")
                    out[x:x + count, k] = body[pos + 1]
                    pos += 2
                else:
                    if count == 0 or x + count > cols or pos + 1 + count > len(body):
                        raise _fail(path, "bad run length in a scanline")
                    out[x:x + count, k] = np.frombuffer(body[pos + 1:pos + 1 + count], np.uint8)
                    pos += 1 + count
                x += count
        return pos
    x, shift = 0, 0                                  # flat or old-style RLE pixels
    while x < cols:
        px = bytes(body[pos:pos + 4])
        if len(px) < 4:
            raise _fail(path, "the file ends before the last scanline")
        pos += 4
        if px[0] == 1 and px[1] == 1 and px[2] == 1:
            count = px[3] << shift
            if x == 0 or x + count > cols:
                raise _fail(path, "an old-style run has no pixel to repeat or overruns its scanline")
            out[x:x + count] = out[x - 1]
            x += count
            shift += 8
        else:
            out[x] = np.frombuffer(px, np.uint8)
            x += 1
            shift = 0
    return pos


def _decode(rgbe: np.ndarray) -> np.ndarray:
    e = rgbe[..., 3].astype(np.int32)
    scale = np.where(e > 0, np.ldexp(np.float32(1.0), e - 136), 0.0).astype(np.float32)
    return (rgbe[..., :3].astype(np.float32) + 0.5) * scale[..., None]


def encode_rgbe(rgb: np.ndarray) -> np.ndarray:
    """uint8 (..., 4) RGBE pixels of non-negative float RGB (Radiance's ``setcolr``)."""
    rgb = np.asarray(rgb, np.float64)
    peak = rgb.max(axis=-1)
    mant, exp = np.frexp(peak)
    ok = peak > 1e-32
    scale = np.where(ok, mant * 255.9999 / np.where(ok, peak, 1.0), 0.0)
    out = np.zeros(rgb.shape[:-1] + (4,), np.uint8)
    out[..., :3] = np.where(ok[..., None], np.floor(rgb * scale[..., None]), 0).astype(np.uint8)
    out[..., 3] = np.where(ok, exp + 128, 0).astype(np.uint8)
    return out


def write_hdr(path: str | os.PathLike, rgb: np.ndarray) -> None:
    """Write float RGB (rows, cols, 3), finite and >= 0, as a Radiance file (module doc)."""
    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] != 3 or not np.all(np.isfinite(rgb)) or rgb.min(initial=0.0) < 0:
        raise ValueError("write_hdr takes finite non-negative RGB of shape (rows, cols, 3)")
    rows, cols = rgb.shape[:2]
    pixels = encode_rgbe(rgb)
    parts = [b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n", f"-Y {rows} +X {cols}\n".encode()]
    for r in range(rows):
        if 8 <= cols <= 0x7FFF:
            parts.append(bytes((2, 2, cols >> 8, cols & 255)))
            for k in range(4):
                comp = pixels[r, :, k].tobytes()
                for x in range(0, cols, 128):
                    chunk = comp[x:x + 128]
                    parts.append(bytes((len(chunk),)) + chunk)
        else:
            parts.append(pixels[r].tobytes())
    with open(path, "wb") as fh:
        fh.write(b"".join(parts))
