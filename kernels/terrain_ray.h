/* terrain_ray.h — the exact terrain occlusion test of a sun ray from a surface point: every
 * bilinear patch under the ray tested in closed form (shadow.cl's patch test; float64 twin
 * oclshade.reference.quadrics.terrain_margin).  Shared by the object passes that shade
 * their own pixels against the terrain (quadric.cl, mesh.cl).
 *   terrain_blocks(h, H, W, zmax, p, ray): 1 iff the terrain hides the sun from p = (u, v,
 *   z - offset) (heightmap coordinates: u column, v row; relative heights h, NaN = hole);
 *   ray = (ux, uy, w, 0): the sun ray per horizontal metre in cells, rise w = tan(elevation).
 *   terrain_segment_blocks(h, H, W, zmax, p, seg, surface): 1 iff the terrain rises strictly
 *   above the segment p + t seg.xyz, 0 < t <= 1, from p to a point light (same coordinates;
 *   seg.w = t_near, one cell along the segment's major axis: 1 / max(|seg.x|, |seg.y|));
 *   twin oclshade.reference.quadrics.terrain_segment_occludes.  A segment along z (the light
 *   straight above or below p) tests the patch under p.  surface != 0: p is a terrain
 *   surface point (a terrain pixel): its height is the bilinear surface's at (u, v) (p.z is
 *   not read) and f = S - z starts at 0: in the start patch f(t) = t (a + s2 t) (a > 0, the
 *   light below the local surface, blocks at once), and while t < t_near f is carried from
 *   patch to patch from the slopes (shadow.cl's near start: a start a hair's breadth off a
 *   grid line would otherwise compare two independently rounded heights and flip its
 *   verdict); beyond t_near, and after a hole, heights are compared directly.  The start
 *   patch is the first valid patch the segment meets before t_near (a start rounded off
 *   the map's edge or into a hole next to its patch is put on that patch's surface,
 *   extended; f(t_in) = t_in (a0 + s2 t_in) from the start); with none, p.z is used.
 */
#ifndef OCLS_TERRAIN_RAY_H
#define OCLS_TERRAIN_RAY_H
#include "common.h"

/* 1 iff the bilinear surface rises strictly above the ray inside patch (pr, pc) between
 * t_in and t_out (the twin: reference.quadrics.terrain_margin; shadow.cl's patch test). */
OCLS_INLINE int patch_above(__global const float *h, int W, int pr, int pc, float3 p, float4 ray, float t_in,
                            float t_out)
{
    __global const float *c = h + pr * W + pc;
    const float h00 = c[0], h01 = c[1], h10 = c[W], h11 = c[W + 1];
    if (isnan(h00) || isnan(h01) || isnan(h10) || isnan(h11)) return 0;
    const float fx = (p.x + ray.x * t_in) - (float)pc, fy = (p.y + ray.y * t_in) - (float)pr;
    const float ex = h01 - h00, ey = h10 - h00, k = (h00 - h01) - (h10 - h11);
    const float s_a = h00 + ex * fx + ey * fy + k * (fx * fy);
    const float a = (ex + k * fy) * ray.x + (ey + k * fx) * ray.y - ray.z;
    const float s2 = k * (ray.x * ray.y);
    const float len = t_out - t_in;
    const float f_a = s_a - (p.z + ray.z * t_in);
    if (f_a > 0.0f) return 1;
    if (f_a + (a + s2 * len) * len > 0.0f) return 1;
    if (s2 < 0.0f) {
        const float tau = -a / (2.0f * s2);
        if (tau > 0.0f && tau < len && f_a - (a * a) / (4.0f * s2) > 0.0f) return 1;
    }
    return 0;
}

/* Clip the line p + t dir (dir.xy) to the map's sample box [0, W-1] x [0, H-1], narrowing
 * [t0, t1]; 0 when nothing is left, else 1 with (pr, pc) the patch the line enters at t0. */
OCLS_INLINE int clip_to_map(int H, int W, float3 p, float4 dir, float *t0, float *t1, int *pc, int *pr)
{
    const float lo[2] = {0.0f, 0.0f}, hi[2] = {(float)(W - 1), (float)(H - 1)};
    const float pos[2] = {p.x, p.y}, d[2] = {dir.x, dir.y};
    for (int a = 0; a < 2; ++a) {
        if (d[a] == 0.0f) {
            if (pos[a] < lo[a] || pos[a] > hi[a]) return 0;
        } else {
            const float ta = (lo[a] - pos[a]) / d[a], tb = (hi[a] - pos[a]) / d[a];
            *t0 = fmax(*t0, fmin(ta, tb));
            *t1 = fmin(*t1, fmax(ta, tb));
        }
    }
    if (!(*t0 < *t1)) return 0;
    const float x = p.x + dir.x * *t0, y = p.y + dir.y * *t0;
    *pc = clamp(dir.x < 0.0f ? ocls_ceil_int(x) - 1 : ocls_floor_int(x), 0, W - 2);
    *pr = clamp(dir.y < 0.0f ? ocls_ceil_int(y) - 1 : ocls_floor_int(y), 0, H - 2);
    return 1;
}

