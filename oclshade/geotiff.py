"""A streaming GeoTIFF writer: bands arrive one at a time, memory stays one band.

Each band is cut into blocks (256 x 256 tiles by default, or strips), each block
predicted and compressed (DEFLATE, LZW, ZSTD or none, through imagecodecs) and
appended to an anonymous temporary file per resolution level; overviews (2x
nearest-neighbour levels, as ``gdaladdo``'s default) are cut from the band
while it is in memory. :meth:`GeoTiffWriter.save` then writes the file: header,
every IFD (full resolution first, then the overviews), then the blocks, the
smallest overview's first and the full resolution's last: the layout of a
Cloud-Optimized GeoTIFF. With ``cog`` the file also carries GDAL's structural
metadata (IFDs before data, blocks in row-major order, each block's size in
the 4 bytes before it and its last 4 bytes repeated after it), so GDAL reports
``LAYOUT=COG``. Bands are stored planar (``INTERLEAVE=BAND``), little-endian;
classic TIFF unless the file needs 64-bit offsets (``BIGTIFF``).

Option names and values follow GDAL's GTiff and COG drivers (see docs/io.md).
"""
from __future__ import annotations

import os
import shutil
import struct
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import BinaryIO, Callable, Mapping, Sequence

import imagecodecs
import numpy as np

__all__ = ["OPTION_KEYS", "TiffOptions", "GeoTiffWriter", "tiff_options"]

# TIFF field types: struct format, size in bytes
_TYPES = {1: ("B", 1), 2: ("s", 1), 3: ("H", 2), 4: ("I", 4), 12: ("d", 8), 16: ("Q", 8)}
ASCII, SHORT, LONG, LONG8 = 2, 3, 4, 16

COMPRESSION_CODES = {"NONE": 1, "LZW": 5, "DEFLATE": 8, "ZSTD": 50000}
OPTION_KEYS = ("COMPRESS", "PREDICTOR", "ZLEVEL", "ZSTD_LEVEL", "TILED", "BLOCKXSIZE", "BLOCKYSIZE",
               "BLOCKSIZE", "BIGTIFF", "OVERVIEWS")
# GDAL's structural metadata after the header (its COG layout; the final space pads as GDAL's does)
_GHOST = ("LAYOUT=IFDS_BEFORE_DATA\nBLOCK_ORDER=ROW_MAJOR\nBLOCK_LEADER=SIZE_AS_UINT4\n"
          "BLOCK_TRAILER=LAST_4_BYTES_REPEATED\nKNOWN_INCOMPATIBLE_EDITION=NO\n ")
_GDAL_NODATA = 42113        # GDAL's nodata tag: also on the overviews
_STRIP_BYTES = 8192          # GDAL's default strip: rows holding at most 8 KiB
_CLASSIC_LIMIT = 1 << 32


@dataclass(frozen=True)
class TiffOptions:
    """How a GeoTIFF is laid out and compressed (GDAL creation option names in the comments)."""

    compress: str = "DEFLATE"          # COMPRESS
    predictor: int = 1                 # PREDICTOR: 1 none, 2 horizontal differencing, 3 floating point
    level: int | None = None           # ZLEVEL (DEFLATE) or ZSTD_LEVEL (ZSTD); None: the codec's default
    tiled: bool = True                 # TILED
    block: tuple[int, int] = (256, 256)  # BLOCKXSIZE, BLOCKYSIZE (strips: rows per strip in [1])
    bigtiff: str = "IF_NEEDED"         # BIGTIFF: YES, NO, IF_NEEDED, IF_SAFER
    overviews: bool = False            # OVERVIEWS=AUTO (COG driver name) or NONE
    cog: bool = False                  # GDAL's COG layout metadata (block leaders and trailers)


def _choice(key: str, value: str, allowed: Sequence[str]) -> str:
    if value not in allowed:
        raise ValueError(f"{key}={value}: expected {'|'.join(allowed)}")
    return value


def _integer(key: str, value: str, low: int, high: int) -> int:
    try:
        n = int(value)
    except ValueError:
        n = low - 1
    if not low <= n <= high:
        raise ValueError(f"{key}={value}: expected an integer {low}..{high}")
    return n


