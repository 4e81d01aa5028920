/* shadow_volume.cl — mesh shadows by shadow volumes (paper 003), counted per pixel in compute.
 * Host: oclshade/meshes/shadow_volumes.py (volumes, start count, tiles' prefix sums).
 * Float64 twin: oclshade/reference/mesh_shadows.py (shadow rays against every triangle).
 *
 * ABI summary (every argument, layout and work size under "ABI" below):
 *   sv_bin      one work-item per volume face, 1-D global >= ntri: counts (fill 0) or lists
 *               (fill 1) the faces of each T x T pixel tile (int count / offset / list buffers)
 *   sv_prepare  one work-item per face, 1-D global >= ntri (pinhole only): 4 float4 edge and
 *               plane vectors per face
 *   sv_count    one work-item per pixel, global (>= IW, >= IH): the uchar shadow mask from the
 *               float4 view-space G-buffer positions and the tiles' face lists
 *   sv_apply    one work-item per pixel, 1-D global >= n: coef[i] = kshadow where mask[i]
 *   Vertices float4 (xyz view space), faces int4 (a, b, c, kind), cam float4 (sx, sy, near,
 *   maxdepth).  -D options: OCLS_ORTHO (orthographic camera) only; -cl-std=CL1.2, no fast-math.
 *
 * Volumes.  One closed oriented triangle surface per light (paper 003 sections 3-4): light
 * caps (the caster faces, kind 1), sides (the silhouette edges extruded away from the light,
 * kind 0) and dark caps (the casters at the extrusion's end, reversed, kind 1).  Vertices are
 * indexed and shared, in view space (camera-relative float32 offsets of the host's float64
 * world positions: paper 003's "space distances" remedy), so neighbouring faces use the very
 * same vertex values.
 *
 * Counting (Crow's count, paper 003 section 2).  Each hit pixel's view segment runs from its
 * start o to its G-buffer point p; the count is w0 + the signed crossings of the volume faces
 * (+1 entering: a face turned to the viewer, -1 leaving); p is in shadow iff the count != 0.
 *   start o: perspective, the eye (0, 0, 0) with w0 = the eye's winding number, computed
 *            exactly in float64 on the host (the "exact start count": the near caps' job);
 *            orthographic, (p.x, p.y, zs) with zs above every volume vertex, w0 = 0.
 *   caps   : crossed only where the segment is nearer than the near plane (depth < near);
 *            beyond it the light caps are the casters themselves, opaque in the G-buffer, so
 *            no segment crosses them before its end (z-pass as in the paper; a point on a
 *            lit caster face is not shadowed by its own cap), and the dark caps lie beyond
 *            every receiver (automatic extrusion length).
 *   test   : watertight.  The line o + t d (d = p - o) meets triangle (A, B, C) iff its three
 *            edge functions d . ((V_i - o) x (V_j - o)) have one sign, evaluated as
 *            d . (a x (b - a)) (a = V_i - o, b = V_j - o): a long vector crossed with the short
 *            edge rounds to u |a| |b - a|, where two long nearly parallel ones would round to
 *            u |a| |b|.  Each edge's function is
 *            evaluated with its vertices in index order (lower first) and negated for the
 *            other winding, so two faces sharing an edge see exactly opposite values; an
 *            exact 0 takes the sign of the first non-zero component of (V_i - o) x (V_j - o)
 *            (simulation of simplicity: the line moved by (e, e^2, e^3)), so a line through an
 *            edge or a vertex crosses exactly one of the faces around it.  All negative: the
 *            face is turned to the viewer (+1).  The crossing counts if its parameter
 *            t = (a . N) / (d . N) (a = A - o, N = (B - A) x (C - A)) lies in (0, t_end):
 *            t_end = 1 - bias for sides, the near plane's t for caps (if nearer).
 *   bias   : the segment stops OCLS_SV_BIAS x the point's depth short of it, towards the eye
 *            (paper 003's near caps "pushed slightly into the scene", the other way round): a
 *            surface lying in a volume's side (a face edge-on to the light, as the side of a
 *            box under a sun along its axis) is decided on the viewer's side, not by rounding.
 *            2^-18 = 64 u: past the count's rounding (about 9 u of the distances involved)
 *            wherever the view ray meets the face at more than ~10 degrees.
 *
 * Binning.  The frame is cut into T x T pixel tiles (TW x TH of them); each volume face goes to
 * the tiles of its projected bounding rectangle (1 pixel of margin; the whole frame when a
 * vertex is at or behind the eye plane of a pinhole camera) that are not wholly outside one
 * edge of its projected triangle (1.5 pixels to spare; long thin sides cross few of the
 * tiles of their rectangle); faces deeper than every hit (maxdepth) and caps deeper than
 * near are dropped.  Two passes of sv_bin: count per tile,
 * the host's prefix sums, fill.
 *
 * ABI (every buffer row-major, packed; IW x IH the frame in pixels; T the tile side in pixels,
 * TW = ceil(IW / T), TH = ceil(IH / T) tiles, tile t = ty * TW + tx)
 *   shared arguments
 *     __global const float4 *verts  view-space vertex positions (xyz; w unused)
 *     __global const int4 *tris     ntri faces (a, b, c, kind): vertex indices wound outwards;
 *                                   kind 0 side, 1 cap
 *     const float4 cam              (sx, sy, near, maxdepth): pixel-ray slopes (pinhole) or
 *                                   half extents (-D OCLS_ORTHO), the near plane, the largest
 *                                   depth of a hit pixel
 *   sv_bin(int ntri, tris, verts, cam, int IW, int IH, int T, int TW, int TH, int fill,
 *          __global int *count, __global const int *offset, __global int *list)
 *     count   TW*TH ints, zeroed by the host before each pass
 *     fill 0: count[t] += 1 (atomic) for every tile t of each face; offset, list unused
 *     fill 1: list[offset[t] + k] = face, k = count[t]++ (atomic; order within a tile free); offset: TW*TH + 1 exclusive prefix
 *             sums of pass 0's counts (host), list: offset[TW*TH] ints
 *     global size >= ntri (1-D), any local size (the host: Runtime.local_size(k, 64))
 *   sv_prepare(int ntri, tris, verts, __global float4 *planes)          (pinhole only)
 *     planes  out, 4 float4 per face: (m0, kind), (m1, 0), (m2, 0), (N, a . N): the edge
 *             vectors of its edges a->b, b->c, c->a (edge function d . m) and its plane; the
 *             eye is every pixel's start, so they serve every pixel
 *     global size >= ntri (1-D), any local size
 *   sv_count(verts, tris, __global const float4 *planes, __global const int *offset,
 *            __global const int *list, __global const float4 *position, cam, float zs,
 *            int w0, int IW, int IH, int T, int TW, __global uchar *mask)
 *     planes    sv_prepare's (pinhole; orthographic: unused, may be any buffer: the faces are
 *               read from verts and tris per pixel, whose start differs)
 *     offset, list  sv_bin's pass 1 (TW*TH + 1 and offset[TW*TH] ints)
 *     position  the G-buffer's view-space float4 per pixel, IW*IH (w = 1 hit)
 *     zs        the orthographic start height (above every volume vertex); w0 the eye's
 *               winding number (pinhole, from the host's float64 count)
 *     mask      out, IW*IH uchar: 1 the light is hidden by a caster, 0 lit or empty
 *     global size (>= IW, >= IH), any local size (the host: Runtime.grid_2d)
 *   sv_apply(int n, __global const uchar *mask, float kshadow, __global float *coef)
 *     coef[i] = kshadow where mask[i], else unchanged (n floats, a shadow-coefficient buffer,
 *     1 = lit; kshadow paper 000 eq. (1)).  global size >= n (1-D), any local size
 *   -D options: OCLS_ORTHO (orthographic camera); no others.
 *   Build with -cl-std=CL1.2, no fast-math.  C host: host/src/shadow_volumes.c.
 */
