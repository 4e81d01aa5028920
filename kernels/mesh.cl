/* mesh.cl — triangle meshes ray-cast through a BVH into a G-buffer (paper 001's G-buffer stage:
 * per-vertex normals, uvs, alpha cut-outs, tangent-space normal maps), their pixels shaded
 * against the terrain, and any-hit shadow rays through the BVH.  Float64 twin:
 * oclshade/reference/meshes.py; host: oclshade/meshes/caster.py; docs/meshes.md.
 *
 * Frames and precision.  Each mesh m keeps its vertices in float32 relative to its own origin
 * (float64 on the host, the centre of its bounds); the host passes the camera position
 * relative to that origin (a float64 difference rounded once), so a mesh 1e7 m from the
 * world origin is cast with the precision of one at the origin.  Rays are built in view
 * space as terrain.cl builds them (t along them is the depth -z_view) and turned to world
 * axes by the camera's rotation (rows vw0..vw2: view -> world); hits go back to view space
 * as o_view + t d_view and the normals by wv0..wv2 (world -> view).
 *
 * Step 1, traversal: the BVH of oclshade/meshes/bvh.py (preorder; near child first; a box is
 * entered when the slab interval [tmin, tmax (1 + 2 gamma_3)] meets [t_lo, best]: the
 * (1 + 2 gamma_3) of Ize, "Robust BVH ray traversal", JCGT 2013, makes float32 slabs
 * conservative).  Step 2, the watertight ray-triangle test of Woop, Benthin and Wald,
 * "Watertight ray/triangle intersection", JCGT 2013: the ray's largest axis kz, shear
 * constants Sx, Sy, Sz, edge functions U, V, W of the sheared vertices; a shared edge gets
 * the same U (negated) in both triangles (same operands, FP_CONTRACT off, rounding symmetric
 * in sign), so no ray passes between two triangles.  Edge ties (U, V or W == 0) count as hits
 * (the paper's double-precision recheck is left out: a tie then hits both triangles, which
 * may differ only in which one reports the hit).  Two-sided: no back-face culling.
 * Step 3, alpha cut-outs: a candidate hit on a textured mesh whose texel alpha (nearest
 * texel of the interpolated uv, uv wrapping) is below the mesh's cutoff is skipped, and the
 * traversal goes on.  Step 4, shading: the per-vertex normals interpolated by the hit's
 * barycentrics, turned to face the viewer when the triangle is seen from its back; a normal
 * map's texel n_ts gives n = normalize(n_ts.x T + n_ts.y B + n_ts.z N) with T the triangle's
 * tangent (along growing u) made orthogonal to N and B = sign cross(N, T) (paper 001).
 *
 * ABI
 *   Per mesh k (nm of them), host-filled:
 *     __global const float4 *mf  3 float4: camera position relative to the mesh origin (xyz);
 *                                colour (linear rgb, w = alpha cutoff); screen rectangle
 *                                (x0, y0, x1, y1) as whole numbers: only pixels x0 <= x < x1,
 *                                y0 <= y < y1 may see the mesh (conservative; mesh_cast only)
 *     __global const int4 *mi    3 int4: (root node, flags, 0, 0) flags bit 0 texture, bit 1
 *                                normal map, bit 2 casts shadows; texture (first texel, w, h,
 *                                0); normal map (first texel, w, h, 0)
 *   Shared by every mesh (indices global across the meshes, the host adds the offsets):
 *     __global const float4 *box   2 per node: lo (xyz), hi (xyz)
 *     __global const int2 *info    per node: (a, count): leaf slots a .. a + count - 1, or
 *                                  (count == 0) children i + 1 and a
 *     __global const float4 *tri   3 per slot: the triangle's vertices (mesh-relative)
 *     __global const int4 *tvtx    per slot: vertex indices (i0, i1, i2, 0) of the triangle
 *     __global const float4 *tangent per slot: tangent (xyz, unit, along growing u; 0
 *                                  without uvs), w = handedness +-1
 *     __global const float4 *vnrm  per vertex: unit normal (xyz)
 *     __global const float2 *vuv   per vertex: uv (0 without uvs)
 *     __global const float4 *texel every texture's and normal map's texels, row 0 the top of
 *                                  the image (v = 1); normal maps in xyz
 *   mesh_cast(nm, mf, mi, box, info, tri, tvtx, tangent, vnrm, vuv, texel, cam, IW, IH,
 *             vw0, vw1, vw2, wv0, wv1, wv2, position, normal, uv, uv_grad, depth, albedo, object)
 *     float4 cam            (sx, sy, near, far) as terrain.cl (-D OCLS_ORTHO: half extents)
 *     float4 vw0..vw2       rows of the view -> world rotation; wv0..wv2 its inverse
 *     outputs: the G-buffer of oclshade/gbuffer.py (IW*IH each): position (w = 1 hit),
 *     normal (w = 0), uv (the mesh's texture uv, 0 without), uv_grad (0), depth (+inf
 *     empty), albedo (colour x texel rgb, a = 1); __global int *object: -(k + 1), 0 none.
 *     global size (>= IW, >= IH), any local size.
 *   mesh_terrain_shadow(n, position, object, sun, h, H, W, zmax, hm0, hm1, hm2, ray, kshadow,
 *                       coef)
 *     as quadric_shadow's terrain part (terrain_ray.h): every mesh pixel (object < 0) gets
 *     kshadow if the terrain hides the sun from it (or sun.w != 0: the sun at or below the
 *     horizon), else 1; other pixels are left alone.  global size >= n (1-D).
 *   mesh_shadow_rays(n, nm, mf, mi, box, info, tri, tvtx, vuv, texel, position, vw0, vw1, vw2,
 *                    light, hidden)
 *     __global const float4 *light  per mesh: w = 0 a directional light, xyz the world unit
 *                           vector to it (the sun); w = 1 a point light, xyz its position
 *                           relative to the mesh origin (float64 difference rounded once)
 *     __global int *hidden  1 where a hit pixel's ray toward the light meets a triangle of a
 *                           mesh with flag bit 2 (alpha cut-outs honoured) further than
 *                           64 FLT_EPSILON (|p_view| + |camera - origin|) metres (the float32
 *                           rounding of the surface point: no self-hits) and, for a point
 *                           light, before the light; else 0.
 *     global size >= n (1-D).
 *   mesh_shadow_apply(n, hidden, kshadow, coef)
 *     coef[i] = kshadow where hidden[i] (mesh_shadow_rays' output), else unchanged.
 *     global size >= n (1-D).
 *   -D OCLS_ORTHO: orthographic camera.  -D OCLS_OWN_BUILTINS: common.h's inline fmin, fmax,
 *   fabs (the same results; faster on PyPI PoCL 3.0).  Build with -cl-std=CL1.2, no fast-math.
 */
