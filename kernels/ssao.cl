/* ssao.cl — screen-space ambient occlusion over a G-buffer (paper 001):
 * preparation, the AO estimator (the paper's point samples, or line samples),
 * the N x N box blur and an edge-aware blur.
 *
 * ABI summary: five kernels, one work-item per pixel (ssao_ao, ssao_box_h, ssao_box_v: per
 * `lanes` = OCLS_SSAO_LANES adjacent pixels of a row), global size (W, H) (those three:
 * (ceil(W / lanes), H)) rounded up to any local size (surplus items store nothing; ssao_prepare
 * and ssao_edge have no early return).  Buffers are row-major, one row of W pixels after
 * another, read as plain floats; the 4-float fields are the G-buffer's (oclshade/gbuffer.py): pos = view-space x, y, z and
 * w = 1 hit / 0 empty; nrm = view-space unit normal (w unused).
 *
 *   ssao_prepare(pos, nrm, [alpha, alpha_eps], [nmap, tangent,] W, H, zbuf, nout)
 *     zbuf  float, W*H (out): view-space z of the pixel's surface, -INFINITY
 *           when the pixel is empty (pos.w < 0.5, a non-finite z, or
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
 *   ssao_ao(pos, nout, zbuf, W, H, prj, kern, m, mpad, radius, delta, seed, ao)
 *     global size (ceil(W / lanes), H): one work-item per `lanes` adjacent pixels of a row
 *     pos, nout as float * (4 floats per pixel; scalar loads, see below)
 *     prj   __constant float[16]: three rows (host float64, rounded once):
 *           with M the projection matrix, pru = W/2 (M[0] + M[3]),
 *           prv = H/2 (M[3] - M[1]), prw = M[3], so a view-space point A
 *           (w = 1) lands on pixel coordinates (pru.A / prw.A, prv.A / prw.A);
 *           then E: the homogeneous point all lines of sight meet (null vector
 *           of M's rows 0, 1, 3; camera centre with E.w = 1, or the view
 *           direction with E.w = 0, E.z > 0)
 *     kern  __constant float[3 mpad]: the sample table, structure of arrays
 *           x[mpad], y[mpad], z[mpad], entries m..mpad-1 NaN (they land nowhere,
 *           never counted); generated once by the host.  Point samples: the
 *           tangent-space kernel (unit radius, z along the normal); line
 *           samples: disk points (x, y) and chord half-lengths z = sqrt(1 - x^2 - y^2);
 *           ray samples: the same numbers read as unit tangent-space directions
 *     m     int, 1..256; mpad >= m (the host: m rounded up to a multiple of 8, a table
 *           layout, not `lanes`); radius,
 *           delta float (radius > 0); seed uint
 *     ao    float, W*H (out): unoccluded fraction 1 - k, 1 on empty pixels
 *           (line samples: 1 - occupied length / length)
 *   ssao_box_h(ao, zbuf, W, H, rad, tmp)      -D OCLS_BLUR_BOX
 *   ssao_box_v(tmp, zbuf, W, H, rad, out)     -D OCLS_BLUR_BOX
 *     global size (ceil(W / lanes), H): one work-item per `lanes` adjacent pixels of a row;
 *     tmp 2 W H floats, two planes: sums of AO over the hit pixels of the
 *     horizontal window, then their counts; out = mean over the hit pixels of the clipped
 *     (2 rad + 1)^2 window.  Separable exactly: the 2-D sums are products
 *     of 1-D windows (clipping at the border too); empty pixels stay 1.
 *   ssao_edge(ao, pos, nout, zbuf, W, H, rad, plane_tol, out)  -D OCLS_BLUR_EDGE
 *     weighted mean over the (2 rad + 1)^2 window (not separable: the
 *     weights depend on the pair of pixels), see "Edge-aware blur" below.
 *
 * -D options: OCLS_ALPHA (alpha map), OCLS_NORMAL_MAP (normal map),
 *   OCLS_RANGE_CHECK (range check), OCLS_PLANE_TEST (plane test, step 4: adds the
 *   float4 W*H buffer `plane` as the last argument of ssao_prepare (out) and of
 *   ssao_ao (in)), OCLS_LINES (line samples, see below; not in the paper),
 *   OCLS_RAYS with OCLS_RAY_STEPS=k (ray samples, see below; not in the paper),
 *   OCLS_BLUR_BOX, OCLS_BLUR_EDGE (which blur
 *   kernels the program holds).  A feature not defined is not compiled.
 *   OCLS_SSAO_LANES=lanes, lanes in {4, 8, 16} (default 8): the pixels per work-item of
 *   ssao_ao, ssao_box_h and ssao_box_v (their vector width); a speed setting only, every
 *   value gives the same result bits.
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
 *   4. the depth test, against the stored surface where it is known: on the line
 *      of sight of the sample's pixel j, through j's stored point Q (pos[j]),
 *      o = E.xyz - E.w Q towards the camera.  The sample is moved onto that line
 *      at its own depth, A' = Q + o (A_t.z - Q.z) / o.z (at most half a pixel
 *      sideways); it counts only when A' is on or above P's base plane,
 *      N . (Q - P) + (A_t.z - Q.z) / o.z N . o >= 0, and is occluded iff
 *      z_t >= A_t.z + delta (z_t = zbuf[j], = Q.z).  Comparing A_t itself with the
 *      depth at the pixel centre instead (the paper) makes an oblique plane
 *      occlude itself: the stored depth is nearer than the plane at A_t for
 *      samples on the near side of the centre; here, on any plane, a counted
 *      sample lies above the plane and a sample behind it is not counted, so a
 *      plane reads 1 up to float32 rounding (a point within rounding of the
 *      plane may flip; delta above the G-buffer's rounding removes that).  Pixel j
 *      holds no usable surface (empty: z_t = -inf, o.z <= 0, Q or o not finite):
 *      the sample counts and is not occluded.  With
 *      OCLS_PLANE_TEST (not in the paper) instead: counted, and occluded iff L.xyz . A_t - L.w <= -delta,
 *      L = plane[pixel]: the sample lies at least delta below the tangent plane
 *      of the occluder's surface (written by ssao_prepare: L = (N, N . Q) from
 *      the pixel's position Q and geometric normal N normalised, before any
 *      normal map; (0, 0, 1, Q.z) for a degenerate N, i.e. the depth test;
 *      (0, 0, 0, -inf) on empty pixels: never occludes); exact on a plane too,
 *      by extending the occluder's plane to A_t.  With
 *      OCLS_RANGE_CHECK also z_t - P.z <= R (an occluder more than R in
 *      front of P cannot be inside the hemisphere; the paper has no check);
 *   5. AO = 1 - occluded / counted (1 when nothing is counted).
 *   Normals with |N|^2 not in (1e-12, inf) (zero, NaN) give AO = 1.
 *
 * Line samples (-D OCLS_LINES; volumetric obscurance after Loos and Sloan 2010):
 *   the same quantity as the points of a volume-uniform kernel, the occupied
 *   fraction of the hemisphere (ball of radius R at P cut by N . (X - P) >= 0),
 *   integrated along lines instead of sampled at points.  Under the depth-buffer
 *   model the solid along a line of sight is one interval, behind the stored
 *   surface, so one fetch per line suffices; along the normal it would not (the
 *   line crosses many pixels).  For a hit pixel with P, N:
 *   L1. U = (E.xyz - E.w P) / |.|, P's line of sight towards the camera; a pixel
 *       with U.z <= 0 or a non-finite |.|^2 gets AO = 1;
 *   L2. steps 1-2 with U in place of N: T, B span the disk perpendicular to U;
 *   L3. for each table entry (x, y, hs): A = P + R (T x + B y), its pixel as in
 *       step 3 (skipped off screen or behind the camera); the line A + t U meets
 *       the ball for |t| <= h = R hs, and the base plane where a + t c >= 0,
 *       a = R (x N.T + y N.B), c = N . U: t >= t_c = -a / c when c >= 0 (c = 0:
 *       everything when a >= 0, nothing when a < 0), t <= t_c when c < 0; so the
 *       line's chord is [lo, hi] and its length max(hi - lo, 0);
 *   L4. the depth test (as in step 4, along the line the depth is known on): the
 *       line is replaced by the line of sight of A's pixel j, Q + t D through j's
 *       stored point Q, D = o / |o| (o as in step 4), in the coordinate
 *       tau = t + b, b = (Q - P) . D (tau = 0 closest to P): it meets the ball for
 *       |tau| <= hq = sqrt(max(R^2 - |(Q - P) x D|^2, 0)) (the cross product keeps
 *       the distance accurate when Q is far from P), the base plane where
 *       a' + tau c' >= 0, a' = N . (Q - P) - b c', c' = N . D (cut as in L3), and
 *       the solid is tau <= b - delta / D.z (at least delta behind Q); occupied
 *       length max(min(hi, b - delta / D.z) - lo, 0).  On any plane the solid
 *       part lies beyond the base plane: a plane reads 1 up to float32 rounding.
 *       A pixel j without a usable surface (step 4): the line of L3, nothing
 *       solid.  With the plane test: the line of L3, solid below the occluder's
 *       plane L by delta, t <= t_s = (-delta - (L.xyz . A - L.w)) / (L.xyz . U) when
 *       L.xyz . U > 0, else the point test of step 4 at A decides the whole line
 *       (+inf or -inf); occupied length max(min(hi, t_s) - lo, 0).  Either way 0
 *       when the range check (z_t - P.z <= R) fails;
 *   L5. AO = 1 - (sum of occupied lengths) / (sum of lengths) over the lines on
 *       screen, 1 when that sum is 0.
 *   Exact up to the per-pixel depth and the m-line quadrature, whose nodes move by
 *   at most half a pixel (to the pixels' lines of sight).
 *
 * Ray samples (-D OCLS_RAYS, OCLS_RAY_STEPS = k; not in the paper): the screen-space
 *   estimate of ray-traced AO (cosine-weighted rays of length R, a ray occluded when
 *   it meets the surface): steps 1-2 with N; each table entry is a unit direction
 *   S (Malley: cosine-weighted), tested at the k points A = P + R (i / k)
 *   (T S.x + B S.y + N S.z), i = 1..k, each by steps 3-4; the ray counts when all
 *   its points are on screen and in front of the camera, and is occluded when one of
 *   its counted points is (with the range check: one within range); AO = 1 -
 *   occluded rays / counted rays (1 when none counts).
 *
 * Edge-aware blur: weight of neighbour q for centre p (both hit) is
 *   w = c^4 / (1 + (d / plane_tol)^2),  c = max(N_p . N_q, 0),
 *   d = |N_p . (P_q - P_p)|  (distance of q from p's tangent plane);
 * the centre gets |N|^8 (1 for unit normals).  Only +, *, / are used, no exp.
 */
