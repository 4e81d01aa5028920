/* pyramid.cl — mean mip pyramid and extrema (max/min) pyramid of a heightmap.
 *
 * Surface model: bilinear interpolation between cell-centre samples.  A
 * "patch" (r, c) is the square between samples (r..r+1, c..c+1); an H x W map
 * has Hp x Wp = max(H-1,1) x max(W-1,1) patches (a single row or column gets
 * one degenerate patch row/column whose missing corners are holes).
 *
 * Extrema pyramid (paper 000 stage 1, made to bound the exact surface model).
 * Level l covers tiles of 2^l x 2^l patches; level 0 is the heightmap itself
 * (the traversal tests patches exactly there), so the buffer holds levels
 * 1..L, L being the first level of 1 x 1 texels (L >= 1):
 *   level 1      : ceil(Hp/2) x ceil(Wp/2) texels, each over the (up to 3x3)
 *                  samples of its (up to 2x2) patches: x = max of the valid
 *                  samples (bounds every valid patch and edge), -INF if none;
 *                  y = min of the samples, -INF if any is a hole (a tile with a
 *                  hole can never prove "certainly shadowed").
 *   level l > 1  : ceil(Hp/2^l) x ceil(Wp/2^l) texels, each the max / min of
 *                  the (up to) 2x2 texels of level l-1 below it.
 *   Bilinear interpolation is a convex combination of its corners, so level
 *   l bounds the surface over its 2^l x 2^l patches exactly; min/max only, so
 *   every device produces bit-identical pyramids.
 *
 * Mean mip pyramid: level 0 = the samples; level l = mean of the valid
 *   samples among the (up to) 2x2 below, summed in the fixed order
 *   (r,c), (r,c+1), (r+1,c), (r+1,c+1) and divided by their count; NaN if none.
 *
 * ABI (int arguments are 32-bit ints; global sizes may be rounded up to any
 * local size: work-items past (C, R) return at once)
 *   extrema_base(h, H, W, out, Hp, Wp, R, C)  global (C, R)
 *       __global const float *h   H*W samples, NaN = hole (the heights the
 *                                 shadow pass will read, same buffer or values)
 *       __global float2 *out      R*C texels of level 1 (R = ceil(Hp/2), C = ceil(Wp/2)),
 *                                 i.e. the pyramid buffer at offset 0
 *   extrema_reduce(ext, in_off, Rin, Cin, out_off, R, C)  global (C, R)
 *       __global float2 *ext  the whole pyramid; level l-1 (Rin x Cin) starts
 *       at in_off, level l (R x C) at out_off (offsets in float2 units);
 *       launched for l = 2..L in order, each after the previous one
 *   Pyramid buffer: levels 1..L back to back, level 1 at texel 0, level l at
 *   the sum of (rows x cols) of levels 1..l-1; level l has
 *   ceil(Hp/2^l) x ceil(Wp/2^l) texels.  The level-offset table the shadow
 *   pass reads (shadow.cl, lvl_off) is int32[L+1]: [l] = that offset, [0]
 *   unused (the hosts store -1).
 *   mip_reduce(in, Rin, Cin, out, R, C)      global (C, R)
 *       in: level l-1 (Rin x Cin float), out: level l (R x C float)
 *   -D OCLS_BASE_LANES=N (N = 4, 8 or 16; chosen per device by the tuning
 *   lookup, usually on CPU devices): extrema_base computes N texels of a row
 *   per work-item, global (ceil(C/N), R), on floatN lanes from contiguous
 *   loads (PoCL runs the one-texel kernel on scalar code: 36 of the 72 ms of
 *   a 4096^2 pyramid on an AVX-512 Xeon); the same texels bit
 *   for bit (min / max of the same samples).  No other -D options; the hosts
 *   build with -cl-std=CL1.2 and paste common.h in place of its include (a
 *   build of your own may instead pass -I <this folder>).
 */
#include "common.h"

