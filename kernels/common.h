/* oclshade shared kernel header.
 *
 * ABI conventions shared by every kernel file (see each file for its own
 * arguments, layouts and work sizes):
 *   - heightmaps are row-major float32 arrays (rows = north->south,
 *     cols = west->east), NaN = nodata hole;
 *   - heights handed to kernels are relative to a per-map offset chosen by the
 *     host (float64 subtraction on the host), so float32 keeps full precision
 *     for DEMs far from sea level;
 *   - extrema pyramids are one buffer of float2 (x = max, y = min) holding all
 *     levels back to back, with a table of level offsets (see pyramid.cl);
 *   - no -cl-fast-relaxed-math; contraction into FMA is off so results do not
 *     depend on the device's FMA choices.
 */
#ifndef OCLS_COMMON_H
#define OCLS_COMMON_H

#pragma OPENCL FP_CONTRACT OFF

/* Helpers are small and called in the hot loops: some compilers (PoCL 3's
 * LLVM among them) keep plain `inline` functions out of line. */
#if defined(__clang__) || defined(__GNUC__)
#define OCLS_INLINE inline __attribute__((always_inline))
#else
#define OCLS_INLINE inline
#endif

/* floor / ceil - 1 of a float as an int without the library calls (exact for
 * |p| < 2^31). */
OCLS_INLINE int ocls_floor_int(float p)
{
    const int i = (int)p;                 /* truncates toward zero */
    return (float)i > p ? i - 1 : i;
}

OCLS_INLINE int ocls_ceil_int(float p)
{
    const int i = (int)p;
    return (float)i < p ? i + 1 : i;
}

/* Rows/cols of pyramid level l for a base grid of n0 rows (or cols): ceil(n0 / 2^l). */
OCLS_INLINE int ocls_level_extent(int n0, int l) { return ((n0 - 1) >> l) + 1; }

/* Height sample (r, c) of an H x W map; NaN outside the map. */
OCLS_INLINE float ocls_sample(__global const float *h, int H, int W, int r, int c)
{
    return (r >= 0 && r < H && c >= 0 && c < W) ? h[r * W + c] : NAN;
}

#endif