def tiff_options(options: Mapping[str, str] | None, dtype: np.dtype | type, cog: bool = False) -> TiffOptions:
    """Check GDAL-style creation options (keys and values case-insensitive) for bands of ``dtype``.

    Defaults: tiled 256 x 256 (512 x 512 for a COG, as GDAL's COG driver), DEFLATE,
    PREDICTOR 2 for integer and 3 for floating-point bands, no overviews (AUTO for a
    COG). Raises ValueError naming the option and the values it takes.
    """
    dtype = np.dtype(dtype)
    opts = {str(k).strip().upper(): str(v).strip().upper() for k, v in (options or {}).items()}
    unknown = sorted(set(opts) - set(OPTION_KEYS))
    if unknown:
        raise ValueError(f"unknown creation option {unknown[0]}; known: {', '.join(OPTION_KEYS)}")
    compress = _choice("COMPRESS", opts.get("COMPRESS", "DEFLATE"), tuple(COMPRESSION_CODES))
    if compress != "NONE" and not getattr(imagecodecs, compress).available:
        raise ValueError(f"COMPRESS={compress}: this imagecodecs build cannot encode it")
    natural = 3 if dtype.kind == "f" else 2
    predictor = _integer("PREDICTOR", opts.get("PREDICTOR", str(natural if compress != "NONE" else 1)), 1, 3)
    if predictor != 1 and compress == "NONE":
        raise ValueError(f"PREDICTOR={predictor} needs compression (COMPRESS=DEFLATE, LZW or ZSTD)")
    if predictor not in (1, natural):
        raise ValueError(f"PREDICTOR={predictor} does not suit {dtype} bands: use {natural} (or 1)")
    level = None
    for key, codec, high in (("ZLEVEL", "DEFLATE", 12), ("ZSTD_LEVEL", "ZSTD", 22)):
        if key in opts:
            if compress != codec:
                raise ValueError(f"{key} applies to COMPRESS={codec}, not COMPRESS={compress}")
            level = _integer(key, opts[key], 1, high)
    tiled = _choice("TILED", opts.get("TILED", "YES"), ("YES", "NO")) == "YES"
    if cog and not tiled:
        raise ValueError("TILED=NO: a Cloud-Optimized GeoTIFF is tiled")
    side = opts.get("BLOCKSIZE", "512" if cog else "256")
    bx, by = opts.get("BLOCKXSIZE", side), opts.get("BLOCKYSIZE", side)
    if tiled:
        block = (_integer("BLOCKXSIZE", bx, 16, 4096), _integer("BLOCKYSIZE", by, 16, 4096))
        if block[0] % 16 or block[1] % 16:
            raise ValueError(f"BLOCKXSIZE={block[0]}, BLOCKYSIZE={block[1]}: tiles are multiples of 16")
    else:
        if "BLOCKXSIZE" in opts or "BLOCKSIZE" in opts:
            raise ValueError("BLOCKXSIZE/BLOCKSIZE need TILED=YES (strips are the full width)")
        block = (0, _integer("BLOCKYSIZE", by, 1, 1 << 20) if "BLOCKYSIZE" in opts else 0)
    bigtiff = _choice("BIGTIFF", opts.get("BIGTIFF", "IF_NEEDED"), ("YES", "NO", "IF_NEEDED", "IF_SAFER"))
    overviews = _choice("OVERVIEWS", opts.get("OVERVIEWS", "AUTO" if cog else "NONE"), ("AUTO", "NONE")) == "AUTO"
    if overviews and not tiled:
        raise ValueError("OVERVIEWS=AUTO needs TILED=YES")
    return TiffOptions(compress, predictor, level, tiled, block, bigtiff, overviews, cog)


def _encoder(options: TiffOptions) -> Callable[[np.ndarray], bytes]:
    """A block (rows, cols) to its predicted and compressed bytes."""
    predict = {1: lambda a: a, 2: lambda a: imagecodecs.delta_encode(a, axis=-1),
               3: lambda a: imagecodecs.floatpred_encode(a, axis=-1)}[options.predictor]
    level = {} if options.level is None else {"level": options.level}
    compress = {"NONE": bytes, "LZW": imagecodecs.lzw_encode,
                "DEFLATE": lambda b: imagecodecs.deflate_encode(b, **level),   # zlib stream (libdeflate)
                "ZSTD": lambda b: imagecodecs.zstd_encode(b, **level)}[options.compress]
    return lambda block: compress(np.ascontiguousarray(predict(block)).tobytes())


