/* ssao.cl — screen-space ambient occlusion over a G-buffer (paper 001):
 * preparation, the AO estimator, the N x N box blur and an edge-aware blur.
 *
 * ABI summary: four kernels, each one work-item per pixel, global size
 * (W, H) rounded up to any local size (surplus items return at once).
 * Buffers are row-major, one row of W pixels after another; float4 fields
 * are the G-buffer's (oclshade/gbuffer.py): pos = view-space x, y, z and
 * w = 1 hit / 0 empty; nrm = view-space unit normal (w unused).
 *
 *   ssao_prepare(pos, nrm, [alpha, alpha_eps], [nmap, tangent,] W, H, zbuf, nout)
 *     zbuf  float, W*H (out): view-space z of the pixel's surface, -INFINITY
 *           when the pixel is empty (pos.w < 0.5, a non-finite position, or
 *           under -D OCLS_ALPHA alpha < alpha_eps: the paper's discarded
 *           cut-out fragment).  An empty pixel gets no AO and occludes nothing.
 *     nout  float4, W*H (out): the normal the AO pass uses; without -D
 *           OCLS_NORMAL_MAP a copy of nrm, with it the mapped normal
 *           N' = normalize(T n.x + B n.y + N n.z), nmap = tangent-space normal
 *           per pixel (float4, xyz in [-1, 1], already sampled at the pixel),
 *           tangent = view-space tangent per pixel (float4: xyz, w = +-1
 *           handedness), T made orthogonal to N by Gram-Schmidt, B = w N x T
 *           (the paper's N_vcs = (M_mv^-1)^T M_ts^-1 N_ts per pixel).
 *           Degenerate T (parallel to N, zero) keeps N unmapped.
 *   ssao_ao(pos, nout, zbuf, W, H, prx, pry, prw, kern, m, radius, delta,
 *           seed, ao)
 *     prx, pry, prw  float4: rows 0, 1 and 3 of the projection matrix
 *     kern  __constant float4 *, m entries: the tangent-space sample kernel
 *           (unit radius, z along the normal), generated once by the host
 *     m     int, 1..256; radius, delta float (radius > 0); seed uint
 *     ao    float, W*H (out): unoccluded fraction 1 - k, 1 on empty pixels
 *   ssao_box_h(ao, zbuf, W, H, half, tmp)      -D OCLS_BLUR_BOX
 *   ssao_box_v(tmp, zbuf, W, H, half, out)     -D OCLS_BLUR_BOX
 *     tmp float2 W*H: (sum of AO over hit pixels, count of hit pixels) in the
 *     horizontal window; out = mean over the hit pixels of the clipped
 *     (2 half + 1)^2 window.  Separable exactly: the 2-D sums are products
 *     of 1-D windows (clipping at the border too); empty pixels stay 1.
 *   ssao_edge(ao, pos, nout, zbuf, W, H, half, plane_tol, out)  -D OCLS_BLUR_EDGE
 *     weighted mean over the (2 half + 1)^2 window (not separable: the
 *     weights depend on the pair of pixels), see "Edge-aware blur" below.
 *
 * -D options: OCLS_ALPHA (alpha map), OCLS_NORMAL_MAP (normal map),
 *   OCLS_RANGE_CHECK (range check), OCLS_BLUR_BOX, OCLS_BLUR_EDGE (which blur
 *   kernels the program holds).  A feature not defined is not compiled.
 *
 * AO estimator (paper 001, "AO map"), for a hit pixel with P, N:
 *   1. per-pixel rotation vector V_r = (2 f1 - 1, 2 f2 - 1, 0) from the
 *      integer hash ocls_pixel_hash(col, row, seed) (f = (2k + 1) 2^-25 for a
 *      24-bit k, so V_r is exact in float32 and float64 alike);
 *   2. Gram-Schmidt: T = normalize(V_r - N (V_r . N)), B = N x T; when
 *      |V_r - N (V_r . N)|^2 < 1e-8 (V_r along N) T comes from the view axis
 *      least aligned with N instead (the paper does not say);
 *   3. for each sample S_t: A_t = P + R (T S.x + B S.y + N S.z); clip = M_pr A_t;
 *      a sample with clip.w <= 0 (behind the camera) or whose pixel
 *      (floor((ndc.x + 1) W / 2), floor((1 - ndc.y) H / 2)) is off screen is
 *      skipped: not counted at all (the paper does not say; clamping to the
 *      edge would invent occluders, counting it as open would lighten
 *      borders);
 *   4. the sample is occluded iff z_t >= A_t.z + delta (z_t = zbuf at its
 *      pixel; an empty pixel has z_t = -inf and never occludes); with
 *      OCLS_RANGE_CHECK also z_t - P.z <= R (an occluder more than R in
 *      front of P cannot be inside the hemisphere; the paper has no check);
 *   5. AO = 1 - occluded / counted (1 when nothing is counted).
 *   Normals with |N|^2 not in (1e-12, inf) (zero, NaN) give AO = 1.
 *
 * Edge-aware blur: weight of neighbour q for centre p (both hit) is
 *   w = c^4 / (1 + (d / plane_tol)^2),  c = max(N_p . N_q, 0),
 *   d = |N_p . (P_q - P_p)|  (distance of q from p's tangent plane);
 * the centre has weight 1.  Only +, *, / are used, no exp.
 */
