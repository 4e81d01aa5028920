/* mesh_raster.cl — BENCH-ONLY PROTOTYPE (not in the library): a minimal compute rasteriser of
 * a triangle mesh into depth, position and normal, to compare with kernels/mesh.cl's BVH ray
 * caster (bench/mesh_gbuffer.py; docs/meshes.md "Rasteriser or BVH").
 *
 * A visibility buffer in three passes, one work-item per triangle for the first two:
 *   raster_depth(nt, vtx, IW, IH, cam, zbuf)   each triangle's pixels (centres inside its
 *       screen bounding box, edge functions >= 0 for either winding) atomic_min their depth
 *       (perspective-correct 1 / sum(b_k / z_k); positive float bits ordered as uint).
 *   raster_id(nt, vtx, IW, IH, cam, zbuf, ids)  again; the triangle whose depth equals the
 *       pixel's minimum writes its index (equal depths: any one of them).
 *   raster_resolve(vtx, nrm, IW, IH, cam, zbuf, ids, position, normal, depth)  per pixel: the
 *       ray through the pixel against the triangle it holds (float32 Moller-Trumbore, no
 *       bounds) for barycentrics, interpolated normal, view-space position.
 *   vtx: float4 x 3 per triangle, view-space vertices (the host subtracts the camera in
 *   float64); nrm: float4 x 3 per triangle, view-space vertex normals.  cam = (sx, sy, near,
 *   far) as terrain.cl.  zbuf is filled with 0x7f800000 (+inf) and ids with -1 first.
 * Left out, as a prototype: clipping at the near plane (a triangle with a vertex in front
 * of it is dropped), top-left fill rules (shared edges may be drawn twice: harmless for
 * depth), alpha cut-outs, textures.
 */
#pragma OPENCL FP_CONTRACT OFF

static int project(__global const float4 *v, int IW, int IH, float4 cam, float2 *s, float *z)
{
    for (int k = 0; k < 3; ++k) {
        const float d = -v[k].z;
        if (!(d > cam.z)) return 0;
        const float nx = v[k].x / (d * cam.x), ny = v[k].y / (d * cam.y);
        s[k] = (float2)(((nx + 1.0f) * (float)IW - 1.0f) * 0.5f, ((1.0f - ny) * (float)IH - 1.0f) * 0.5f);
        z[k] = d;
    }
    return 1;
}

static float edge(float2 a, float2 b, float2 p) { return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x); }

#define RASTER_LOOP(BODY)                                                                            \
    float2 s[3];                                                                                     \
    float z[3];                                                                                      \
    if (!project(vtx + 3 * t, IW, IH, cam, s, z)) return;                                            \
    const float area = edge(s[0], s[1], s[2]);                                                       \
    if (area == 0.0f) return;                                                                        \
    const int x0 = max((int)ceil(fmin(fmin(s[0].x, s[1].x), s[2].x)), 0);                            \
    const int x1 = min((int)floor(fmax(fmax(s[0].x, s[1].x), s[2].x)), IW - 1);                      \
    const int y0 = max((int)ceil(fmin(fmin(s[0].y, s[1].y), s[2].y)), 0);                            \
    const int y1 = min((int)floor(fmax(fmax(s[0].y, s[1].y), s[2].y)), IH - 1);                      \
    const float inv = 1.0f / area;                                                                   \
    for (int y = y0; y <= y1; ++y)                                                                   \
        for (int x = x0; x <= x1; ++x) {                                                             \
            const float2 p = (float2)((float)x, (float)y);                                           \
            const float b0 = edge(s[1], s[2], p) * inv, b1 = edge(s[2], s[0], p) * inv,              \
                        b2 = edge(s[0], s[1], p) * inv;                                              \
            if (b0 < 0.0f || b1 < 0.0f || b2 < 0.0f) continue;                                       \
            const float d = 1.0f / (b0 / z[0] + b1 / z[1] + b2 / z[2]);                              \
            if (!(d >= cam.z && d <= cam.w)) continue;                                               \
            const int i = y * IW + x;                                                                \
            BODY                                                                                     \
        }

__kernel void raster_depth(const int nt, __global const float4 *vtx, const int IW, const int IH, const float4 cam,
                           volatile __global uint *zbuf)
{
    const int t = get_global_id(0);
    if (t >= nt) return;
    RASTER_LOOP(atomic_min(&zbuf[i], as_uint(d));)
}

__kernel void raster_id(const int nt, __global const float4 *vtx, const int IW, const int IH, const float4 cam,
                        __global const uint *zbuf, __global int *ids)
{
    const int t = get_global_id(0);
    if (t >= nt) return;
    RASTER_LOOP(if (as_uint(d) == zbuf[i]) ids[i] = t;)
}

__kernel void raster_resolve(__global const float4 *vtx, __global const float4 *nrm, const int IW, const int IH,
                             const float4 cam, __global const uint *zbuf, __global const int *ids,
                             __global float4 *position, __global float4 *normal, __global float *depth)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= IW || y >= IH) return;
    const int i = y * IW + x, t = ids[i];
    if (t < 0) {
        position[i] = (float4)(0.0f); normal[i] = (float4)(0.0f); depth[i] = INFINITY;
        return;
    }
    const float nx = (2.0f * (float)x + 1.0f) / (float)IW - 1.0f, ny = 1.0f - (2.0f * (float)y + 1.0f) / (float)IH;
    const float3 d = (float3)(nx * cam.x, ny * cam.y, -1.0f);
    __global const float4 *v = vtx + 3 * t;
    const float3 e1 = v[1].xyz - v[0].xyz, e2 = v[2].xyz - v[0].xyz, pv = cross(d, e2);
    const float det = dot(e1, pv), inv = det != 0.0f ? 1.0f / det : 0.0f;
    const float3 tv = -v[0].xyz, qv = cross(tv, e1);
    const float b1 = dot(tv, pv) * inv, b2 = dot(d, qv) * inv, tt = dot(e2, qv) * inv;
    __global const float4 *n = nrm + 3 * t;
    float3 nn = (1.0f - b1 - b2) * n[0].xyz + b1 * n[1].xyz + b2 * n[2].xyz;
    if (dot(cross(e1, e2), d) > 0.0f) nn = -nn;
    position[i] = (float4)(tt * d, 1.0f);
    normal[i] = (float4)(normalize(nn), 0.0f);
    depth[i] = as_float(zbuf[i]);
}