#include "common.h"

#define OCLS_HASH_SALT 0x9e3779b9u
/* x is finite (no isfinite(): PoCL's builtin call keeps the work-item loop scalar) */
#define OCLS_FINITE(x) ((x) - (x) == 0.0f)

/* A 32-bit integer mix (xorshift-multiply rounds), on uint or uint vector lanes alike;
 * CPU twin: reference/ao.py. */
#define OCLS_MIX_ROUNDS(x) \
    x ^= x >> 16; x *= 0x7feb352du; x ^= x >> 15; x *= 0x846ca68bu; x ^= x >> 16
OCLS_INLINE uint ocls_mix(uint x)
{
    OCLS_MIX_ROUNDS(x);
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

__kernel void ssao_prepare(__global const float *restrict pos, __global const float *restrict nrm,
#ifdef OCLS_ALPHA
                           __global const float *restrict alpha, float alpha_eps,
#endif
#ifdef OCLS_NORMAL_MAP
                           __global const float *restrict nmap, __global const float *restrict tangent,
#endif
                           int W, int H, __global float *restrict zbuf, __global float *restrict nout
#ifdef OCLS_PLANE_TEST
                           , __global float *restrict plane
#endif
                           )
{
    const int c = get_global_id(0), r = get_global_id(1);
    const int inside = c < W && r < H;
    const int i = inside ? r * W + c : 0;
    /* x and y are not read: four adjacent loads merge into one float4 load that
     * keeps PoCL from vectorising; a non-finite x or y gives AO 1 (no sample counted) */
    const float pz = pos[4 * i + 2], pw = pos[4 * i + 3];
    int hit = pw >= 0.5f && OCLS_FINITE(pz);
#ifdef OCLS_ALPHA
    hit = hit && alpha[i] >= alpha_eps;
#endif
    float nx = nrm[4 * i], ny = nrm[4 * i + 1], nz = nrm[4 * i + 2];
#ifdef OCLS_PLANE_TEST
    /* the occluder's tangent plane from the geometric normal (before any normal map) */
    const float gnn = nx * nx + ny * ny + nz * nz;
    const int gok = gnn > 1e-12f && OCLS_FINITE(gnn);
    const float gl = gok ? sqrt(gnn) : 1.0f;
    const float plx = gok ? nx / gl : 0.0f, ply = gok ? ny / gl : 0.0f, plz = gok ? nz / gl : 1.0f;
    const float px = pos[4 * i], py = pos[4 * i + 1];
    const float pld = plx * px + ply * py + plz * pz;
    const int pok = hit && OCLS_FINITE(pld);
#endif
#ifdef OCLS_NORMAL_MAP
    {
        const float gx = tangent[4 * i], gy = tangent[4 * i + 1], gz = tangent[4 * i + 2];
        const float hand = tangent[4 * i + 3] < 0.0f ? -1.0f : 1.0f;
        const float gn = gx * nx + gy * ny + gz * nz;
        const float tx = gx - nx * gn, ty = gy - ny * gn, tz = gz - nz * gn;
        const float tt = tx * tx + ty * ty + tz * tz;
        const int tok = tt > 1e-12f && OCLS_FINITE(tt);
        const float tl = tok ? sqrt(tt) : 1.0f;
        const float Tx = tx / tl, Ty = ty / tl, Tz = tz / tl;
        const float Bx = (ny * Tz - nz * Ty) * hand, By = (nz * Tx - nx * Tz) * hand, Bz = (nx * Ty - ny * Tx) * hand;
        const float qx = nmap[4 * i], qy = nmap[4 * i + 1], qz = nmap[4 * i + 2];
        const float mx = Tx * qx + Bx * qy + nx * qz, my = Ty * qx + By * qy + ny * qz, mz = Tz * qx + Bz * qy + nz * qz;
        const float mm = mx * mx + my * my + mz * mz;
        const int ok = tok && mm > 1e-12f && OCLS_FINITE(mm);
        const float ml = ok ? sqrt(mm) : 1.0f;
        nx = ok ? mx / ml : nx;
        ny = ok ? my / ml : ny;
        nz = ok ? mz / ml : nz;
    }
#endif
    if (inside) {
        zbuf[i] = hit ? pz : -INFINITY;
        nout[4 * i] = nx;
        nout[4 * i + 1] = ny;
        nout[4 * i + 2] = nz;
        nout[4 * i + 3] = 0.0f;
#ifdef OCLS_PLANE_TEST
        plane[4 * i] = pok ? plx : 0.0f;
        plane[4 * i + 1] = pok ? ply : 0.0f;
        plane[4 * i + 2] = pok ? plz : 0.0f;
        plane[4 * i + 3] = pok ? pld : -INFINITY;
#endif
    }
}

/* ssao_ao, ssao_box_h, ssao_box_v: one work-item per OCLS_SSAO_LANES horizontally adjacent
 * pixels, every step on vector lanes of that width (explicit SIMD: PoCL does not vectorise
 * these kernels' work-item loops by itself); lanes past the row end compute on a copy of the
 * item's first pixel and store nothing.  Per lane the operations are those of the scalar
 * definition above, in the same order, so the width changes the speed, never a result bit. */
#ifndef OCLS_SSAO_LANES
#define OCLS_SSAO_LANES 8
#endif
#if OCLS_SSAO_LANES != 4 && OCLS_SSAO_LANES != 8 && OCLS_SSAO_LANES != 16
#error "OCLS_SSAO_LANES must be 4, 8 or 16"
#endif
/* the OCLS_SSAO_LANES-wide types and built-ins (common.h): float -> float8, vload -> vload8, ... */
#define ocls_vfloat OCLS_CAT(float, OCLS_SSAO_LANES)
#define ocls_vint OCLS_CAT(int, OCLS_SSAO_LANES)
#define ocls_vuint OCLS_CAT(uint, OCLS_SSAO_LANES)
#define ocls_convert_vfloat(x) OCLS_CONVERT_TO(ocls_vfloat, x)
#define ocls_convert_vint(x) OCLS_CONVERT_TO(ocls_vint, x)
#define ocls_convert_vuint(x) OCLS_CONVERT_TO(ocls_vuint, x)
#define ocls_vload OCLS_LANE_FN(vload, OCLS_SSAO_LANES)
#define ocls_vstore OCLS_LANE_FN(vstore, OCLS_SSAO_LANES)
#define ocls_vload4 OCLS_LANE_FN(vload, 4)

#define OCLS_DOT3(ax, ay, az, bx, by, bz) ((ax) * (bx) + (ay) * (by) + (az) * (bz))
/* The lane numbers (0, 1, ..., lanes - 1), and OCLS_QUADS(M, p, q, r, t): the lanes' components
 * s0 .. sf four at a time, M(p, q, r, t, a, b, c, d) per four lanes, separated by commas (four
 * fixed arguments, unused ones passed as 0: OpenCL C 1.2 has no variadic macros, and NVIDIA's
 * compiler refuses them). */
#if OCLS_SSAO_LANES == 4
#define OCLS_LANE_IDS (int4)(0, 1, 2, 3)
#define OCLS_QUADS(M, p, q, r, t) M(p, q, r, t, s0, s1, s2, s3)
#elif OCLS_SSAO_LANES == 8
#define OCLS_LANE_IDS (int8)(0, 1, 2, 3, 4, 5, 6, 7)
#define OCLS_QUADS(M, p, q, r, t) M(p, q, r, t, s0, s1, s2, s3), M(p, q, r, t, s4, s5, s6, s7)
#else
#define OCLS_LANE_IDS (int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15)
#define OCLS_QUADS(M, p, q, r, t) M(p, q, r, t, s0, s1, s2, s3), M(p, q, r, t, s4, s5, s6, s7), \
                                  M(p, q, r, t, s8, s9, sa, sb), M(p, q, r, t, sc, sd, se, sf)
#endif
/* OCLS_GATHER(buf, idx, stride, off): the float vector of buf[stride idx + off] per lane of the
 * int vector idx (OCLS_G4: four of its lanes) */
#define OCLS_AT(buf, i, stride, off) (buf)[(stride) * (i) + (off)]
#define OCLS_G4(buf, idx, stride, off, a, b, c, d) \
    OCLS_AT(buf, (idx).a, stride, off), OCLS_AT(buf, (idx).b, stride, off), \
    OCLS_AT(buf, (idx).c, stride, off), OCLS_AT(buf, (idx).d, stride, off)
#define OCLS_GATHER(buf, idx, stride, off) ((ocls_vfloat)(OCLS_QUADS(OCLS_G4, buf, idx, stride, off)))
/* OCLS_LOAD4(buf, j, lx, ly, lz, ld): the 4-float records (x, y, z, w) of the pixels j in buf
 * (occluder planes, positions), one 16-byte load per lane, transposed into lx, ly, lz, ld.
 * OCLS_P4_LOAD declares q_<a>, the records of four lanes a .. d (x, y, z, w of lane a, then of
 * b, ...); OCLS_P4_PART picks one component of the four (swizzle sw: x s048c, y s159d, z s26ae,
 * w s37bf). */
#define OCLS_P4_LOAD(buf, j, unused1, unused2, a, b, c, d) \
    q_##a = (float16)(ocls_vload4((j).a, buf), ocls_vload4((j).b, buf), \
                      ocls_vload4((j).c, buf), ocls_vload4((j).d, buf))