#include "common.h"

#define OCLS_HASH_SALT 0x9e3779b9u

/* A 32-bit integer mix (xorshift-multiply rounds); CPU twin: reference/ao.py. */
OCLS_INLINE uint ocls_mix(uint x)
{
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

OCLS_INLINE uint ocls_pixel_hash(uint col, uint row, uint seed)
{
    return ocls_mix(col ^ ocls_mix(row ^ ocls_mix(seed)));
}

/* 2 f - 1 with f = (2k + 1) 2^-25, k = the top 24 bits of h: exact. */
OCLS_INLINE float ocls_signed_unit(uint h)
{
    const int k = (int)(h >> 8);
    return (float)(2 * k + 1 - (1 << 24)) * 0x1p-24f;
}

__kernel void ssao_prepare(__global const float4 *pos, __global const float4 *nrm,
#ifdef OCLS_ALPHA
                           __global const float *alpha, float alpha_eps,
#endif
#ifdef OCLS_NORMAL_MAP
                           __global const float4 *nmap, __global const float4 *tangent,
#endif
                           int W, int H, __global float *zbuf, __global float4 *nout)
{
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= W || r >= H) return;
    const int i = r * W + c;
    const float4 p = pos[i];
    int hit = p.w >= 0.5f && isfinite(p.x) && isfinite(p.y) && isfinite(p.z);
#ifdef OCLS_ALPHA
    hit = hit && alpha[i] >= alpha_eps;
#endif
    zbuf[i] = hit ? p.z : -INFINITY;
    float4 n = nrm[i];
#ifdef OCLS_NORMAL_MAP
    {
        const float3 N = n.xyz;
        const float4 tg = tangent[i];
        const float3 t0 = tg.xyz - N * dot(tg.xyz, N);
        const float tt = dot(t0, t0);
        if (tt > 1e-12f && isfinite(tt)) {
            const float3 T = t0 / sqrt(tt);
            const float3 B = cross(N, T) * (tg.w < 0.0f ? -1.0f : 1.0f);
            const float4 q = nmap[i];
            const float3 m = T * q.x + B * q.y + N * q.z;
            const float mm = dot(m, m);
            if (mm > 1e-12f && isfinite(mm))
                n = (float4)(m / sqrt(mm), 0.0f);
        }
    }
#endif
    nout[i] = n;
}