@dataclass
class _Level:
    """One resolution level: its size and its blocks, appended to a temporary file."""

    rows: int
    cols: int
    file: BinaryIO
    offsets: list[int]
    counts: list[int]


class GeoTiffWriter:
    """Write ``shape = (bands, rows, cols)`` bands of ``dtype`` one at a time (:meth:`write`),
    then the GeoTIFF (:meth:`save`). ``tags``: extra main-IFD tags ``(code, type, values)``
    (GeoTIFF keys, GDAL metadata and nodata). Temporary files go to ``directory``."""

    def __init__(self, shape: tuple[int, int, int], dtype: np.dtype | type, options: TiffOptions,
                 tags: Sequence[tuple[int, int, object]] = (), directory: str | os.PathLike | None = None):
        self.count, rows, cols = shape
        self.dtype = np.dtype(dtype).newbyteorder("<")
        self.options, self.tags = options, list(tags)
        self.written = 0
        self._encode = _encoder(options)
        self._pool = ThreadPoolExecutor(max_workers=os.cpu_count() or 1)
        self.levels: list[_Level] = []
        bx, by = options.block
        while True:
            self.levels.append(_Level(rows, cols, tempfile.TemporaryFile(dir=directory), [], []))
            if not options.overviews or max(rows, cols) <= max(bx, by):
                break
            rows, cols = -(-rows // 2), -(-cols // 2)

    def _block_shape(self, level: _Level) -> tuple[int, int]:
        if self.options.tiled:
            return self.options.block[1], self.options.block[0]
        per_row = level.cols * self.dtype.itemsize
        return min(level.rows, self.options.block[1] or max(1, _STRIP_BYTES // per_row)), level.cols

    def _blocks(self, band: np.ndarray, level: _Level) -> list[np.ndarray]:
        """The band's blocks in row-major order; edge tiles padded with zeros (strips are not)."""
        th, tw = self._block_shape(level)
        blocks = []
        for r in range(0, level.rows, th):
            for c in range(0, level.cols, tw):
                part = band[r:r + th, c:c + tw]
                if self.options.tiled and part.shape != (th, tw):
                    padded = np.zeros((th, tw), self.dtype)
                    padded[:part.shape[0], :part.shape[1]] = part
                    part = padded
                blocks.append(np.ascontiguousarray(part, dtype=self.dtype))
        return blocks

    def write(self, band: np.ndarray) -> None:
        """Append the next band (rows, cols), and its overviews."""
        if self.written == self.count:
            raise ValueError(f"all {self.count} bands are already written")
        band = np.asarray(band)
        cog = self.options.cog
        for level in self.levels:
            for data in self._pool.map(self._encode, self._blocks(band, level)):
                leader = struct.pack("<I", len(data)) if cog else b""
                trailer = data[-4:] if cog else b""
                level.offsets.append(level.file.tell() + len(leader))
                level.counts.append(len(data))
                level.file.write(leader + data + trailer)
            band = band[::2, ::2]
        self.written += 1

    def close(self) -> None:
        """Drop the temporary files (also after a failure)."""
        self._pool.shutdown()
        for level in self.levels:
            level.file.close()

    def _ifds(self, big: bool, header: int, data: int) -> bytes:
        """Every IFD, chained, from file offset ``header`` on; the levels' blocks from offset
        ``data`` on, the smallest level first. The IFDs' size does not depend on the offsets."""
        bases, pos = {}, data
        for level in reversed(self.levels):
            bases[id(level)] = pos
            pos += level.file.seek(0, os.SEEK_END)
        out = bytearray()
        for k, level in enumerate(self.levels):
            start = header + len(out)
            ifd = bytearray(_ifd(self._entries(level, k, bases[id(level)], big), start, big))
            if k + 1 < len(self.levels):          # the next IFD follows this one and its values
                at = _ifd_next_pointer(ifd, big)
                ifd[at:at + (8 if big else 4)] = struct.pack("<Q" if big else "<I", start + len(ifd))
            out += ifd
        return bytes(out)

    def _entries(self, level: _Level, k: int, base: int, big: bool) -> list[tuple[int, int, object]]:
        n = self.count
        th, tw = self._block_shape(level)
        offsets = tuple(base + o for o in level.offsets)
        kind = {"u": 1, "i": 2, "f": 3}[self.dtype.kind]
        entries = [(254, LONG, (1 if k else 0,)), (256, LONG, (level.cols,)), (257, LONG, (level.rows,)),
                   (258, SHORT, (8 * self.dtype.itemsize,) * n),
                   (259, SHORT, (COMPRESSION_CODES[self.options.compress],)),
                   (262, SHORT, (1,)), (277, SHORT, (n,)), (284, SHORT, (2 if n > 1 else 1,)),
                   (339, SHORT, (kind,) * n)]
        if self.options.predictor != 1:
            entries.append((317, SHORT, (self.options.predictor,)))
        if n > 1:
            entries.append((338, SHORT, (0,) * (n - 1)))      # ExtraSamples: unspecified
        pos = LONG8 if big else LONG
        if self.options.tiled:
            entries += [(322, LONG, (tw,)), (323, LONG, (th,)), (324, pos, offsets),
                        (325, pos, tuple(level.counts))]
        else:
            entries += [(273, pos, offsets), (278, LONG, (th,)), (279, pos, tuple(level.counts))]
        return entries + (self.tags if k == 0 else [t for t in self.tags if t[0] == _GDAL_NODATA])

    def save(self, fh: BinaryIO) -> None:
        """Write the complete GeoTIFF to ``fh`` (at its start) once every band is written."""
        if self.written != self.count:
            raise ValueError(f"{self.written} of {self.count} bands written")
        ghost = b""
        if self.options.cog:
            text = _GHOST.encode("ascii")
            ghost = f"GDAL_STRUCTURAL_METADATA_SIZE={len(text):06d} bytes\n".encode("ascii") + text
        data_size = sum(level.file.seek(0, os.SEEK_END) for level in self.levels)

        def layout(big: bool) -> tuple[int, int]:
            header = (16 if big else 8) + len(ghost)
            header += header % 2                   # IFDs start on a word boundary
            return header, header + len(self._ifds(big, header, 0))

        big = self.options.bigtiff == "YES"
        header, data = layout(big)
        if not big and data + data_size >= _CLASSIC_LIMIT:
            if self.options.bigtiff == "NO":
                raise ValueError(f"BIGTIFF=NO: the file needs {data + data_size} bytes, more than a classic "
                                 f"TIFF's 4 GiB; use BIGTIFF=IF_NEEDED or YES")
            big = True
            header, data = layout(big)
        start = struct.pack("<2sHHHQ", b"II", 43, 8, 0, header) if big else struct.pack("<2sHI", b"II", 42, header)
        fh.write(start + ghost + b"\0" * (header - len(start) - len(ghost)) + self._ifds(big, header, data))
        for level in reversed(self.levels):
            level.file.seek(0)
            shutil.copyfileobj(level.file, fh, 16 << 20)


def _values(kind: int, values: object) -> bytes:
    fmt, _ = _TYPES[kind]
    if kind == ASCII:
        return str(values).encode("utf-8") + b"\0"
    vals = tuple(values)  # type: ignore[arg-type]
    return struct.pack(f"<{len(vals)}{fmt}", *vals)


def _ifd(entries: Sequence[tuple[int, int, object]], start: int, big: bool) -> bytes:
    """One IFD at file offset ``start``, its out-of-line values after it; next-IFD pointer 0."""
    entries = sorted(entries, key=lambda e: e[0])
    inline = 8 if big else 4
    head = struct.Struct("<HHQ" if big else "<HHI")
    table = bytearray(struct.pack("<Q" if big else "<H", len(entries)))
    extra = bytearray()
    extra_at = start + len(table) + len(entries) * (head.size + inline) + inline
    for code, kind, values in entries:
        raw = _values(kind, values)
        count = len(raw) // _TYPES[kind][1]
        if len(raw) <= inline:
            field = raw.ljust(inline, b"\0")
        else:
            field = struct.pack("<Q" if big else "<I", extra_at + len(extra))
            extra += raw + b"\0" * (len(raw) % 2)
        table += head.pack(code, kind, count) + field
    return bytes(table + b"\0" * inline + extra)


def _ifd_next_pointer(ifd: bytes, big: bool) -> int:
    """Position of the next-IFD pointer within an IFD made by :func:`_ifd`."""
    count = struct.unpack_from("<Q" if big else "<H", ifd)[0]
    return (8 if big else 2) + count * (20 if big else 12)