#define OCLS_P4_PART(sw, unused1, unused2, unused3, a, b, c, d) q_##a.sw
#define OCLS_LOAD4(buf, j, lx, ly, lz, ld) { \
    const float16 OCLS_QUADS(OCLS_P4_LOAD, buf, j, 0, 0); \
    lx = (ocls_vfloat)(OCLS_QUADS(OCLS_P4_PART, s048c, 0, 0, 0)); \
    ly = (ocls_vfloat)(OCLS_QUADS(OCLS_P4_PART, s159d, 0, 0, 0)); \
    lz = (ocls_vfloat)(OCLS_QUADS(OCLS_P4_PART, s26ae, 0, 0, 0)); \
    ld = (ocls_vfloat)(OCLS_QUADS(OCLS_P4_PART, s37bf, 0, 0, 0)); }
/* OCLS_SIGHT(j, zt): step 4's pixel j (depth zt): declares its stored point Q = (qx, qy, qz) (from
 * pos), w = Q - P, its line of sight o = E.xyz - E.w Q towards the camera (E = prj[12..15], not
 * normalised) and surf: j holds a surface usable as an occluder (zt > -inf, o.z > 0, o and w finite). */
#define OCLS_SIGHT(j, zt) \
    ocls_vfloat qx, qy, qz, qd; \
    OCLS_LOAD4(pos, j, qx, qy, qz, qd); \
    const ocls_vfloat ox = prj[12] - prj[15] * qx, oy = prj[13] - prj[15] * qy, oz = prj[14] - prj[15] * qz; \
    const ocls_vfloat wx = qx - Px, wy = qy - Py, wz = qz - Pz; \
    const ocls_vint surf = ((zt) != -INFINITY) & (oz > 0.0f) & (OCLS_DOT3(ox, oy, oz, ox, oy, oz) < INFINITY) \
                           & (OCLS_DOT3(wx, wy, wz, wx, wy, wz) < INFINITY)

