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

Bands may instead arrive as windows (:meth:`GeoTiffWriter.write_window`: any
rectangles, in any order, each cell once): each block is encoded as soon as the
windows have filled it (partly filled blocks wait in memory), :meth:`save` puts
the blocks in the file's order, and the overviews are made at the end from the
full-resolution blocks read back a block row at a time.  The file is the same,
byte for byte, as from whole bands.

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


def _decoder(options: TiffOptions, dtype: np.dtype) -> Callable[[bytes, tuple[int, int]], np.ndarray]:
    """A block's bytes (as :func:`_encoder` made them) back to the (rows, cols) block."""
    decompress = {"NONE": bytes, "LZW": imagecodecs.lzw_decode, "DEFLATE": imagecodecs.deflate_decode,
                  "ZSTD": imagecodecs.zstd_decode}[options.compress]
    unpredict = {1: lambda a: a, 2: lambda a: imagecodecs.delta_decode(a, axis=-1),
                 3: lambda a: imagecodecs.floatpred_decode(a, axis=-1)}[options.predictor]

    def decode(data: bytes, shape: tuple[int, int]) -> np.ndarray:
        return unpredict(np.frombuffer(decompress(data), dtype).reshape(shape).copy())

    return decode


@dataclass
class _Level:
    """One resolution level: its size and its blocks in a temporary file, in the order they
    were encoded (``stored``: block numbers, band-major then row-major); ``offsets`` and
    ``counts`` by block number (where the data starts in the file, after any leader)."""

    rows: int
    cols: int
    file: BinaryIO
    offsets: list[int]
    counts: list[int]
    stored: list[int]

    def add(self, number: int, data: bytes, cog: bool) -> None:
        leader = struct.pack("<I", len(data)) if cog else b""
        trailer = data[-4:] if cog else b""
        self.offsets[number] = self.file.tell() + len(leader)
        self.counts[number] = len(data)
        self.stored.append(number)
        self.file.write(leader + data + trailer)

    def placed(self, cog: bool) -> list[int]:
        """Where each block's data starts in the level's part of the file (block-number order)."""
        extra = 4 if cog else 0
        out, pos = [], 0
        for count in self.counts:
            out.append(pos + extra)
            pos += count + 2 * extra
        return out

    def copy_to(self, fh: BinaryIO, cog: bool) -> None:
        """The blocks into ``fh`` in block-number order (a plain copy when stored so)."""
        self.file.seek(0)
        if self.stored == sorted(self.stored):
            shutil.copyfileobj(self.file, fh, 16 << 20)
            return
        extra = 4 if cog else 0
        for number in range(len(self.offsets)):
            self.file.seek(self.offsets[number] - extra)
            fh.write(self.file.read(self.counts[number] + 2 * extra))


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
        self._windows = False                     # write_window used (then write may not be)
        self._pending: dict[int, tuple[np.ndarray, np.ndarray]] = {}   # block number -> (block, filled)
        bx, by = options.block
        while True:
            level = _Level(rows, cols, tempfile.TemporaryFile(dir=directory), [], [], [])
            self.levels.append(level)
            n = self.count * self._blocks_per_band(level)
            level.offsets, level.counts = [0] * n, [0] * n
            if not options.overviews or max(rows, cols) <= max(bx, by):
                break
            rows, cols = -(-rows // 2), -(-cols // 2)

    def _block_shape(self, level: _Level) -> tuple[int, int]:
        if self.options.tiled:
            return self.options.block[1], self.options.block[0]
        per_row = level.cols * self.dtype.itemsize
        return min(level.rows, self.options.block[1] or max(1, _STRIP_BYTES // per_row)), level.cols

    def _blocks_per_band(self, level: _Level) -> int:
        th, tw = self._block_shape(level)
        return -(-level.rows // th) * -(-level.cols // tw)

    def _blocks(self, band: np.ndarray, level: _Level) -> list[np.ndarray]:
        """The blocks of a band, or of a stripe of whole block rows of it, in row-major order; edge
        tiles padded with zeros (strips are not)."""
        th, tw = self._block_shape(level)
        blocks = []
        for r in range(0, band.shape[0], th):
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
        if self._windows:
            raise ValueError("bands are being written as windows (write_window); write does not mix with it")
        band = np.asarray(band)
        for level in self.levels:
            first = self.written * self._blocks_per_band(level)
            for k, data in enumerate(self._pool.map(self._encode, self._blocks(band, level))):
                level.add(first + k, data, self.options.cog)
            band = band[::2, ::2]
        self.written += 1

    def write_window(self, band: int, row0: int, col0: int, data: np.ndarray) -> None:
        """Cells [row0, row0 + rows) x [col0, col0 + cols) of band ``band`` (0-based); windows come
        in any order, each cell once.  Blocks the windows complete are encoded now."""
        data = np.asarray(data)
        level = self.levels[0]
        rows, cols = data.shape if data.ndim == 2 else (0, 0)
        if self.written:
            raise ValueError("bands are being written whole (write); write_window does not mix with it")
        if not 0 <= band < self.count:
            raise ValueError(f"band {band} out of range: the file has {self.count} band(s), numbered from 0")
        if data.ndim != 2 or rows == 0 or cols == 0 or row0 < 0 or col0 < 0 or row0 + rows > level.rows or \
                col0 + cols > level.cols:
            raise ValueError(f"window of shape {data.shape} at ({row0}, {col0}) does not lie in the "
                             f"{level.rows}x{level.cols} band")
        self._windows = True
        th, tw = self._block_shape(level)
        per_row = -(-level.cols // tw)
        done: dict[int, np.ndarray] = {}
        for br in range(row0 // th, (row0 + rows - 1) // th + 1):
            for bc in range(col0 // tw, (col0 + cols - 1) // tw + 1):
                number = band * self._blocks_per_band(level) + br * per_row + bc
                r0, c0 = br * th, bc * tw
                valid = (min(th, level.rows - r0), min(tw, level.cols - c0))   # the block's cells in the band
                a0, a1 = max(row0, r0), min(row0 + rows, r0 + valid[0])
                b0, b1 = max(col0, c0), min(col0 + cols, c0 + valid[1])
                if level.counts[number] or number in done:
                    raise ValueError(f"band {band}: cells ({a0}, {b0}) written twice")
                block, filled = self._pending.pop(number, (None, None))
                if block is None:
                    shape = (th, tw) if self.options.tiled else valid
                    block, filled = np.zeros(shape, self.dtype), np.zeros(valid, bool)
                part = (slice(a0 - r0, a1 - r0), slice(b0 - c0, b1 - c0))
                if filled[part].any():
                    raise ValueError(f"band {band}: cells ({a0}, {b0}) written twice")
                block[part] = data[a0 - row0:a1 - row0, b0 - col0:b1 - col0]
                filled[part] = True
                if filled.all():
                    done[number] = block
                else:
                    self._pending[number] = (block, filled)
        for number, encoded in zip(done, self._pool.map(self._encode, done.values())):
            level.add(number, encoded, self.options.cog)

    def _overviews_from_windows(self) -> None:
        """The overview levels made from the full-resolution blocks, a block row at a time (as
        :meth:`write` makes them from whole bands: every other row and column)."""
        decode = _decoder(self.options, self.dtype)
        for upper, lower in zip(self.levels[:-1], self.levels[1:]):
            th, tw = self._block_shape(upper)
            per_band, per_row = self._blocks_per_band(upper), -(-upper.cols // tw)
            lower_th = self._block_shape(lower)[0]
            for band in range(self.count):
                first = band * self._blocks_per_band(lower)
                for r in range(0, upper.rows, 2 * lower_th):    # upper rows giving one lower block row
                    stripe = np.empty((min(2 * lower_th, upper.rows - r), upper.cols), self.dtype)
                    for br in range(r // th, (r + stripe.shape[0] - 1) // th + 1):
                        for bc in range(per_row):
                            number = band * per_band + br * per_row + bc
                            upper.file.seek(upper.offsets[number])
                            block = decode(upper.file.read(upper.counts[number]), (th, tw))
                            a0, a1 = max(r, br * th), min(r + stripe.shape[0], (br + 1) * th)
                            c1 = min(upper.cols, (bc + 1) * tw)
                            stripe[a0 - r:a1 - r, bc * tw:c1] = block[a0 - br * th:a1 - br * th, :c1 - bc * tw]
                    blocks = self._blocks(stripe[::2, ::2], lower)
                    at = first + (r // (2 * lower_th)) * -(-lower.cols // self._block_shape(lower)[1])
                    for k, data in enumerate(self._pool.map(self._encode, blocks)):
                        lower.add(at + k, data, self.options.cog)
                upper.file.seek(0, os.SEEK_END)

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
        offsets = tuple(base + o for o in level.placed(self.options.cog))
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
        if self._windows:
            level = self.levels[0]
            missing = len(level.offsets) - len(level.stored)
            if missing:
                raise ValueError(f"{missing} of {len(level.offsets)} blocks not completely written (windows missing)")
            if len(self.levels[-1].stored) < len(self.levels[-1].offsets):
                self._overviews_from_windows()
        elif self.written != self.count:
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
            level.copy_to(fh, self.options.cog)


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