#include "common.h"
#include "terrain_ray.h"

#define OCLS_STACK 64
#define OCLS_TEXTURE 1
#define OCLS_NORMAL_MAP 2
#define OCLS_CASTS 4
/* 1 + 2 gamma_3, gamma_n = n u / (1 - n u), u = 2^-24 (Ize 2013) */
#define OCLS_SLAB_GROW 1.0000003576278687f

OCLS_INLINE float axis_of(float3 v, int k) { return k == 0 ? v.x : (k == 1 ? v.y : v.z); }

/* A ray prepared for the watertight test and the slab test. */
typedef struct {
    float3 o, d, inv;
    int kx, ky, kz;
    float sx, sy, sz;
} Ray;

OCLS_INLINE Ray make_ray(float3 o, float3 d)
{
    Ray r;
    r.o = o;
    r.d = d;
    /* a zero component gets a huge finite inverse: (lo - o) * inv stays a number (no 0 * inf) */
    r.inv = (float3)(1.0f / (d.x != 0.0f ? d.x : 1e-30f), 1.0f / (d.y != 0.0f ? d.y : 1e-30f),
                     1.0f / (d.z != 0.0f ? d.z : 1e-30f));
    const float ax = fabs(d.x), ay = fabs(d.y), az = fabs(d.z);
    r.kz = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2);
    r.kx = r.kz == 2 ? 0 : r.kz + 1;
    r.ky = r.kx == 2 ? 0 : r.kx + 1;
    if (axis_of(d, r.kz) < 0.0f) { const int s = r.kx; r.kx = r.ky; r.ky = s; }
    const float dz = axis_of(d, r.kz);
    r.sx = axis_of(d, r.kx) / dz;
    r.sy = axis_of(d, r.ky) / dz;
    r.sz = 1.0f / dz;
    return r;
}