/* Stores the lanes of v at p[0], p[1], ... (p: pixel c0 of a row of W pixels), those before the row end. */
OCLS_INLINE void ocls_store_lanes(ocls_vfloat v, int c0, int W, __global float *p)
{
    if (c0 + OCLS_SSAO_LANES <= W) {
        ocls_vstore(v, 0, p);
    } else {
        float a[OCLS_SSAO_LANES];
        ocls_vstore(v, 0, a);
        for (int k = 0; c0 + k < W; ++k)
            p[k] = a[k];
    }
}

OCLS_INLINE ocls_vuint ocls_mixv(ocls_vuint x)
{
    OCLS_MIX_ROUNDS(x);
    return x;
}

OCLS_INLINE ocls_vfloat ocls_signed_unitv(ocls_vuint h)
{
    const ocls_vint k = ocls_convert_vint(h >> 8);
    return ocls_convert_vfloat(2 * k + 1 - (1 << 24)) * 0x1p-24f;
}

#ifndef OCLS_DEPTH_TOL
#error "OCLS_DEPTH_TOL (the depth test's relative tolerance, oclshade.ssao.DEPTH_TOL) must be defined"
#endif
#if defined(OCLS_RAYS) && !defined(OCLS_RAY_STEPS)
#error "OCLS_RAYS needs OCLS_RAY_STEPS (points per ray)"
#endif
#ifndef OCLS_LINES
/* Steps 3-4 for one point A per lane, given as its clip coordinates (qu, qv, qw) and view-space
 * (ax, ay, az): *on = on screen and in front of the camera, *count = counted (on, and with the
 * depth test the snapped point on or above P's base plane); returns "occluded" (without the range
 * check's verdict folded into *count: the caller counts with *count, occluded with both). */
