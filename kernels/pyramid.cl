/* pyramid.cl — mean mip pyramid and extrema (max/min) pyramid of a heightmap.
 *
 * Surface model: bilinear interpolation between cell-centre samples.  A
 * "patch" (r, c) is the square between samples (r..r+1, c..c+1); an H x W map
 * has Hp x Wp = max(H-1,1) x max(W-1,1) patches (a single row or column gets
 * one degenerate patch row/column whose missing corners are holes).
 *
 * Extrema pyramid (paper 000 stage 1, made to bound the exact surface model):
 *   level 0      : one texel per patch: x = max of the patch's valid corners
 *                  (bounds the bilinear patch and any valid edge of it),
 *                  y = min of its corners, or -INF if any corner is a hole
 *                  (a tile with a hole can never prove "certainly shadowed");
 *                  x = -INF when no corner is valid (occludes nothing).
 *   level l > 0  : ceil(Hp/2^l) x ceil(Wp/2^l) texels, each the max / min of
 *                  the (up to) 2x2 texels of level l-1 below it.  The last
 *                  level is 1 x 1 (the global max/min).
 *   Bilinear interpolation is a convex combination of its corners, so level
 *   l bounds the surface over its 2^l x 2^l patches exactly; min/max only, so
 *   every device produces bit-identical pyramids.
 *
 * Mean mip pyramid: level 0 = the samples; level l = mean of the valid
 *   samples among the (up to) 2x2 below, summed in the fixed order
 *   (r,c), (r,c+1), (r+1,c), (r+1,c+1) and divided by their count; NaN if none.
 *
 * ABI
 *   extrema_base(h, H, W, out, Hp, Wp)       global (Wp, Hp), any local size
 *       __global const float *h   H*W samples, NaN = hole
 *       __global float2 *out      Hp*Wp texels of level 0
 *   extrema_reduce(ext, in_off, Rin, Cin, out_off, R, C)  global (C, R)
 *       __global float2 *ext  the whole pyramid; level l-1 (Rin x Cin) starts
 *       at in_off, level l (R x C) at out_off (offsets in float2 units)
 *   mip_reduce(in, Rin, Cin, out, R, C)      global (C, R)
 *       in: level l-1 (Rin x Cin float), out: level l (R x C float)
 *   No -D options.
 */
#include "common.h"

__kernel void extrema_base(__global const float *h, const int H, const int W,
                           __global float2 *out, const int Hp, const int Wp)
{
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= Wp || r >= Hp) return;
    const float a = ocls_sample(h, H, W, r, c), b = ocls_sample(h, H, W, r, c + 1);
    const float d = ocls_sample(h, H, W, r + 1, c), e = ocls_sample(h, H, W, r + 1, c + 1);
    float hi = fmax(fmax(a, b), fmax(d, e));          /* fmax ignores NaN */
    float lo = fmin(fmin(a, b), fmin(d, e));
    if (isnan(hi)) hi = -INFINITY;
    if (isnan(a) || isnan(b) || isnan(d) || isnan(e)) lo = -INFINITY;
    out[r * Wp + c] = (float2)(hi, lo);
}

__kernel void extrema_reduce(__global float2 *ext, const int in_off, const int Rin, const int Cin,
                             const int out_off, const int R, const int C)
{
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= C || r >= R) return;
    __global const float2 *in = ext + in_off;
    __global float2 *out = ext + out_off;
    const int r0 = 2 * r, c0 = 2 * c;
    const int r1 = min(r0 + 1, Rin - 1), c1 = min(c0 + 1, Cin - 1);
    const float2 p = in[r0 * Cin + c0], q = in[r0 * Cin + c1];
    const float2 s = in[r1 * Cin + c0], t = in[r1 * Cin + c1];
    out[r * C + c] = (float2)(fmax(fmax(p.x, q.x), fmax(s.x, t.x)),
                              fmin(fmin(p.y, q.y), fmin(s.y, t.y)));
}

__kernel void mip_reduce(__global const float *in, const int Rin, const int Cin,
                         __global float *out, const int R, const int C)
{
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= C || r >= R) return;
    const int r0 = 2 * r, c0 = 2 * c;
    float sum = 0.0f;
    int n = 0;
    for (int dr = 0; dr < 2; ++dr) {
        for (int dc = 0; dc < 2; ++dc) {
            const int rr = r0 + dr, cc = c0 + dc;
            if (rr < Rin && cc < Cin) {
                const float v = in[rr * Cin + cc];
                if (!isnan(v)) { sum = sum + v; n += 1; }
            }
        }
    }
    out[r * C + c] = n > 0 ? sum / (float)n : NAN;
}
