/* sunshine.cl — sunshine over time: per-cell sums over many suns of the
 * time in direct sun, the time in cast shadow and the beam incidence on the
 * sloped surface, accumulated on the device in place (constant memory: one
 * set of sums per cell, whatever the number of suns).  Host:
 * oclshade/sunshine; float64 twin: oclshade.reference.sunshine; definitions
 * and error in docs/solar.md ("Sunshine over time").
 *
 * Definitions, per cell and per daylight sun (elevation > 0; the host skips
 * the others) with unit vector s = (east, north, up) and weight w seconds:
 *   facing  the sun is above the cell's tangent plane:
 *           v = s.z - gx s.x + gy s.y > 0 with (gx, gy) = ocls_gradient
 *           (common.h), the very test of shadow.cl's self output negated;
 *   cast    the cell is in cast shadow (paper 000): its shadow mask is 1
 *           (sunshine_masks) or, by the horizon route, its horizon elevation
 *           at the sun's azimuth is above the sun's (sunshine_horizons);
 *   direct  facing and not cast.
 * Sums (each compiled in by its -D option; an output not compiled in is not
 * written and its argument may be a 1-byte dummy buffer):
 *   OCLS_OUT_SUN   sun[idx]  += w when direct       uint seconds (exact)
 *   OCLS_OUT_CAST  cast[idx] += w when cast         uint seconds (exact)
 *   OCLS_OUT_BEAM  beam[idx] += (w / 3600) cos i when direct, in hours, with
 *                  cos i = v / sqrt(1 + gx^2 + gy^2) (the incidence angle on
 *                  the sloped surface): float2 (sum, compensation) of a
 *                  Kahan summation (Kahan 1965), so the sum's rounding does
 *                  not grow with the number of suns
 * Nodata cells (NaN height) are left untouched (the host writes NaN there).
 *
 * ABI
 *   __kernel sunshine_masks(h, H, W, cell, mask, sunvec, weight, sun, cast, beam)
 *     __global const float *h     H*W heights as for shadow.cl (relative to
 *                                 the host's offset; NaN = nodata)
 *     int H, W
 *     float2 cell                 (dx, dy) in metres
 *     __global const uchar *mask  H*W: shadow.cl's mask output for this sun
 *                                 (1 cast shadow, 0 lit, 255 nodata), read
 *                                 where shadow_cells left it on the device
 *     float4 sunvec               (s.x, s.y, s.z, 0) as for shadow.cl
 *     uint weight                 w, seconds (1 .. 2^32 - 1; the host keeps
 *                                 every sum below 2^32)
 *     float hours                 w / 3600 rounded to float32 (beam only)
 *     __global uint *sun, __global uint *cast, __global float2 *beam  H*W each
 *   __kernel sunshine_horizons(h, H, W, cell, low, high, frac, elevation,
 *                              sunvec, weight, hours, sun, cast, beam)
 *     low, high   __global const float *: H*W horizon elevation angles in
 *                 degrees at the two computed azimuths around the sun's
 *                 (oclshade/horizon), NaN = nodata
 *     frac        float in [0, 1]: where the sun's azimuth lies between them
 *     elevation   float: the sun's elevation in degrees
 *     cast iff low + frac (high - low) > elevation (linear interpolation
 *     of the horizon between the two azimuths)
 *   global size (W, H) rounded up to the local size; any local size.
 *
 * Sun tables (-D OCLS_SUN_TABLE, both kernels): a step whose sun varies over
 * the map (a sun field of blocks, as shadow.cl's "sun tables") is summed in
 * one launch: each cell takes its block's sun from a table and the cell,
 * sunvec, frac and elevation arguments are not read.  Extra arguments after beam:
 *     __global const int    *band   H + W ints: cell (i, j) is in block
 *                                   b = band[i] + band[H + j] (shadow.cl)
 *     __global const float4 *suns   2 per block: the sun vector, then
 *                                   (frac, elevation, dx, dy): frac and
 *                                   elevation read by the horizon route
 *                                   only, (dx, dy) the block's cell size in
 *                                   place of the cell argument (a
 *                                   geographic grid's blocks: their own on
 *                                   the ground, with the sun vector there;
 *                                   oclshade/sun.py true_directions)
 *     __global const int    *keys   1 per block
 *     int key                       a cell adds to its sums only when
 *                                   keys[b] == key (the host gives the blocks
 *                                   whose sun is down a key no launch has;
 *                                   the horizon route launches once per
 *                                   interval of grid azimuths holding some
 *                                   block's sun, keyed by the interval)
 *
 * Build options: -D OCLS_OUT_SUN / OCLS_OUT_CAST / OCLS_OUT_BEAM,
 * OCLS_SUN_TABLE and -cl-std=CL1.2, nothing else (no fast-math).
 */