#ifdef OCLS_PLANE_TEST
#define OCLS_PLANE_ARG , __global const float *restrict plane
#define OCLS_PLANE_PASS , plane
#else
#define OCLS_PLANE_ARG
#define OCLS_PLANE_PASS
#endif
#define OCLS_POINT_ARGS pos, zbuf OCLS_PLANE_PASS, prj, W, fW, fH, ii, Px, Py, Pz, Nx, Ny, Nz, radius, delta
OCLS_INLINE ocls_vint ocls_point(__global const float *restrict pos, __global const float *restrict zbuf OCLS_PLANE_ARG,
                                 __constant float *prj, int W, float fW, float fH, ocls_vint ii,
                                 ocls_vfloat Px, ocls_vfloat Py, ocls_vfloat Pz, ocls_vfloat Nx, ocls_vfloat Ny,
                                 ocls_vfloat Nz, float radius, float delta, ocls_vfloat qu, ocls_vfloat qv,
                                 ocls_vfloat qw, ocls_vfloat ax, ocls_vfloat ay, ocls_vfloat az,
                                 ocls_vint *on_out, ocls_vint *count_out)
{
    const ocls_vfloat inv = 1.0f / qw;
    const ocls_vfloat u = qu * inv, y = qv * inv;
    const ocls_vint on = (qw > 0.0f) & (u >= 0.0f) & (u < fW) & (y >= 0.0f) & (y < fH);
    const ocls_vint j = select(ii, ocls_convert_vint(y) * W + ocls_convert_vint(u), on);
#ifdef OCLS_PLANE_TEST
    ocls_vfloat lx, ly, lz, ld;
    OCLS_LOAD4(plane, j, lx, ly, lz, ld);
    ocls_vint occ = OCLS_DOT3(lx, ly, lz, ax, ay, az) - ld <= -delta;
    *count_out = on;
#else
    /* the depth test; the sample moved onto pixel j's line of sight at its own depth,
     * A' = Q + o (A.z - Q.z) / o.z, counts only on or above P's base plane (step 4) */
    const ocls_vfloat zt = OCLS_GATHER(zbuf, j, 1, 0);
    OCLS_SIGHT(j, zt);
    ocls_vint occ = surf & (zt >= az + (delta + OCLS_DEPTH_TOL * fabs(zt)));
    const ocls_vfloat base = OCLS_DOT3(Nx, Ny, Nz, wx, wy, wz) + (az - qz) / oz * OCLS_DOT3(Nx, Ny, Nz, ox, oy, oz);
    *count_out = on & (~surf | (base >= 0.0f));
#endif
#ifdef OCLS_RANGE_CHECK
#ifdef OCLS_PLANE_TEST
    const ocls_vfloat zt = OCLS_GATHER(zbuf, j, 1, 0);
#endif
    occ = occ & (zt - Pz <= radius);
#endif
    *on_out = on;
    return occ;
}
#endif