/* Entry distance of the ray into box node j when it is within [t_lo, t_hi], else INFINITY. */
OCLS_INLINE float box_entry(__global const float4 *box, int j, const Ray *r, float t_lo, float t_hi)
{
    const float3 t0 = (box[2 * j].xyz - r->o) * r->inv, t1 = (box[2 * j + 1].xyz - r->o) * r->inv;
    const float tmin = fmax(fmax(fmin(t0.x, t1.x), fmin(t0.y, t1.y)), fmax(fmin(t0.z, t1.z), t_lo));
    const float tmax = fmin(fmin(fmax(t0.x, t1.x), fmax(t0.y, t1.y)), fmax(t0.z, t1.z)) * OCLS_SLAB_GROW;
    return tmin <= fmin(tmax, t_hi) ? tmin : INFINITY;
}

/* Woop et al. 2013: t of the hit in [t_lo, t_hi] and barycentrics (of v0, v1, v2), or 0. */
OCLS_INLINE int watertight(__global const float4 *v, const Ray *r, float t_lo, float t_hi, float *t, float3 *bary)
{
    const float3 A = v[0].xyz - r->o, B = v[1].xyz - r->o, C = v[2].xyz - r->o;
    const float Akz = axis_of(A, r->kz), Bkz = axis_of(B, r->kz), Ckz = axis_of(C, r->kz);
    const float Ax = axis_of(A, r->kx) - r->sx * Akz, Ay = axis_of(A, r->ky) - r->sy * Akz;
    const float Bx = axis_of(B, r->kx) - r->sx * Bkz, By = axis_of(B, r->ky) - r->sy * Bkz;
    const float Cx = axis_of(C, r->kx) - r->sx * Ckz, Cy = axis_of(C, r->ky) - r->sy * Ckz;
    const float U = Cx * By - Cy * Bx, V = Ax * Cy - Ay * Cx, W = Bx * Ay - By * Ax;
    if ((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f)) return 0;
    const float det = U + V + W;
    if (det == 0.0f) return 0;
    const float T = U * (r->sz * Akz) + V * (r->sz * Bkz) + W * (r->sz * Ckz);
    const float s = det < 0.0f ? -1.0f : 1.0f, Ts = s * T, dets = s * det;
    if (Ts < t_lo * dets || Ts > t_hi * dets) return 0;
    const float inv = 1.0f / det;
    *t = T * inv;
    *bary = (float3)(U * inv, V * inv, W * inv);
    return 1;
}

/* Alpha of the nearest texel of uv (wrapping) in texture (first, w, h). */
OCLS_INLINE float4 texel_at(__global const float4 *texel, int4 tex, float2 uv)
{
    const float fu = uv.x - floor(uv.x), fv = uv.y - floor(uv.y);
    const int c = min((int)(fu * (float)tex.y), tex.y - 1), rw = min((int)((1.0f - fv) * (float)tex.z), tex.z - 1);
    return texel[tex.x + max(rw, 0) * tex.y + max(c, 0)];
}

OCLS_INLINE float2 uv_at(__global const int4 *tvtx, __global const float2 *vuv, int slot, float3 b)
{
    const int4 iv = tvtx[slot];
    return b.x * vuv[iv.x] + b.y * vuv[iv.y] + b.z * vuv[iv.z];
}

/* Nearest (any = 0) or any (any = 1) hit of ray r in [t_lo, t_hi] in the BVH from `root`:
 * the slot hit (-1 none), its t and barycentrics.  Textured meshes skip cut-out texels. */