#include "common.h"

/* the segment ends this fraction of the point's depth short of it (see "bias" above) */
#define OCLS_SV_BIAS 3.814697265625e-6f

OCLS_INLINE float3 sv_cross(float3 u, float3 v)
{
    return (float3)(u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x);
}

OCLS_INLINE float sv_dot(float3 u, float3 v)
{
    return (u.x * v.x + u.y * v.y) + u.z * v.z;
}

/* the edge function's vector m of edge i -> j (u, v: its ends less the start o): the edge
 * function is d . m; m = u x (v - u) evaluated with the lower index first, negated for the
 * other order (exact), so two faces sharing the edge hold exactly opposite vectors */
OCLS_INLINE float3 edge_normal(int i, float3 u, int j, float3 v)
{
    return i > j ? -sv_cross(v, u - v) : sv_cross(u, v - u);     /* = u x v: no cancellation */
}

/* sign (+1 / -1, never 0) of d . m, an exact 0 decided by the first non-zero component of m */
OCLS_INLINE int sos_sign(float3 d, float3 m)
{
    const float f = sv_dot(d, m);
    if (f != 0.0f) return f > 0.0f ? 1 : -1;
    if (m.x != 0.0f) return m.x > 0.0f ? 1 : -1;
    if (m.y != 0.0f) return m.y > 0.0f ? 1 : -1;
    return m.z < 0.0f ? -1 : 1;
}