#include "common.h"

#pragma OPENCL FP_CONTRACT OFF

/* Add one sun's contributions to cell idx (shadow: its cast flag). */
OCLS_INLINE void accumulate(__global const float *h, int H, int W, int i, int j, float2 cell, int shadow,
                            float4 s, uint weight, float hours,
                            __global uint *sun, __global uint *cast, __global float2 *beam)
{
    const int idx = i * W + j;
    const float2 g = ocls_gradient(h, H, W, i, j, cell);
    const float v = s.z - g.x * s.x + g.y * s.y;
    const int direct = !shadow && v > 0.0f;
#ifdef OCLS_OUT_SUN
    if (direct) sun[idx] += weight;
#endif
#ifdef OCLS_OUT_CAST
    if (shadow) cast[idx] += weight;
#endif
#ifdef OCLS_OUT_BEAM
    if (direct) ocls_kahan_add(beam, idx, hours * (v / sqrt(1.0f + g.x * g.x + g.y * g.y)));
#endif
}

#ifdef OCLS_SUN_TABLE
#define OCLS_SUN_PARAMS , __global const int *band, __global const float4 *suns, __global const int *keys, \
    const int key
#define OCLS_SUN_ARG(name) name##_unread
/* the sun of cell (i, j): declares sunvec, frac and elevation; returns when its block's key is not key */
#define OCLS_TABLE_SUN(i, j) \
    const int block_ = band[i] + band[H + (j)]; \
    if (keys[block_] != key) return; \
    const float4 sunvec = suns[2 * block_], at_ = suns[2 * block_ + 1]; \
    const float frac = at_.x, elevation = at_.y; \
    const float2 cell = at_.zw
#else
#define OCLS_SUN_PARAMS
#define OCLS_SUN_ARG(name) name
#define OCLS_TABLE_SUN(i, j) (void)0
#endif

__kernel void sunshine_masks(__global const float *h, const int H, const int W, const float2 OCLS_SUN_ARG(cell),
                             __global const uchar *mask, const float4 OCLS_SUN_ARG(sunvec), const uint weight,
                             const float hours, __global uint *sun, __global uint *cast, __global float2 *beam
                             OCLS_SUN_PARAMS)
{
    const int j = get_global_id(0), i = get_global_id(1);
    if (j >= W || i >= H) return;
    OCLS_TABLE_SUN(i, j);
    const uchar m = mask[i * W + j];
    if (m == 255) return;
    accumulate(h, H, W, i, j, cell, m == 1, sunvec, weight, hours, sun, cast, beam);
}

__kernel void sunshine_horizons(__global const float *h, const int H, const int W, const float2 OCLS_SUN_ARG(cell),
                                __global const float *low, __global const float *high,
                                const float OCLS_SUN_ARG(frac), const float OCLS_SUN_ARG(elevation),
                                const float4 OCLS_SUN_ARG(sunvec), const uint weight, const float hours,
                                __global uint *sun, __global uint *cast, __global float2 *beam OCLS_SUN_PARAMS)
{
    const int j = get_global_id(0), i = get_global_id(1);
    if (j >= W || i >= H) return;
    OCLS_TABLE_SUN(i, j);
    const int idx = i * W + j;
    if (isnan(h[idx])) return;
    const float a = low[idx], b = high[idx];
    accumulate(h, H, W, i, j, cell, a + frac * (b - a) > elevation, sunvec, weight, hours, sun, cast, beam);
}