OCLS_INLINE int trace(__global const float4 *box, __global const int2 *info, __global const float4 *tri,
                      __global const int4 *tvtx, __global const float2 *vuv, __global const float4 *texel,
                      int root, int textured, int4 tex, float cutoff, const Ray *r, float t_lo, float t_hi,
                      int any, float *t_hit, float3 *b_hit)
{
    int stack[OCLS_STACK];
    int top = 0, hit = -1, j = root;
    if (box_entry(box, j, r, t_lo, t_hi) == INFINITY) return -1;
    for (;;) {
        const int2 nd = info[j];
        if (nd.y > 0) {
            for (int s = nd.x; s < nd.x + nd.y; ++s) {
                float t;
                float3 b;
                if (!watertight(tri + 3 * s, r, t_lo, t_hi, &t, &b)) continue;
                if (textured && texel_at(texel, tex, uv_at(tvtx, vuv, s, b)).w < cutoff) continue;
                hit = s; t_hi = t; *t_hit = t; *b_hit = b;
                if (any) return hit;
            }
        } else {
            const int c0 = j + 1, c1 = nd.x;
            const float e0 = box_entry(box, c0, r, t_lo, t_hi), e1 = box_entry(box, c1, r, t_lo, t_hi);
            if (e0 != INFINITY && e1 != INFINITY) {
                const int near = e0 <= e1 ? c0 : c1;
                stack[top++] = e0 <= e1 ? c1 : c0;
                j = near;
                continue;
            }
            if (e0 != INFINITY) { j = c0; continue; }
            if (e1 != INFINITY) { j = c1; continue; }
        }
        /* pop the next node still in reach */
        for (;;) {
            if (top == 0) return hit;
            j = stack[--top];
            if (box_entry(box, j, r, t_lo, t_hi) != INFINITY) break;
        }
    }
}

OCLS_INLINE float3 turn(float4 r0, float4 r1, float4 r2, float3 v)
{
    return (float3)(dot(r0.xyz, v), dot(r1.xyz, v), dot(r2.xyz, v));
}

__kernel void mesh_cast(const int nm, __global const float4 *mf, __global const int4 *mi,
                        __global const float4 *box, __global const int2 *info, __global const float4 *tri,
                        __global const int4 *tvtx, __global const float4 *tangent, __global const float4 *vnrm,
                        __global const float2 *vuv, __global const float4 *texel, const float4 cam,
                        const int IW, const int IH, const float4 vw0, const float4 vw1, const float4 vw2,
                        const float4 wv0, const float4 wv1, const float4 wv2,
                        __global float4 *position, __global float4 *normal, __global float2 *uv,
                        __global float4 *uv_grad, __global float *depth, __global float4 *albedo,
                        __global int *object)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= IW || y >= IH) return;
    const int i = y * IW + x;
    const float nx = (2.0f * (float)x + 1.0f) / (float)IW - 1.0f, ny = 1.0f - (2.0f * (float)y + 1.0f) / (float)IH;
#ifdef OCLS_ORTHO
    const float3 o = (float3)(nx * cam.x, ny * cam.y, 0.0f), d = (float3)(0.0f, 0.0f, -1.0f);
#else
    const float3 o = (float3)(0.0f), d = (float3)(nx * cam.x, ny * cam.y, -1.0f);
#endif
    const float3 dw = turn(vw0, vw1, vw2, d), ow = turn(vw0, vw1, vw2, o);
    float best = cam.w, t = 0.0f;
    int hit = -1, mesh = -1;
    float3 bary = (float3)(0.0f);
    for (int k = 0; k < nm; ++k) {
        const float4 rect = mf[3 * k + 2];
        if ((float)x < rect.x || (float)x >= rect.z || (float)y < rect.y || (float)y >= rect.w) continue;
        const int4 m0 = mi[3 * k];
        const Ray r = make_ray(mf[3 * k].xyz + ow, dw);
        float3 b;
        const int s = trace(box, info, tri, tvtx, vuv, texel, m0.x, m0.y & OCLS_TEXTURE, mi[3 * k + 1],
                            mf[3 * k + 1].w, &r, cam.z, best, 0, &t, &b);
        if (s >= 0) { best = t; hit = s; mesh = k; bary = b; }
    }
    if (hit < 0) {
        position[i] = (float4)(0.0f); normal[i] = (float4)(0.0f); uv[i] = (float2)(0.0f);
        uv_grad[i] = (float4)(0.0f); depth[i] = INFINITY; albedo[i] = (float4)(0.0f); object[i] = 0;
        return;
    }
    const int4 iv = tvtx[hit], m0 = mi[3 * mesh];
    __global const float4 *v = tri + 3 * hit;
    const float3 ng = cross(v[1].xyz - v[0].xyz, v[2].xyz - v[0].xyz);
    float3 n = bary.x * vnrm[iv.x].xyz + bary.y * vnrm[iv.y].xyz + bary.z * vnrm[iv.z].xyz;
    n = dot(n, n) > 0.0f ? normalize(n) : normalize(ng);
    if (dot(ng, dw) > 0.0f) n = -n;                       /* seen from the back */
    const float2 tuv = uv_at(tvtx, vuv, hit, bary);
    float4 colour = (float4)(mf[3 * mesh + 1].xyz, 1.0f);
    if (m0.y & OCLS_TEXTURE) colour.xyz *= texel_at(texel, mi[3 * mesh + 1], tuv).xyz;
    if (m0.y & OCLS_NORMAL_MAP) {
        const float4 tg = tangent[hit];
        const float3 tn = tg.xyz - dot(tg.xyz, n) * n;
        if (dot(tn, tn) > 0.0f) {
            const float3 T = normalize(tn), B = tg.w * cross(n, T);
            const float3 m = texel_at(texel, mi[3 * mesh + 2], tuv).xyz;
            const float3 nm_ = m.x * T + m.y * B + m.z * n;
            if (dot(nm_, nm_) > 0.0f) n = normalize(nm_);
        }
    }
    position[i] = (float4)(o + best * d, 1.0f);
    normal[i] = (float4)(normalize(turn(wv0, wv1, wv2, n)), 0.0f);
    uv[i] = tuv;
    uv_grad[i] = (float4)(0.0f);
    depth[i] = best;
    albedo[i] = colour;
    object[i] = -(mesh + 1);
}