/* Level-1 texel (r, c): max / min over the samples of its (up to 2 x 2) patches. */
OCLS_INLINE float2 base_texel(__global const float *h, int H, int W, int Hp, int Wp, int r, int c)
{
    /* samples of patches 2r..min(2r+1, Hp-1) x 2c..min(2c+1, Wp-1) */
    const int r_end = min(2 * r + 1, Hp - 1) + 1, c_end = min(2 * c + 1, Wp - 1) + 1;
    float hi = -INFINITY, lo = INFINITY;
    int hole = 0;
    if (r_end == 2 * r + 2 && c_end == 2 * c + 2) {   /* a full 3 x 3 block: straight-line code */
        __global const float *p = h + 2 * r * W + 2 * c;
#define OCLS_TAKE(k) { const float v = p[k]; hole |= isnan(v); hi = fmax(hi, v); lo = fmin(lo, v); }
        OCLS_TAKE(0) OCLS_TAKE(1) OCLS_TAKE(2)
        OCLS_TAKE(W) OCLS_TAKE(W + 1) OCLS_TAKE(W + 2)
        OCLS_TAKE(2 * W) OCLS_TAKE(2 * W + 1) OCLS_TAKE(2 * W + 2)
#undef OCLS_TAKE
        return (float2)(hi, hole ? -INFINITY : lo);
    }
    for (int i = 2 * r; i <= r_end; ++i) {
        for (int j = 2 * c; j <= c_end; ++j) {
            const float v = ocls_sample(h, H, W, i, j);
            hole |= isnan(v);
            hi = fmax(hi, v);                          /* fmax ignores NaN */
            lo = fmin(lo, v);
        }
    }
    return (float2)(hi, hole ? -INFINITY : lo);
}

__kernel void extrema_base(__global const float *h, const int H, const int W,
                           __global float2 *out, const int Hp, const int Wp, const int R, const int C)
{
#ifdef OCLS_BASE_LANES
#define ocls_floatv OCLS_CAT(float, OCLS_BASE_LANES)
#define ocls_intv OCLS_CAT(int, OCLS_BASE_LANES)
#define OCLS_VLOAD OCLS_LANE_FN(vload, OCLS_BASE_LANES)
#define OCLS_VSTORE OCLS_LANE_FN(vstore, OCLS_BASE_LANES)
/* columns 2k + 2 of the lanes: e shifted by one lane, the last from p[2N] */
#if OCLS_BASE_LANES == 4
#define OCLS_NEXT_EVEN(e, p) ((float4)((e).s123, (p)[8]))
#elif OCLS_BASE_LANES == 8
#define OCLS_NEXT_EVEN(e, p) ((float8)((e).s1234, (e).s567, (p)[16]))
#elif OCLS_BASE_LANES == 16
#define OCLS_NEXT_EVEN(e, p) ((float16)((e).s1234, (e).s5678, (e).s9abc, (e).sdef, (p)[32]))
#else
#error "OCLS_BASE_LANES must be 4, 8 or 16"
#endif
    const int N = OCLS_BASE_LANES, c0 = get_global_id(0) * N, r = get_global_id(1);
    if (c0 >= C || r >= R) return;
    if (c0 + N <= C && 2 * c0 + 2 * N <= Wp && 2 * r + 2 <= Hp) {
        /* N full 3 x 3 blocks: per sample row, e / o / n = columns 2k, 2k + 1, 2k + 2 */
        ocls_floatv hi = -INFINITY, lo = INFINITY;
        ocls_intv hole = 0;
        for (int i = 0; i < 3; ++i) {
            __global const float *p = h + (2 * r + i) * W + 2 * c0;
            const ocls_floatv a = OCLS_VLOAD(0, p), b = OCLS_VLOAD(0, p + N);
            const ocls_floatv e = (ocls_floatv)(a.even, b.even), o = (ocls_floatv)(a.odd, b.odd);
            const ocls_floatv n = OCLS_NEXT_EVEN(e, p);
            hole |= isnan(e) | isnan(o) | isnan(n);
            hi = fmax(hi, fmax(fmax(e, o), n));
            lo = fmin(lo, fmin(fmin(e, o), n));
        }
        float hv[OCLS_BASE_LANES], lv[OCLS_BASE_LANES];
        OCLS_VSTORE(hi, 0, hv);
        OCLS_VSTORE(select(lo, (ocls_floatv)(-INFINITY), hole), 0, lv);
        for (int k = 0; k < N; ++k) out[r * C + c0 + k] = (float2)(hv[k], lv[k]);
        return;
    }
    for (int c = c0; c < min(c0 + N, C); ++c) out[r * C + c] = base_texel(h, H, W, Hp, Wp, r, c);
#else
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= C || r >= R) return;
    out[r * C + c] = base_texel(h, H, W, Hp, Wp, r, c);
#endif
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
