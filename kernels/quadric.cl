/* quadric.cl — quadrics ray-cast in closed form into a G-buffer, merged by depth with another
 * G-buffer (the terrain's), and their shadows (paper 004: quadrics stand on the terrain in
 * the same frame).  Float64 twin: oclshade/reference/quadrics.py.
 *
 * Shapes.  Quadric k is a unit shape in local coordinates q = M (p - c), M = S^-1 R^T (R: the
 * local axes as columns, S = diag(radii), c the centre), everything in view space:
 *   kind 0 ellipsoid (spheres too)  |q|^2 = 1                        gradient q
 *   kind 1 cylinder   qx^2 + qy^2 = 1, |qz| <= 1; caps qz = +-1     (qx, qy, 0); (0, 0, +-1)
 *   kind 2 paraboloid qx^2 + qy^2 = qz, 0 <= qz <= 1 (open bowl)     (2qx, 2qy, -1)
 * The view-space normal is M^T gradient, normalised, turned to face the ray where the
 * surface is seen from inside.
 *
 * Roots (robust float32).  A ray p = o + t d is f + t g in q (f = M o - M c, g = M d).
 *   First the origin moves to the ray's point f1 = f + tc g closest to the shape's centre
 *   (tc = (c0 - f).g / g.g): the equations below are then in numbers of the shape's size, and
 *   a far object's |f|^2 and b^2 (thousands of radii away: both ~1e7, their difference ~1)
 *   no longer cancel below float32 resolution.  t = tc + tau.
 *   Ellipsoid and cylinder side (the unit sphere / circle): with gh = g / |g| and
 *   b = f1 . gh, the discriminant is 1 - |f1 - b gh|^2 (Haines et al., "Precision
 *   improvements for ray/sphere intersection", Ray Tracing Gems 2019, ch. 7: the
 *   perpendicular miss distance directly); then q = -(b + sign(b) sqrt(disc)), roots c / q
 *   and q (the stable quadratic formula: -b and the root never cancel), c = |f1|^2 - 1.
 *   Paraboloid: A tau^2 + B tau + C = 0 with the discriminant B^2 - 4 A C as a difference of
 *   products with fma (Kahan: the product's rounding error recovered exactly), the same
 *   stable formula, and the linear root when A = 0 (a ray along the axis).
 *   Error: docs/reflections.md "Quadrics" (measured against the twin in tests/test_quadrics.py).
 *
 * ABI
 *   Per quadric k (nq of them), host-filled:
 *     __global const float4 *qf   5 float4: m0, m1, m2 (rows of M in xyz; w = -(M c) of that
 *                                 row, so f = (m0.o + m0.w, ...)), albedo (linear rgba),
 *                                 bound (view-space centre xyz and radius w of a sphere
 *                                 holding the shape)
 *     __global const int4 *qi     2 int4: (kind, 0, 0, 0), screen rectangle (x0, y0, x1, y1):
 *                                 pixels x0 <= x < x1, y0 <= y < y1 may see it (conservative)
 *   quadric_cast(nq, qf, qi, cam, IW, IH, hm0, hm1, position, normal, uv, uv_grad, depth,
 *                albedo, object)
 *     float4 cam            (sx, sy, near, far) as terrain.cl (-D OCLS_ORTHO: half extents)
 *     int IW, IH            image size
 *     float4 hm0, hm1       rows of the affine map view -> heightmap (u = column, v = row),
 *                           for the uv field of a hit
 *     outputs: the G-buffer of oclshade/gbuffer.py (IW*IH each): position (w = 1 hit),
 *     normal (w = 0), uv, uv_grad (0: quadric pixels carry no screen-space uv derivatives),
 *     depth (t = -z_view, +inf empty), albedo; __global int *object: k + 1 of the hit, 0 none
 *     global size (>= IW, >= IH), any local size.
 *   gbuffer_merge(n, src position, normal, uv, uv_grad, depth, albedo, object,
 *                 dst position, normal, uv, uv_grad, depth, albedo, object)
 *     per pixel i < n: where src depth < dst depth (nearest hit wins; a tie keeps dst) every
 *     field of src is copied over dst, object included (dst object must be initialised, 0
 *     for a terrain G-buffer).  global size >= n (1-D).
 *   object_normals(n, object, normal, shading)
 *     shading[i] = normal[i] where object[i] != 0 (quadrics > 0, meshes < 0: mesh.cl; the
 *     terrain's smooth shading normals do not apply to objects).  global size >= n (1-D).
 *   quadric_shadow(n, nq, qf, qi, position, object, sun, h, H, W, zmax, hm0, hm1, hm2, ray,
 *                  kshadow, coef)
 *     float4 sun            view-space unit vector to the sun (xyz); w: mode 0 trace,
 *                           1 sun at or below the horizon (every hit pixel gets kshadow)
 *     h, H, W               relative heights (NaN = hole) of the terrain, rows x cols
 *     float zmax            largest finite relative height
 *     float4 hm0, hm1, hm2  rows of the affine map view -> (u, v, z - offset)
 *     float4 ray            (ux, uy, w, 0): the sun ray per horizontal metre in heightmap
 *                           units (cells; rows run south), rise w = tan(elevation)
 *     float kshadow         the coefficient of a shadowed pixel (paper 000 eq. 1)
 *     __global float *coef  in/out, one per pixel: the terrain shadow pass's coefficients;
 *                           a terrain pixel whose sun ray meets a quadric gets kshadow; an
 *                           object pixel gets kshadow if its sun ray meets a quadric (its own
 *                           closed shape excluded, an open paraboloid included past 1e-3 of
 *                           its bound) or the terrain (exact: every patch under the ray tested
 *                           in closed form), else 1
 *     global size >= n (1-D).
 *   quadric_point_shadow(n, nq, qf, qi, position, object, light, kshadow, coef)
 *     A point light (docs/meshes.md "Point lights"): float4 light = its view-space position
 *     (xyz).  Every hit pixel whose segment to the light, p + t (light - p) with 0 < t <= 1,
 *     meets a quadric gets kshadow (its own closed shape excluded, an open paraboloid
 *     included past t > 1e-3 of its bound's radius); the others keep theirs (the terrain
 *     pass below has set every hit pixel first).  global size >= n (1-D).
 *   terrain_point_shadow(n, position, object, light, h, H, W, zmax, hm0, hm1, hm2, kshadow, coef)
 *     The terrain's shadows of a point light on every pixel (terrain, quadric and mesh ones):
 *     float4 light = its position in (u, v, z - offset) (xyz); h, H, W, zmax, hm0..hm2 as
 *     quadric_shadow.  A hit pixel gets kshadow when the terrain rises above its segment to
 *     the light (terrain_ray.h terrain_segment_blocks: exact, every patch under the segment;
 *     a terrain pixel, object 0, starts on the surface), else 1; an empty pixel gets 1.
 *     global size >= n (1-D).  C: oclshade_enqueue_terrain_point_shadow, _quadric_point_shadow.
 *   -D OCLS_ORTHO: orthographic camera.  Build with -cl-std=CL1.2, no fast-math.
 */