__kernel void mesh_terrain_shadow(const int n, __global const float4 *position, __global const int *object,
                                  const float4 sun, __global const float *h, const int H, const int W,
                                  const float zmax, const float4 hm0, const float4 hm1, const float4 hm2,
                                  const float4 ray, const float kshadow, __global float *coef)
{
    const int i = get_global_id(0);
    if (i >= n || object[i] >= 0 || !(position[i].w > 0.5f)) return;
    if (sun.w != 0.0f) {
        coef[i] = kshadow;
        return;
    }
    const float3 p = position[i].xyz;
    const float3 q = (float3)(dot(hm0.xyz, p) + hm0.w, dot(hm1.xyz, p) + hm1.w, dot(hm2.xyz, p) + hm2.w);
    coef[i] = terrain_blocks(h, H, W, zmax, q, ray) ? kshadow : 1.0f;
}

__kernel void mesh_shadow_rays(const int n, const int nm, __global const float4 *mf, __global const int4 *mi,
                               __global const float4 *box, __global const int2 *info, __global const float4 *tri,
                               __global const int4 *tvtx, __global const float2 *vuv,
                               __global const float4 *texel, __global const float4 *position,
                               const float4 vw0, const float4 vw1, const float4 vw2,
                               __global const float4 *light, __global int *hidden)
{
    const int i = get_global_id(0);
    if (i >= n) return;
    const float4 pv = position[i];
    int blocked = 0;
    if (pv.w > 0.5f) {
        const float3 pw = turn(vw0, vw1, vw2, pv.xyz);
        for (int k = 0; k < nm && !blocked; ++k) {
            const int4 m0 = mi[3 * k];
            if (!(m0.y & OCLS_CASTS)) continue;
            const float3 c = mf[3 * k].xyz, p = c + pw;
            const float4 l = light[k];
            const float3 dir = l.w == 0.0f ? l.xyz : l.xyz - p;
            const float reach = sqrt(dot(dir, dir));
            if (!(reach > 0.0f)) continue;
            const Ray r = make_ray(p, dir);
            const float t_lo = 64.0f * FLT_EPSILON * (length(pv.xyz) + length(c)) / reach;
            float t;
            float3 b;
            blocked = trace(box, info, tri, tvtx, vuv, texel, m0.x, m0.y & OCLS_TEXTURE, mi[3 * k + 1],
                            mf[3 * k + 1].w, &r, t_lo, l.w == 0.0f ? INFINITY : 1.0f, 1, &t, &b) >= 0;
        }
    }
    hidden[i] = blocked;
}

__kernel void mesh_shadow_apply(const int n, __global const int *hidden, const float kshadow, __global float *coef)
{
    const int i = get_global_id(0);
    if (i < n && hidden[i]) coef[i] = kshadow;
}