__kernel void ssao_ao(__global const float *restrict pos, __global const float *restrict nrm,
                      __global const float *restrict zbuf, int W, int H,
                      __constant float *prj, __constant float *kern, int m, int mpad, float radius,
                      float delta, uint seed, __global float *restrict ao
#ifdef OCLS_PLANE_TEST
                      , __global const float *restrict plane
#endif
                      )
{
    const int c0 = OCLS_SSAO_LANES * (int)get_global_id(0), r = get_global_id(1);
    if (c0 >= W || r >= H) return;
    const ocls_vint cc = c0 + OCLS_LANE_IDS;
    const ocls_vint inside = cc < W;
    const ocls_vint ii = select((ocls_vint)(r * W + c0), r * W + cc, inside);
    const ocls_vfloat zc = OCLS_GATHER(zbuf, ii, 1, 0);
    const ocls_vfloat n0x = OCLS_GATHER(nrm, ii, 4, 0), n0y = OCLS_GATHER(nrm, ii, 4, 1), n0z = OCLS_GATHER(nrm, ii, 4, 2);
    const ocls_vfloat Px = OCLS_GATHER(pos, ii, 4, 0), Py = OCLS_GATHER(pos, ii, 4, 1), Pz = OCLS_GATHER(pos, ii, 4, 2);
    const ocls_vfloat nn = OCLS_DOT3(n0x, n0y, n0z, n0x, n0y, n0z);
    const ocls_vint live0 = inside & (zc != -INFINITY) & (nn > 1e-12f) & (nn < INFINITY);
    const ocls_vfloat one = (ocls_vfloat)(1.0f), zero = (ocls_vfloat)(0.0f);
#ifdef OCLS_LINES
    /* P's line of sight U = (E.xyz - E.w P) / |.| towards the camera, E = prj[12..15] */
    const ocls_vfloat gux = prj[12] - prj[15] * Px, guy = prj[13] - prj[15] * Py, guz = prj[14] - prj[15] * Pz;
    const ocls_vfloat gu = OCLS_DOT3(gux, guy, guz, gux, guy, guz);
    const ocls_vint live = live0 & (gu < INFINITY) & (guz > 0.0f);
    const ocls_vfloat ul = select(one, sqrt(gu), live);
    const ocls_vfloat Fx = select(zero, gux / ul, live), Fy = select(zero, guy / ul, live), Fz = select(one, guz / ul, live);
#else
    const ocls_vint live = live0;
#endif
    const ocls_vfloat nl = select(one, sqrt(nn), live);
    const ocls_vfloat Nx = select(zero, n0x / nl, live), Ny = select(zero, n0y / nl, live), Nz = select(one, n0z / nl, live);
#ifndef OCLS_LINES
    const ocls_vfloat Fx = Nx, Fy = Ny, Fz = Nz;     /* the frame's axis: N (lines: U) */
#endif

    /* steps 1-2: rotation vector and Gram-Schmidt against the frame's axis F */
    const ocls_vuint h = ocls_mixv(ocls_convert_vuint(cc) ^ (ocls_vuint)(ocls_mix((uint)r ^ ocls_mix(seed))));
    const ocls_vfloat vx = ocls_signed_unitv(h), vy = ocls_signed_unitv(ocls_mixv(h ^ OCLS_HASH_SALT));
    const ocls_vfloat vn = vx * Fx + vy * Fy;
    const ocls_vfloat gx = vx - Fx * vn, gy = vy - Fy * vn, gz = 0.0f - Fz * vn;
    const ocls_vfloat ax = fabs(Fx), ay = fabs(Fy), az = fabs(Fz);
    const ocls_vint ex = (ax <= ay) & (ax <= az), ey = ~ex & (ay <= az), ez = ~ex & ~ey;
    const ocls_vfloat en = select(select(Fz, Fy, ey), Fx, ex);     /* e . F for the axis e */
    const ocls_vint fallback = ~(OCLS_DOT3(gx, gy, gz, gx, gy, gz) >= 1e-8f);
    const ocls_vfloat tx = select(gx, select(zero, one, ex) - Fx * en, fallback);
    const ocls_vfloat ty = select(gy, select(zero, one, ey) - Fy * en, fallback);
    const ocls_vfloat tz = select(gz, select(zero, one, ez) - Fz * en, fallback);
    const ocls_vfloat tl = sqrt(OCLS_DOT3(tx, ty, tz, tx, ty, tz));
    const ocls_vfloat Tx = tx / tl, Ty = ty / tl, Tz = tz / tl;
    const ocls_vfloat Bx = Fy * Tz - Fz * Ty, By = Fz * Tx - Fx * Tz, Bz = Fx * Ty - Fy * Tx;
    const ocls_vfloat RTx = Tx * radius, RTy = Ty * radius, RTz = Tz * radius;
    const ocls_vfloat RBx = Bx * radius, RBy = By * radius, RBz = Bz * radius;

    /* step 3, projected: clip coordinates are linear in A_t, so the pixel's
     * P, R T, R B and R N are projected once (rows prj, see the ABI). */
    const ocls_vfloat cpu = OCLS_DOT3(prj[0], prj[1], prj[2], Px, Py, Pz) + prj[3];
    const ocls_vfloat cpv = OCLS_DOT3(prj[4], prj[5], prj[6], Px, Py, Pz) + prj[7];
    const ocls_vfloat cpw = OCLS_DOT3(prj[8], prj[9], prj[10], Px, Py, Pz) + prj[11];
    const ocls_vfloat ctu = OCLS_DOT3(prj[0], prj[1], prj[2], RTx, RTy, RTz);
    const ocls_vfloat ctv = OCLS_DOT3(prj[4], prj[5], prj[6], RTx, RTy, RTz);
    const ocls_vfloat ctw = OCLS_DOT3(prj[8], prj[9], prj[10], RTx, RTy, RTz);
    const ocls_vfloat cbu = OCLS_DOT3(prj[0], prj[1], prj[2], RBx, RBy, RBz);
    const ocls_vfloat cbv = OCLS_DOT3(prj[4], prj[5], prj[6], RBx, RBy, RBz);
    const ocls_vfloat cbw = OCLS_DOT3(prj[8], prj[9], prj[10], RBx, RBy, RBz);
    const float fW = (float)W, fH = (float)H;

#ifdef OCLS_LINES
    /* line samples (see "Line samples"): the chord |t| <= R hs of the line A + t U, cut by the
     * base plane a + t c >= 0 at t_c = -a / c (c = 0: a >= 0 keeps the chord, a < 0 empties it) */
    const ocls_vfloat RnT = radius * OCLS_DOT3(Nx, Ny, Nz, Tx, Ty, Tz), RnB = radius * OCLS_DOT3(Nx, Ny, Nz, Bx, By, Bz);
    const ocls_vfloat cN = OCLS_DOT3(Nx, Ny, Nz, Fx, Fy, Fz);
    const ocls_vint cpos = cN >= 0.0f;
    const ocls_vfloat ninv_c = select(-1.0f / cN, (ocls_vfloat)(-INFINITY), cN == 0.0f);
#ifndef OCLS_PLANE_TEST
    const float rr = radius * radius;
#endif
    ocls_vfloat len_sum = zero, occ_sum = zero;
    for (int t = 0; t < m; ++t) {
        const float sx = kern[t], sy = kern[mpad + t], hc = radius * kern[2 * mpad + t];
        const ocls_vfloat qu = cpu + (ctu * sx + cbu * sy);
        const ocls_vfloat qv = cpv + (ctv * sx + cbv * sy);
        const ocls_vfloat qw = cpw + (ctw * sx + cbw * sy);
        const ocls_vfloat az_t = Pz + (RTz * sx + RBz * sy);
        const ocls_vfloat inv = 1.0f / qw;
        const ocls_vfloat u = qu * inv, y = qv * inv;
        const ocls_vint on = (qw > 0.0f) & (u >= 0.0f) & (u < fW) & (y >= 0.0f) & (y < fH);
        const ocls_vint j = select(ii, ocls_convert_vint(y) * W + ocls_convert_vint(u), on);
        const ocls_vfloat tc = (RnT * sx + RnB * sy) * ninv_c;
        const ocls_vfloat lo = select((ocls_vfloat)(-hc), fmax(-hc, tc), cpos);
        const ocls_vfloat hi = select(fmin(hc, tc), (ocls_vfloat)(hc), cpos);
#ifdef OCLS_PLANE_TEST
        /* solid: t <= t_s, the line below the occluder's plane by delta; a plane not facing
         * along U (L . U <= 0): the point test at A decides the whole line */
        const ocls_vfloat ax_t = Px + (RTx * sx + RBx * sy);
        const ocls_vfloat ay_t = Py + (RTy * sx + RBy * sy);
        ocls_vfloat lx, ly, lz, ld;
        OCLS_LOAD4(plane, j, lx, ly, lz, ld);
        const ocls_vfloat lu = OCLS_DOT3(lx, ly, lz, Fx, Fy, Fz);
        const ocls_vfloat la = OCLS_DOT3(lx, ly, lz, ax_t, ay_t, az_t) - ld;
        const ocls_vfloat ts = select(select((ocls_vfloat)(-INFINITY), (ocls_vfloat)(INFINITY), la <= -delta), (-delta - la) / lu,
                                 lu > 0.0f);
        const ocls_vfloat len = fmax(hi - lo, 0.0f);
        ocls_vfloat occl = fmax(fmin(hi, ts) - lo, 0.0f);
#else
        /* the depth test along pixel j's own line of sight Q + t D (step L4), in tau = t + b
         * (tau = 0 closest to P): chord |tau| <= hq, base plane a + tau cq >= 0, solid
         * tau <= b - delta / D.z; no usable surface: the line through A, nothing solid */
        const ocls_vfloat zt = OCLS_GATHER(zbuf, j, 1, 0);
        OCLS_SIGHT(j, zt);
        const ocls_vfloat il = select(one, 1.0f / sqrt(OCLS_DOT3(ox, oy, oz, ox, oy, oz)), surf);
        const ocls_vfloat Dx = ox * il, Dy = oy * il, Dz = select(one, oz * il, surf);
        const ocls_vfloat b = OCLS_DOT3(wx, wy, wz, Dx, Dy, Dz);
        const ocls_vfloat xx = wy * Dz - wz * Dy, xy = wz * Dx - wx * Dz, xz = wx * Dy - wy * Dx;
        const ocls_vfloat hq = sqrt(fmax(rr - OCLS_DOT3(xx, xy, xz, xx, xy, xz), 0.0f));
        const ocls_vfloat cq = OCLS_DOT3(Nx, Ny, Nz, Dx, Dy, Dz);
        const ocls_vfloat tq = (OCLS_DOT3(Nx, Ny, Nz, wx, wy, wz) - b * cq) * select(-1.0f / cq, (ocls_vfloat)(-INFINITY), cq == 0.0f);
        const ocls_vint qpos = cq >= 0.0f;
        const ocls_vfloat loq = select(-hq, fmax(-hq, tq), qpos), hiq = select(fmin(hq, tq), hq, qpos);
        const ocls_vfloat len = select(fmax(hi - lo, 0.0f), fmax(hiq - loq, 0.0f), surf);
        const ocls_vfloat tsq = b - (delta + OCLS_DEPTH_TOL * fabs(zt)) / Dz;
        ocls_vfloat occl = select(zero, fmax(fmin(hiq, tsq) - loq, 0.0f), surf);
#endif
#ifdef OCLS_RANGE_CHECK
#ifdef OCLS_PLANE_TEST
        const ocls_vfloat zt = OCLS_GATHER(zbuf, j, 1, 0);
#endif
        occl = select(zero, occl, zt - Pz <= radius);
#endif
        len_sum += select(zero, len, on);
        occ_sum += select(zero, occl, on);
    }
    const ocls_vfloat res = select(one, 1.0f - occ_sum / len_sum, live & (len_sum > 0.0f));
#else
    const ocls_vfloat RNx = Nx * radius, RNy = Ny * radius, RNz = Nz * radius;
    const ocls_vfloat cnu = OCLS_DOT3(prj[0], prj[1], prj[2], RNx, RNy, RNz);
    const ocls_vfloat cnv = OCLS_DOT3(prj[4], prj[5], prj[6], RNx, RNy, RNz);
    const ocls_vfloat cnw = OCLS_DOT3(prj[8], prj[9], prj[10], RNx, RNy, RNz);

    /* steps 3-5; ray samples: a ray counts when all its steps are on screen, and is occluded
     * when one of its counted steps is */
    ocls_vint cnt_sum = (ocls_vint)(0), occ_sum = (ocls_vint)(0);
    for (int t = 0; t < m; ++t) {
        const float sx = kern[t], sy = kern[mpad + t], sz = kern[2 * mpad + t];
        /* A - P = R (T sx + B sy + N sz): clip coordinates d(u, v, w) and view space d(x, y, z) */
        const ocls_vfloat du = ctu * sx + cbu * sy + cnu * sz, dv = ctv * sx + cbv * sy + cnv * sz;
        const ocls_vfloat dw = ctw * sx + cbw * sy + cnw * sz;
        const ocls_vfloat dx = RTx * sx + RBx * sy + RNx * sz, dy = RTy * sx + RBy * sy + RNy * sz;
        const ocls_vfloat dz = RTz * sx + RBz * sy + RNz * sz;
#ifdef OCLS_RAYS
        ocls_vint count = (ocls_vint)(-1), occ = (ocls_vint)(0);
        for (int k = 1; k <= OCLS_RAY_STEPS; ++k) {
            const float f = (float)k / (float)OCLS_RAY_STEPS;
            ocls_vint on_k, count_k;
            const ocls_vint occ_k = ocls_point(OCLS_POINT_ARGS, cpu + f * du, cpv + f * dv, cpw + f * dw,
                                               Px + f * dx, Py + f * dy, Pz + f * dz, &on_k, &count_k);
            count &= on_k;
            occ |= count_k & occ_k;
        }
#else
        ocls_vint on, count;
        const ocls_vint occ = ocls_point(OCLS_POINT_ARGS, cpu + du, cpv + dv, cpw + dw, Px + dx, Py + dy, Pz + dz,
                                         &on, &count);
#endif
        cnt_sum -= count;          /* vector comparisons give -1 for true */
        occ_sum -= count & occ;
    }
    const ocls_vfloat res = select(one, 1.0f - ocls_convert_vfloat(occ_sum) / ocls_convert_vfloat(cnt_sum), live & (cnt_sum > 0));
#endif
    ocls_store_lanes(res, c0, W, ao + r * W + c0);
}

