/* terrain_ray.h — the exact terrain occlusion test of a sun ray from a surface point: every
 * bilinear patch under the ray tested in closed form (shadow.cl's patch test; float64 twin
 * oclshade.reference.quadrics.terrain_margin).  Shared by the object passes that shade
 * their own pixels against the terrain (quadric.cl, mesh.cl).
 *   terrain_blocks(h, H, W, zmax, p, ray): 1 iff the terrain hides the sun from p = (u, v,
 *   z - offset) (heightmap coordinates: u column, v row; relative heights h, NaN = hole);
 *   ray = (ux, uy, w, 0): the sun ray per horizontal metre in cells, rise w = tan(elevation).
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

/* 1 iff the terrain occludes the sun ray from p = (u, v, z) (every patch under the ray). */
OCLS_INLINE int terrain_blocks(__global const float *h, int H, int W, float zmax, float3 p, float4 ray)
{
    if (H < 2 || W < 2 || (ray.x == 0.0f && ray.y == 0.0f)) return 0;
    float t0 = 0.0f, t1 = ray.z > 0.0f ? (zmax - p.z) / ray.z : INFINITY;   /* above zmax: lit */
    const float lo[2] = {0.0f, 0.0f}, hi[2] = {(float)(W - 1), (float)(H - 1)};
    const float pos[2] = {p.x, p.y}, dir[2] = {ray.x, ray.y};
    for (int a = 0; a < 2; ++a) {
        if (dir[a] == 0.0f) {
            if (pos[a] < lo[a] || pos[a] > hi[a]) return 0;
        } else {
            const float ta = (lo[a] - pos[a]) / dir[a], tb = (hi[a] - pos[a]) / dir[a];
            t0 = fmax(t0, fmin(ta, tb));
            t1 = fmin(t1, fmax(ta, tb));
        }
    }
    if (!(t0 < t1)) return 0;
    const int sx = ray.x > 0.0f ? 1 : (ray.x < 0.0f ? -1 : 0), sy = ray.y > 0.0f ? 1 : (ray.y < 0.0f ? -1 : 0);
    const float x = p.x + ray.x * t0, y = p.y + ray.y * t0;
    int pc = clamp(sx < 0 ? ocls_ceil_int(x) - 1 : ocls_floor_int(x), 0, W - 2);
    int pr = clamp(sy < 0 ? ocls_ceil_int(y) - 1 : ocls_floor_int(y), 0, H - 2);
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

#endif