/* 1 iff the terrain occludes the sun ray from p = (u, v, z) (every patch under the ray). */
OCLS_INLINE int terrain_blocks(__global const float *h, int H, int W, float zmax, float3 p, float4 ray)
{
    if (H < 2 || W < 2 || (ray.x == 0.0f && ray.y == 0.0f)) return 0;
    float t0 = 0.0f, t1 = ray.z > 0.0f ? (zmax - p.z) / ray.z : INFINITY;   /* above zmax: lit */
    int pc, pr;
    if (!clip_to_map(H, W, p, ray, &t0, &t1, &pc, &pr)) return 0;
    const int sx = ray.x > 0.0f ? 1 : (ray.x < 0.0f ? -1 : 0), sy = ray.y > 0.0f ? 1 : (ray.y < 0.0f ? -1 : 0);
    float t = t0;
    for (int it = 0; it < H + W + 4; ++it) {
        const float tx = sx != 0 ? ((float)(sx > 0 ? pc + 1 : pc) - p.x) / ray.x : INFINITY;
        const float ty = sy != 0 ? ((float)(sy > 0 ? pr + 1 : pr) - p.y) / ray.y : INFINITY;
        const float t_out = fmin(fmin(tx, ty), t1);
        if (patch_above(h, W, pr, pc, p, ray, t, t_out)) return 1;
        if (t_out >= t1) return 0;
        if (tx <= ty) pc += sx;
        if (ty <= tx) pr += sy;
        if (pc < 0 || pc > W - 2 || pr < 0 || pr > H - 2) return 0;
        t = t_out;
    }
    return 0;
}

/* 1 iff the terrain rises strictly above the segment p + t seg.xyz, 0 < t <= 1 (header). */
OCLS_INLINE int terrain_segment_blocks(__global const float *h, int H, int W, float zmax, float3 p, float4 seg,
                                       int surface)
{
    if (H < 2 || W < 2) return 0;
    float t0 = 0.0f, t1 = 1.0f;
    int pc, pr;
    if (!clip_to_map(H, W, p, seg, &t0, &t1, &pc, &pr)) return 0;
    const int sx = seg.x > 0.0f ? 1 : (seg.x < 0.0f ? -1 : 0), sy = seg.y > 0.0f ? 1 : (seg.y < 0.0f ? -1 : 0);
    float z0 = p.z;
    int near = 0, first = 0;
    if (surface && t0 < seg.w) {            /* the start patch: the first valid one within t_near */
        int c0 = pc, r0 = pr;
        for (int it = 0; it < 4; ++it) {
            const float tx = sx != 0 ? ((float)(sx > 0 ? c0 + 1 : c0) - p.x) / seg.x : INFINITY;
            const float ty = sy != 0 ? ((float)(sy > 0 ? r0 + 1 : r0) - p.y) / seg.y : INFINITY;
            __global const float *c = h + r0 * W + c0;
            const float h00 = c[0], h01 = c[1], h10 = c[W], h11 = c[W + 1];
            if (!(isnan(h00) || isnan(h01) || isnan(h10) || isnan(h11))) {
                const float fx = p.x - (float)c0, fy = p.y - (float)r0;     /* the start, extended */
                z0 = h00 + (h01 - h00) * fx + (h10 - h00) * fy + ((h00 - h01) - (h10 - h11)) * (fx * fy);
                near = first = 1;
                break;
            }
            if (fmin(tx, ty) >= fmin(seg.w, t1)) break;
            if (tx <= ty) c0 += sx;
            if (ty <= tx) r0 += sy;
            if (c0 < 0 || c0 > W - 2 || r0 < 0 || r0 > H - 2) break;
        }
    }
    if (seg.z > 0.0f) t1 = fmin(t1, (zmax - z0) / seg.z);                   /* above zmax: lit */
    if (!(t0 < t1)) return 0;
    float t = t0, f = 0.0f;
    for (int it = 0; it < H + W + 4; ++it) {
        const float tx = sx != 0 ? ((float)(sx > 0 ? pc + 1 : pc) - p.x) / seg.x : INFINITY;
        const float ty = sy != 0 ? ((float)(sy > 0 ? pr + 1 : pr) - p.y) / seg.y : INFINITY;
        const float t_out = fmin(fmin(tx, ty), t1);
        __global const float *c = h + pr * W + pc;
        const float h00 = c[0], h01 = c[1], h10 = c[W], h11 = c[W + 1];
        if (isnan(h00) || isnan(h01) || isnan(h10) || isnan(h11)) {
            if (!first) near = 0;                                        /* heights after a hole */
        } else {
            const float fx = (p.x + seg.x * t) - (float)pc, fy = (p.y + seg.y * t) - (float)pr;
            const float ex = h01 - h00, ey = h10 - h00, k = (h00 - h01) - (h10 - h11);
            const float a = (ex + k * fy) * seg.x + (ey + k * fx) * seg.y - seg.z;
            const float s2 = k * (seg.x * seg.y);
            const float len = t_out - t;
            float f_a = near ? f : (h00 + ex * fx + ey * fy + k * (fx * fy)) - (z0 + seg.z * t);
            if (first) {                    /* from the start on this patch's surface: f(0) = 0 */
                const float a0 = a - 2.0f * s2 * t;
                f_a = t * (a0 + s2 * t);
            }
            if (first && t == 0.0f ? a > 0.0f : f_a > 0.0f) return 1;
            f = f_a + (a + s2 * len) * len;
            if (f > 0.0f) return 1;
            if (s2 < 0.0f) {
                const float tau = -a / (2.0f * s2);
                if (tau > 0.0f && tau < len && f_a - (a * a) / (4.0f * s2) > 0.0f) return 1;
            }
            if (t_out >= seg.w) near = 0;
            first = 0;
        }
        if (t_out >= t1) return 0;
        if (tx <= ty) pc += sx;
        if (ty <= tx) pr += sy;
        if (pc < 0 || pc > W - 2 || pr < 0 || pr > H - 2) return 0;
        t = t_out;
    }
    return 0;
}

#endif