#ifdef OCLS_BLUR_BOX
/* One work-item per OCLS_SSAO_LANES adjacent pixels of a row (see ssao_ao); window loops
 * run -rad..rad in that order for every lane (the sums are those of the scalar definition,
 * bitwise), clipped taps masked.  Interior items read whole rows of lanes (ocls_vload); items
 * whose window crosses a border take the masked path.  tmp holds two planes: the sums tmp[0, W H)
 * and the counts tmp[W H, 2 W H). */
__kernel void ssao_box_h(__global const float *restrict ao, __global const float *restrict zbuf,
                         int W, int H, int rad, __global float *restrict tmp)
{
    const int c0 = OCLS_SSAO_LANES * (int)get_global_id(0), r = get_global_id(1);
    if (c0 >= W || r >= H) return;
    const int row = r * W, n = W * H;
    ocls_vfloat sum = (ocls_vfloat)(0.0f), count = (ocls_vfloat)(0.0f);
    if (c0 - rad >= 0 && c0 + OCLS_SSAO_LANES - 1 + rad < W) {
        for (int k = -rad; k <= rad; ++k) {
            const ocls_vint hit = ocls_vload(0, zbuf + row + c0 + k) != -INFINITY;
            sum += select((ocls_vfloat)(0.0f), ocls_vload(0, ao + row + c0 + k), hit);
            count += select((ocls_vfloat)(0.0f), (ocls_vfloat)(1.0f), hit);
        }
    } else {
        const ocls_vint cc = c0 + OCLS_LANE_IDS;
        for (int k = -rad; k <= rad; ++k) {
            const ocls_vint x = cc + k;
            const ocls_vint ok = (x >= 0) & (x < W);
            const ocls_vint j = row + select((ocls_vint)(0), x, ok);
            const ocls_vint hit = ok & (OCLS_GATHER(zbuf, j, 1, 0) != -INFINITY);
            sum += select((ocls_vfloat)(0.0f), OCLS_GATHER(ao, j, 1, 0), hit);
            count += select((ocls_vfloat)(0.0f), (ocls_vfloat)(1.0f), hit);
        }
    }
    ocls_store_lanes(sum, c0, W, tmp + row + c0);
    ocls_store_lanes(count, c0, W, tmp + n + row + c0);
}

