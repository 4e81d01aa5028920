"""The heights and the extrema pyramid as OpenCL images (the shadow family's ``images`` knob).

GPUs read 2-D images through a texture cache built for 2-D locality, which the
pyramid traversal has (a ray's next texel is a neighbour of its last); buffers
are cached by address.  With ``images=1`` the one-ray shadow kernels
(``shadow_cells``, ``shadow_certify``; kernels/shadow.cl with -D OCLS_IMAGES)
read these images instead of the buffers, and give the same bits: an image
read with integer coordinates and nearest filtering returns the stored float.

Layouts (kernels/common.h): the heights are a CL_R / CL_FLOAT image, W x H;
the extrema levels 1..L are stacked into one atlas, CL_RG / CL_FLOAT where the
device supports it, else CL_RGBA / CL_FLOAT (PoCL has no two-channel float
format; the kernels read .xy either way), level l at columns [0, cols_l) and
rows [rows_off[l], rows_off[l] + rows_l), unused texels 0.

Where the device cannot hold them (no image support, no such format, or the
map larger than its largest 2-D image) :func:`build_pyramid_images` says why
and the kernels read the buffers: the knob never decides whether a map can be
shadowed.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pyopencl as cl

if TYPE_CHECKING:
    from .pyramid import ExtremaPyramid
    from .runtime import Runtime


@dataclass(frozen=True)
class PyramidImages:
    """Device images of one pyramid's heights and extrema levels."""

    heights: cl.Image          # CL_R float, (W, H)
    extrema: cl.Image          # CL_RG or CL_RGBA float atlas of levels 1..L
    level_rows: cl.Buffer      # int32: atlas row of level l at [l]; [0] unused
    channels: int              # 2 (CL_RG) or 4 (CL_RGBA)

    @property
    def nbytes(self) -> int:
        """Device memory of the images and the row table."""
        return sum(img.row_pitch * img.height for img in (self.heights, self.extrema)) + self.level_rows.size


def atlas_rows(shapes: list[tuple[int, int]]) -> np.ndarray:
    """The atlas row offset of each stored level, indexed by level ([0] unused: level 0 is
    the heights), and the atlas's row count as the last entry."""
    return np.concatenate([[-1, 0], np.cumsum([r for r, _ in shapes])]).astype(np.int32)


def _float_formats(runtime: Runtime) -> set[int]:
    """The channel orders the device reads as CL_FLOAT 2-D images."""
    formats = cl.get_supported_image_formats(runtime.context, cl.mem_flags.READ_ONLY,
                                             cl.mem_object_type.IMAGE2D)
    return {f.channel_order for f in formats if f.channel_data_type == cl.channel_type.FLOAT}


def images_unavailable(runtime: Runtime, map_shape: tuple[int, int], shapes: list[tuple[int, int]],
                       channel_orders: set[int] | None = None) -> str | None:
    """Why this device cannot hold a map of ``map_shape`` and its stored pyramid levels
    ``shapes`` as images (None: it can).  ``channel_orders``: the device's CL_FLOAT channel
    orders (queried when None)."""
    dev = runtime.device
    if not dev.image_support:
        return "the device has no image support"
    orders = _float_formats(runtime) if channel_orders is None else channel_orders
    if cl.channel_order.R not in orders:
        return "the device has no CL_R / CL_FLOAT image format"
    if not orders & {cl.channel_order.RG, cl.channel_order.RGBA}:
        return "the device has no CL_RG or CL_RGBA / CL_FLOAT image format"
    rows, cols = map_shape
    atlas = (int(atlas_rows(shapes)[-1]), shapes[0][1])
    for what, (r, c) in (("heights", (rows, cols)), ("extrema atlas", atlas)):
        if c > dev.image2d_max_width or r > dev.image2d_max_height:
            return (f"the {what} ({c} x {r}) exceed the device's largest 2-D image "
                    f"({dev.image2d_max_width} x {dev.image2d_max_height})")
    if atlas[0] * atlas[1] * 16 > dev.max_mem_alloc_size:
        return "the extrema atlas exceeds the device's largest allocation"
    return None


def build_pyramid_images(pyramid: ExtremaPyramid) -> PyramidImages | None:
    """The pyramid's heights and extrema as images, or None where the device cannot hold them
    (:func:`images_unavailable`)."""
    rt = pyramid.runtime
    orders = _float_formats(rt) if rt.device.image_support else set()
    if images_unavailable(rt, pyramid.map_shape, pyramid.shapes, orders) is not None:
        return None
    rows, cols = pyramid.map_shape
    channels = 2 if cl.channel_order.RG in orders else 4
    offsets = atlas_rows(pyramid.shapes)
    atlas = np.zeros((int(offsets[-1]), pyramid.shapes[0][1], channels), np.float32)
    for level, texels in enumerate(pyramid.to_numpy(), start=1):
        r, c = texels.shape[:2]
        atlas[offsets[level]:offsets[level] + r, :c, :2] = texels
    create_image = getattr(cl, "create_image", cl.Image)   # pyopencl >= 2024.2; cl.Image before
    # the heights: a device-side copy (4-byte texels, the buffer's layout)
    heights = create_image(rt.context, cl.mem_flags.READ_ONLY,
                           cl.ImageFormat(cl.channel_order.R, cl.channel_type.FLOAT), shape=(cols, rows))
    cl.enqueue_copy(rt.queue, heights, pyramid.heights, offset=0, origin=(0, 0), region=(cols, rows))
    # the atlas: through the host (PoCL's CL_RGBA texels are wider than the buffer's float2)
    order = cl.channel_order.RG if channels == 2 else cl.channel_order.RGBA
    return PyramidImages(
        heights,
        create_image(rt.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                     cl.ImageFormat(order, cl.channel_type.FLOAT),
                     shape=(atlas.shape[1], atlas.shape[0]), hostbuf=atlas),
        rt.to_device(offsets[:-1].copy(), "atlas level rows"),
        channels)