#include "common.h"
#include "terrain_ray.h"

#define OCLS_ELLIPSOID 0
#define OCLS_CYLINDER 1
#define OCLS_PARABOLOID 2

/* a*b - c*d with the rounding error of c*d recovered (Kahan's difference of products) */
OCLS_INLINE float diff_of_products(float a, float b, float c, float d)
{
    const float w = c * d;
    const float e = fma(-c, d, w);
    const float f = fma(a, b, -w);
    return f + e;
}

/* Roots t0 <= t1 of |f + t g|^2 = 1 (g != 0); 0 if the ray misses. */
OCLS_INLINE int unit_sphere_roots(float3 f, float3 g, float *t0, float *t1)
{
    const float len = sqrt(dot(g, g));
    if (!(len > 0.0f)) return 0;
    const float3 gh = g / len;
    const float b = dot(f, gh);
    const float3 l = f - b * gh;
    const float disc = 1.0f - dot(l, l);
    if (disc < 0.0f) return 0;
    const float q = -(b + copysign(sqrt(disc), b));
    if (q == 0.0f) return 0;
    const float c = dot(f, f) - 1.0f;
    const float r0 = c / q, r1 = q;
    *t0 = fmin(r0, r1) / len;
    *t1 = fmax(r0, r1) / len;
    return 1;
}