__kernel void ssao_box_v(__global const float *restrict tmp, __global const float *restrict zbuf,
                         int W, int H, int rad, __global float *restrict out)
{
    const int c0 = OCLS_SSAO_LANES * (int)get_global_id(0), r = get_global_id(1);
    if (c0 >= W || r >= H) return;
    const int n = W * H, full = c0 + OCLS_SSAO_LANES <= W;
    const ocls_vint cc = c0 + OCLS_LANE_IDS;
    const ocls_vint col = select((ocls_vint)(c0), cc, cc < W);
    ocls_vfloat sum = (ocls_vfloat)(0.0f), count = (ocls_vfloat)(0.0f);
    for (int k = -rad; k <= rad; ++k) {
        const int y = r + k;
        if (y < 0 || y >= H) continue;          /* uniform across the lanes */
        if (full) {
            sum += ocls_vload(0, tmp + y * W + c0);
            count += ocls_vload(0, tmp + n + y * W + c0);
        } else {
            const ocls_vint j = y * W + col;
            sum += OCLS_GATHER(tmp, j, 1, 0);
            count += OCLS_GATHER(tmp, j, 1, n);
        }
    }
    const ocls_vint i = r * W + col;
    const ocls_vfloat res = select(sum / count, (ocls_vfloat)(1.0f), OCLS_GATHER(zbuf, i, 1, 0) == -INFINITY);
    ocls_store_lanes(res, c0, W, out + r * W + c0);
}
#endif

#ifdef OCLS_BLUR_EDGE
__kernel void ssao_edge(__global const float *restrict ao, __global const float *restrict pos,
                        __global const float *restrict nrm, __global const float *restrict zbuf,
                        int W, int H, int rad, float plane_tol, __global float *restrict out)
{
    const int c = get_global_id(0), r = get_global_id(1);
    const int inside = c < W && r < H;
    const int i = inside ? r * W + c : 0;
    const float Px = pos[4 * i], Py = pos[4 * i + 1], Pz = pos[4 * i + 2];
    const float Nx = nrm[4 * i], Ny = nrm[4 * i + 1], Nz = nrm[4 * i + 2];
    const float inv_tol = 1.0f / plane_tol;
    float sum = 0.0f, wsum = 0.0f;
    for (int dy = -rad; dy <= rad; ++dy) {
        const int y = r + dy;
        const int oky = y >= 0 && y < H;
        for (int dx = -rad; dx <= rad; ++dx) {
            const int x = c + dx;
            const int ok = oky && x >= 0 && x < W;
            const int j = ok ? y * W + x : i;
            const int hit = ok && zbuf[j] != -INFINITY;
            const float cs = fmax(OCLS_DOT3(Nx, Ny, Nz, nrm[4 * j], nrm[4 * j + 1], nrm[4 * j + 2]), 0.0f);
            const float c2 = cs * cs;
            const float d = fabs(OCLS_DOT3(Nx, Ny, Nz, pos[4 * j] - Px, pos[4 * j + 1] - Py, pos[4 * j + 2] - Pz))
                            * inv_tol;
            const float w = hit ? (c2 * c2) / (1.0f + d * d) : 0.0f;
            sum += w * ao[j];
            wsum += w;
        }
    }
    if (inside)
        out[i] = zbuf[i] == -INFINITY ? 1.0f : (wsum > 0.0f ? sum / wsum : ao[i]);
}
#endif