/* pixel column / row (continuous, pixel centres at integers) of a view-space point */
OCLS_INLINE float2 sv_pixel(float3 v, float4 cam, int IW, int IH)
{
#ifdef OCLS_ORTHO
    const float nx = v.x / cam.x, ny = v.y / cam.y;
#else
    const float depth = -v.z;
    const float nx = v.x / (depth * cam.x), ny = v.y / (depth * cam.y);
#endif
    return (float2)(((nx + 1.0f) * (float)IW - 1.0f) * 0.5f, ((1.0f - ny) * (float)IH - 1.0f) * 0.5f);
}

/* tiles (x0, y0, x1, y1), inclusive, a face may be crossed in; x0 > x1 when none.  *proj:
 * the face's pixel coordinates (xy of a, b, c in s0.xy, s0.zw, s1.xy) and s1.z = 1 when the
 * tiles may be tested against the projected triangle itself (every vertex before the eye). */
OCLS_INLINE int4 face_tiles(float3 a, float3 b, float3 c, int cap, float4 cam, int IW, int IH, int T, float8 *proj)
{
    const int4 none = (int4)(1, 0, 0, 0);
    *proj = (float8)(0.0f);
    const float dmin = fmin(-a.z, fmin(-b.z, -c.z));
    if (dmin > cam.w || (cap && dmin > cam.z)) return none;
#ifndef OCLS_ORTHO
    const float dmax = fmax(-a.z, fmax(-b.z, -c.z));
    if (!(dmax > 0.0f)) return none;
    if (!(dmin > 0.0f)) return (int4)(0, 0, (IW - 1) / T, (IH - 1) / T);
#endif
    const float2 pa = sv_pixel(a, cam, IW, IH), pb = sv_pixel(b, cam, IW, IH), pc = sv_pixel(c, cam, IW, IH);
    const float lim = 4.0f * (float)max(IW, IH);
    const float x0 = clamp(floor(fmin(pa.x, fmin(pb.x, pc.x))) - 1.0f, -lim, lim);
    const float x1 = clamp(ceil(fmax(pa.x, fmax(pb.x, pc.x))) + 1.0f, -lim, lim);
    const float y0 = clamp(floor(fmin(pa.y, fmin(pb.y, pc.y))) - 1.0f, -lim, lim);
    const float y1 = clamp(ceil(fmax(pa.y, fmax(pb.y, pc.y))) + 1.0f, -lim, lim);
    if (!(x1 >= 0.0f && y1 >= 0.0f && x0 <= (float)(IW - 1) && y0 <= (float)(IH - 1))) return none;
    const float big = 1e6f;           /* beyond: the projected edges are not trusted for culling */
    const int sharp = fmax(fmax(fabs(pa.x), fabs(pa.y)), fmax(fmax(fabs(pb.x), fabs(pb.y)),
                                                            fmax(fabs(pc.x), fabs(pc.y)))) < big;
    *proj = (float8)(pa, pb, pc, sharp ? 1.0f : 0.0f, 0.0f);
    return (int4)(max((int)x0, 0) / T, max((int)y0, 0) / T, min((int)x1, IW - 1) / T, min((int)y1, IH - 1) / T);
}

/* 1 when the tile's pixels (with 1.5 pixels to spare) lie wholly outside one edge of the
 * projected triangle (a separating edge: the face cannot be crossed there) */
OCLS_INLINE int tile_outside(float8 q, int tx, int ty, int T)
{
    const float2 p[3] = {q.s01, q.s23, q.s45};
    const float area = (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[1].y - p[0].y) * (p[2].x - p[0].x);
    if (!(fabs(area) > 1e-3f)) return 0;
    const float sgn = area > 0.0f ? 1.0f : -1.0f;
    const float cx0 = (float)(tx * T) - 1.0f, cx1 = (float)(tx * T + T), cy0 = (float)(ty * T) - 1.0f,
                cy1 = (float)(ty * T + T);
    for (int k = 0; k < 3; ++k) {
        const float2 e = p[(k + 1) % 3] - p[k];
        const float spare = 1.5f * sqrt(e.x * e.x + e.y * e.y);
        const float f00 = sgn * (e.x * (cy0 - p[k].y) - e.y * (cx0 - p[k].x));
        const float f01 = sgn * (e.x * (cy0 - p[k].y) - e.y * (cx1 - p[k].x));
        const float f10 = sgn * (e.x * (cy1 - p[k].y) - e.y * (cx0 - p[k].x));
        const float f11 = sgn * (e.x * (cy1 - p[k].y) - e.y * (cx1 - p[k].x));
        if (fmax(fmax(f00, f01), fmax(f10, f11)) < -spare) return 1;
    }
    return 0;
}