/* Roots of A t^2 + B t + C = 0 (count 0, 1 or 2 in r[0], r[1]). */
OCLS_INLINE int quadratic_roots(float A, float B, float C, float *r)
{
    if (A == 0.0f) {
        if (B == 0.0f) return 0;
        r[0] = -C / B;
        return 1;
    }
    const float disc = diff_of_products(B, B, 4.0f * A, C);
    if (disc < 0.0f) return 0;
    const float q = -0.5f * (B + copysign(sqrt(disc), B));
    r[0] = q / A;
    if (q == 0.0f) return 1;
    r[1] = C / q;
    return 2;
}

/* Nearest t in [t_lo, t_hi] where the ray f + t g meets quadric `kind`; its local gradient
 * in *grad.  Returns t_hi + 1 (> t_hi) when there is none.  The roots are found from the
 * ray's point f1 = f + tc g closest to the shape's centre (the origin; (0, 0, 1/2) for the
 * paraboloid): about f1 the equation's coefficients are of the shape's size, so a far
 * object's |f|^2 ~ |b|^2 never cancel (its discriminant would otherwise be lost below
 * float32 resolution at a few thousand radii); t = tc + tau. */
OCLS_INLINE float quadric_hit(int kind, float3 f, float3 g, float t_lo, float t_hi, float3 *grad)
{
    const float3 c0 = (float3)(0.0f, 0.0f, kind == OCLS_PARABOLOID ? 0.5f : 0.0f);
    const float tc = dot(c0 - f, g) / dot(g, g);
    const float3 f1 = f + tc * g;
    float best = INFINITY;
    float r[4];
    int m = 0;
    if (kind == OCLS_ELLIPSOID) {
        if (unit_sphere_roots(f1, g, &r[0], &r[1])) m = 2;
    } else if (kind == OCLS_CYLINDER) {
        if (unit_sphere_roots((float3)(f1.x, f1.y, 0.0f), (float3)(g.x, g.y, 0.0f), &r[0], &r[1])) m = 2;
        if (g.z != 0.0f) {
            r[m++] = (1.0f - f1.z) / g.z;
            r[m++] = (-1.0f - f1.z) / g.z;
        }
    } else {
        const float A = g.x * g.x + g.y * g.y;
        const float B = 2.0f * (f1.x * g.x + f1.y * g.y) - g.z;
        const float C = f1.x * f1.x + f1.y * f1.y - f1.z;
        m = quadratic_roots(A, B, C, r);
    }
    for (int k = 0; k < m; ++k) {
        const float tau = r[k], t = tc + tau;
        if (!(t >= t_lo && t <= t_hi && t < best)) continue;
        const float3 q = f1 + tau * g;
        float3 gk;
        if (kind == OCLS_ELLIPSOID) {
            gk = q;
        } else if (kind == OCLS_CYLINDER) {
            const int side = k >= m - 2 && g.z != 0.0f;          /* the last two roots are the caps */
            if (side ? q.x * q.x + q.y * q.y > 1.0f : fabs(q.z) > 1.0f) continue;
            gk = side ? (float3)(0.0f, 0.0f, k == m - 2 ? 1.0f : -1.0f) : (float3)(q.x, q.y, 0.0f);
        } else {
            if (q.z < 0.0f || q.z > 1.0f) continue;
            gk = (float3)(2.0f * q.x, 2.0f * q.y, -1.0f);
        }
        best = t;
        *grad = gk;
    }
    return best <= t_hi ? best : t_hi + 1.0f;
}