__kernel void ssao_ao(__global const float4 *pos, __global const float4 *nrm,
                      __global const float *zbuf, int W, int H,
                      float4 prx, float4 pry, float4 prw,
                      __constant float4 *kern, int m, float radius, float delta, uint seed,
                      __global float *ao)
{
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= W || r >= H) return;
    const int i = r * W + c;
    const float zc = zbuf[i];
    float3 N = nrm[i].xyz;
    const float nn = dot(N, N);
    if (zc == -INFINITY || !(nn > 1e-12f && nn < INFINITY)) {
        ao[i] = 1.0f;
        return;
    }
    N = N / sqrt(nn);
    const float3 P = pos[i].xyz;

    /* steps 1-2: rotation vector and Gram-Schmidt */
    const uint h = ocls_pixel_hash((uint)c, (uint)r, seed);
    float3 v = (float3)(ocls_signed_unit(h), ocls_signed_unit(ocls_mix(h ^ OCLS_HASH_SALT)), 0.0f);
    float3 t0 = v - N * dot(v, N);
    float tt = dot(t0, t0);
    if (!(tt >= 1e-8f)) {
        const float ax = fabs(N.x), ay = fabs(N.y), az = fabs(N.z);
        v = (ax <= ay && ax <= az) ? (float3)(1.0f, 0.0f, 0.0f)
          : (ay <= az ? (float3)(0.0f, 1.0f, 0.0f) : (float3)(0.0f, 0.0f, 1.0f));
        t0 = v - N * dot(v, N);
        tt = dot(t0, t0);
    }
    const float3 T = t0 / sqrt(tt);
    const float3 B = cross(N, T);
    const float3 RT = T * radius, RB = B * radius, RN = N * radius;
    const float fw = 0.5f * (float)W, fh = 0.5f * (float)H;

    /* steps 3-5 */
    int counted = 0, occluded = 0;
    for (int t = 0; t < m; ++t) {
        const float4 s = kern[t];
        const float3 A = P + (RT * s.x + RB * s.y + RN * s.z);
        const float cw = prw.x * A.x + prw.y * A.y + prw.z * A.z + prw.w;
        const float cx = prx.x * A.x + prx.y * A.y + prx.z * A.z + prx.w;
        const float cy = pry.x * A.x + pry.y * A.y + pry.z * A.z + pry.w;
        const float u = (cx / cw + 1.0f) * fw;
        const float y = (1.0f - cy / cw) * fh;
        const int on = cw > 0.0f && u >= 0.0f && u < (float)W && y >= 0.0f && y < (float)H;
        const int j = on ? (int)y * W + (int)u : i;
        const float zt = zbuf[j];
        int occ = zt >= A.z + delta;
#ifdef OCLS_RANGE_CHECK
        occ = occ && zt - P.z <= radius;
#endif
        counted += on;
        occluded += on && occ;
    }
    ao[i] = counted > 0 ? 1.0f - (float)occluded / (float)counted : 1.0f;
}

#ifdef OCLS_BLUR_BOX
__kernel void ssao_box_h(__global const float *ao, __global const float *zbuf, int W, int H,
                         int half, __global float2 *tmp)
{
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= W || r >= H) return;
    const int row = r * W;
    float sum = 0.0f, count = 0.0f;
    const int lo = max(c - half, 0), hi = min(c + half, W - 1);
    for (int k = lo; k <= hi; ++k) {
        const int hit = zbuf[row + k] != -INFINITY;
        sum += hit ? ao[row + k] : 0.0f;
        count += hit ? 1.0f : 0.0f;
    }
    tmp[row + c] = (float2)(sum, count);
}

__kernel void ssao_box_v(__global const float2 *tmp, __global const float *zbuf, int W, int H,
                         int half, __global float *out)
{
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= W || r >= H) return;
    const int i = r * W + c;
    if (zbuf[i] == -INFINITY) {
        out[i] = 1.0f;
        return;
    }
    float2 acc = (float2)(0.0f, 0.0f);
    const int lo = max(r - half, 0), hi = min(r + half, H - 1);
    for (int k = lo; k <= hi; ++k)
        acc += tmp[k * W + c];
    out[i] = acc.x / acc.y;   /* acc.y >= 1: the centre is a hit */
}
#endif

#ifdef OCLS_BLUR_EDGE
__kernel void ssao_edge(__global const float *ao, __global const float4 *pos,
                        __global const float4 *nrm, __global const float *zbuf, int W, int H,
                        int half, float plane_tol, __global float *out)
{
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= W || r >= H) return;
    const int i = r * W + c;
    if (zbuf[i] == -INFINITY) {
        out[i] = 1.0f;
        return;
    }
    const float3 P = pos[i].xyz, N = nrm[i].xyz;
    const float inv_tol = 1.0f / plane_tol;
    float sum = 0.0f, wsum = 0.0f;
    const int r0 = max(r - half, 0), r1 = min(r + half, H - 1);
    const int c0 = max(c - half, 0), c1 = min(c + half, W - 1);
    for (int y = r0; y <= r1; ++y) {
        for (int x = c0; x <= c1; ++x) {
            const int j = y * W + x;
            const int hit = zbuf[j] != -INFINITY;
            const float3 q = pos[j].xyz;
            const float cs = fmax(dot(N, nrm[j].xyz), 0.0f);
            const float c2 = cs * cs;
            const float d = fabs(dot(N, q - P)) * inv_tol;
            const float w = hit ? (c2 * c2) / (1.0f + d * d) : 0.0f;
            sum += w * ao[j];
            wsum += w;
        }
    }
    out[i] = wsum > 0.0f ? sum / wsum : ao[i];
}
#endif