__kernel void sv_bin(const int ntri, __global const int4 *tris, __global const float4 *verts, const float4 cam,
                     const int IW, const int IH, const int T, const int TW, const int TH, const int fill,
                     __global int *count, __global const int *offset, __global int *list)
{
    const int k = get_global_id(0);
    if (k >= ntri) return;
    const int4 f = tris[k];
    float8 proj;
    const int4 r = face_tiles(verts[f.x].xyz, verts[f.y].xyz, verts[f.z].xyz, f.w, cam, IW, IH, T, &proj);
    for (int ty = r.y; ty <= r.w; ++ty) {
        for (int tx = r.x; tx <= r.z; ++tx) {
            if (proj.s6 > 0.5f && tile_outside(proj, tx, ty, T)) continue;
            const int t = ty * TW + tx;
            if (fill) list[offset[t] + atomic_inc(&count[t])] = k;
            else atomic_inc(&count[t]);
        }
    }
}

/* pinhole: the start is the eye for every pixel, so each face's edge vectors and plane are
 * the same for all its pixels: 4 float4 per face, (m0, kind), (m1, 0), (m2, 0), (N, a . N) */
__kernel void sv_prepare(const int ntri, __global const int4 *tris, __global const float4 *verts,
                         __global float4 *planes)
{
    const int k = get_global_id(0);
    if (k >= ntri) return;
    const int4 f = tris[k];
    const float3 a = verts[f.x].xyz, b = verts[f.y].xyz, c = verts[f.z].xyz;
    const float3 nrm = sv_cross(b - a, c - a);
    planes[4 * k] = (float4)(edge_normal(f.x, a, f.y, b), (float)f.w);
    planes[4 * k + 1] = (float4)(edge_normal(f.y, b, f.z, c), 0.0f);
    planes[4 * k + 2] = (float4)(edge_normal(f.z, c, f.x, a), 0.0f);
    planes[4 * k + 3] = (float4)(nrm, sv_dot(a, nrm));
}

__kernel void sv_count(__global const float4 *verts, __global const int4 *tris, __global const float4 *planes,
                       __global const int *offset, __global const int *list, __global const float4 *position,
                       const float4 cam, const float zs, const int w0, const int IW, const int IH, const int T,
                       const int TW, __global uchar *mask)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= IW || y >= IH) return;
    const int i = y * IW + x;
    const float4 p = position[i];
    if (!(p.w > 0.5f)) { mask[i] = 0; return; }
#ifdef OCLS_ORTHO
    const float3 o = (float3)(p.x, p.y, zs);
    const float t_near = (zs + cam.z) / (zs - p.z);
    const float t_side = 1.0f - OCLS_SV_BIAS * (-p.z / (zs - p.z));
#else
    const float3 o = (float3)(0.0f);
    const float t_near = cam.z / -p.z;
    const float t_side = 1.0f - OCLS_SV_BIAS;
#endif
    const float3 d = p.xyz - o;
    const int t = (y / T) * TW + x / T;
    int count = w0;
    for (int k = offset[t]; k < offset[t + 1]; ++k) {
        const int face = list[k];
#ifdef OCLS_ORTHO
        const int4 f = tris[face];
        const float3 a = verts[f.x].xyz - o, b = verts[f.y].xyz - o, c = verts[f.z].xyz - o;
        const int s0 = sos_sign(d, edge_normal(f.x, a, f.y, b));
        if (sos_sign(d, edge_normal(f.y, b, f.z, c)) != s0 || sos_sign(d, edge_normal(f.z, c, f.x, a)) != s0) continue;
        const float3 nrm = sv_cross(b - a, c - a);
        const float num = sv_dot(a, nrm);
        const int cap = f.w;
#else
        __global const float4 *q = planes + 4 * face;
        const float4 m0 = q[0];
        const int s0 = sos_sign(d, m0.xyz);
        if (sos_sign(d, q[1].xyz) != s0 || sos_sign(d, q[2].xyz) != s0) continue;
        const float3 nrm = q[3].xyz;
        const float num = q[3].w;
        const int cap = m0.w > 0.5f;
#endif
        const float den = sv_dot(d, nrm);
        const float t_end = cap ? fmin(t_near, t_side) : t_side;
        const int inside = den > 0.0f ? (num > 0.0f && num < t_end * den) : (num < 0.0f && num > t_end * den);
        if (inside) count += s0 < 0 ? 1 : -1;
    }
    mask[i] = count != 0;
}

__kernel void sv_apply(const int n, __global const uchar *mask, const float kshadow, __global float *coef)
{
    const int i = get_global_id(0);
    if (i < n && mask[i]) coef[i] = kshadow;
}