OCLS_INLINE float3 local_point(__global const float4 *m, float3 p)
{
    return (float3)(dot(m[0].xyz, p) + m[0].w, dot(m[1].xyz, p) + m[1].w, dot(m[2].xyz, p) + m[2].w);
}

OCLS_INLINE float3 local_vector(__global const float4 *m, float3 v)
{
    return (float3)(dot(m[0].xyz, v), dot(m[1].xyz, v), dot(m[2].xyz, v));
}

__kernel void quadric_cast(const int nq, __global const float4 *qf, __global const int4 *qi, const float4 cam,
                           const int IW, const int IH, const float4 hm0, const float4 hm1,
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
    float best = cam.w;
    int hit = -1;
    float3 grad = (float3)(0.0f);
    for (int k = 0; k < nq; ++k) {
        const int4 rect = qi[2 * k + 1];
        if (x < rect.x || x >= rect.z || y < rect.y || y >= rect.w) continue;
        __global const float4 *m = qf + 5 * k;
        float3 gk;
        const float t = quadric_hit(qi[2 * k].x, local_point(m, o), local_vector(m, d), cam.z, best, &gk);
        if (t <= best && (hit < 0 || t < best)) { best = t; hit = k; grad = gk; }
    }
    if (hit < 0) {
        position[i] = (float4)(0.0f); normal[i] = (float4)(0.0f); uv[i] = (float2)(0.0f);
        uv_grad[i] = (float4)(0.0f); depth[i] = INFINITY; albedo[i] = (float4)(0.0f); object[i] = 0;
        return;
    }
    __global const float4 *m = qf + 5 * hit;
    float3 n = normalize(m[0].xyz * grad.x + m[1].xyz * grad.y + m[2].xyz * grad.z);   /* M^T grad */
    if (dot(n, d) > 0.0f) n = -n;
    const float3 p = o + best * d;
    position[i] = (float4)(p, 1.0f);
    normal[i] = (float4)(n, 0.0f);
    uv[i] = (float2)(dot(hm0.xyz, p) + hm0.w, dot(hm1.xyz, p) + hm1.w);
    uv_grad[i] = (float4)(0.0f);
    depth[i] = best;
    albedo[i] = m[3];
    object[i] = hit + 1;
}

__kernel void gbuffer_merge(const int n, __global const float4 *s_pos, __global const float4 *s_nrm,
                            __global const float2 *s_uv, __global const float4 *s_grad,
                            __global const float *s_depth, __global const float4 *s_alb,
                            __global const int *s_obj, __global float4 *d_pos, __global float4 *d_nrm,
                            __global float2 *d_uv, __global float4 *d_grad, __global float *d_depth,
                            __global float4 *d_alb, __global int *d_obj)
{
    const int i = get_global_id(0);
    if (i >= n || !(s_depth[i] < d_depth[i])) return;
    d_pos[i] = s_pos[i]; d_nrm[i] = s_nrm[i]; d_uv[i] = s_uv[i]; d_grad[i] = s_grad[i];
    d_depth[i] = s_depth[i]; d_alb[i] = s_alb[i]; d_obj[i] = s_obj[i];
}

__kernel void object_normals(const int n, __global const int *object, __global const float4 *normal,
                             __global float4 *shading)
{
    const int i = get_global_id(0);
    if (i < n && object[i] != 0) shading[i] = normal[i];
}

__kernel void quadric_shadow(const int n, const int nq, __global const float4 *qf, __global const int4 *qi,
                             __global const float4 *position, __global const int *object, const float4 sun,
                             __global const float *h, const int H, const int W, const float zmax,
                             const float4 hm0, const float4 hm1, const float4 hm2, const float4 ray,
                             const float kshadow, __global float *coef)
{
    const int i = get_global_id(0);
    if (i >= n) return;
    const float4 pw = position[i];
    if (!(pw.w > 0.5f)) return;
    const int own = object[i];
    if (sun.w != 0.0f) {                      /* sun at or below the horizon */
        coef[i] = kshadow;
        return;
    }
    const float3 p = pw.xyz, s = sun.xyz;
    int blocked = 0;
    for (int k = 0; k < nq && !blocked; ++k) {
        const int kind = qi[2 * k].x;
        if (k + 1 == own && kind != OCLS_PARABOLOID) continue;     /* a closed convex shape */
        __global const float4 *m = qf + 5 * k;
        const float4 b = m[4];
        const float3 v = b.xyz - p;
        const float tc = dot(v, s);
        if (tc < -b.w || dot(v, v) - tc * tc > b.w * b.w) continue;  /* misses the bound */
        float3 gk;
        const float t_lo = k + 1 == own ? 1e-3f * b.w : 0.0f;
        blocked = quadric_hit(kind, local_point(m, p), local_vector(m, s), t_lo, INFINITY, &gk) < INFINITY;
    }
    if (!blocked && own > 0) {
        const float3 q = (float3)(dot(hm0.xyz, p) + hm0.w, dot(hm1.xyz, p) + hm1.w, dot(hm2.xyz, p) + hm2.w);
        blocked = terrain_blocks(h, H, W, zmax, q, ray);
    }
    if (blocked) coef[i] = kshadow;
    else if (own > 0) coef[i] = 1.0f;
}

__kernel void quadric_point_shadow(const int n, const int nq, __global const float4 *qf, __global const int4 *qi,
                                   __global const float4 *position, __global const int *object, const float4 light,
                                   const float kshadow, __global float *coef)
{
    const int i = get_global_id(0);
    if (i >= n) return;
    const float4 pw = position[i];
    if (!(pw.w > 0.5f)) return;
    const int own = object[i];
    const float3 p = pw.xyz, s = light.xyz - p;
    const float reach = sqrt(dot(s, s));
    if (!(reach > 0.0f)) return;
    const float3 sh = s / reach;
    for (int k = 0; k < nq; ++k) {
        const int kind = qi[2 * k].x;
        if (k + 1 == own && kind != OCLS_PARABOLOID) continue;     /* a closed convex shape */
        __global const float4 *m = qf + 5 * k;
        const float4 b = m[4];
        const float3 v = b.xyz - p;
        const float tc = dot(v, sh);
        if (tc < -b.w || tc > reach + b.w || dot(v, v) - tc * tc > b.w * b.w) continue;  /* misses the bound */
        float3 gk;
        const float t_lo = k + 1 == own ? 1e-3f * b.w / reach : 0.0f;
        if (quadric_hit(kind, local_point(m, p), local_vector(m, s), t_lo, 1.0f, &gk) <= 1.0f) {
            coef[i] = kshadow;
            return;
        }
    }
}

__kernel void terrain_point_shadow(const int n, __global const float4 *position, __global const int *object,
                                   const float4 light, __global const float *h, const int H, const int W,
                                   const float zmax, const float4 hm0, const float4 hm1, const float4 hm2,
                                   const float kshadow, __global float *coef)
{
    const int i = get_global_id(0);
    if (i >= n) return;
    const float4 pw = position[i];
    if (!(pw.w > 0.5f)) {
        coef[i] = 1.0f;
        return;
    }
    const float3 p = pw.xyz;
    const float3 q = (float3)(dot(hm0.xyz, p) + hm0.w, dot(hm1.xyz, p) + hm1.w, dot(hm2.xyz, p) + hm2.w);
    const float3 d = light.xyz - q;
    const float major = fmax(fabs(d.x), fabs(d.y));
    const float4 seg = (float4)(d, major > 0.0f ? 1.0f / major : INFINITY);
    coef[i] = terrain_segment_blocks(h, H, W, zmax, q, seg, object[i] == 0) ? kshadow : 1.0f;
}
