/* terrain.cl — heightmap terrain ray casting into a G-buffer (paper 004, voxel bisection).
 *
 * ABI
 *   terrain_cast(h, H, W, ext, ext_off, levels, dil, dil_lev, g0, g1, g2, r0, r1, r2, cam, IW, IH, cu, cv,
 *                geo, hrange, tex, tex_levels, ntex,
 *                position, normal, uv, uv_grad, depth, albedo[, stats])
 *   global size (>= IW, >= IH), any local size; one work-item per pixel.
 *     __global const float *h      H*W relative heights, row-major, NaN = hole
 *     int H, W                     map rows, cols
 *     __global const float2 *ext   extrema pyramid levels 1..levels-1 (pyramid.cl)
 *     __global const int *ext_off  level offsets in float2, indexed by level ([0] unused)
 *     int levels                   pyramid levels counting level 0
 *     __global const float *dil    dilated max levels lmin..levels-1, back to back (terrain_dilate),
 *                                  lmin = min(OCLS_LEAF, levels-1); read by bisect only
 *     __global const int2 *dil_lev per level 0..levels-1: (offset in floats, columns); entries
 *                                  below lmin are not read
 *     float4 g0, g1, g2            rows of the 3x4 affine map view -> (u', v', z)
 *     float4 r0, r1, r2            rows of the world -> view rotation (xyz)
 *     float4 cam                   (sx, sy, near, far): pixel-ray slopes (pinhole) or half
 *                                  extents (-D OCLS_ORTHO), see oclshade/camera.py
 *     int IW, IH                   image width, height in pixels
 *     int cu, cv                   centre sample (col, row)
 *     float4 geo                   (dx, dy, kx, ky)
 *     float4 hrange                (hmin, hmax, -, -) finite relative heights
 *     __global const float4 *tex   colour mip levels (linear RGBA), back to back (-D OCLS_COLOUR)
 *     __global const int4 *tex_levels  per level (offset in float4, cols, rows, 0)
 *     int ntex                     number of colour levels
 *   outputs (layout of oclshade/gbuffer.py), IW*IH each, row-major from the top row:
 *     float4 position (view xyz, w = 1 hit / 0 empty), float4 normal (view, w = 0),
 *     float2 uv, float4 uv_grad (du/dc, dv/dc, du/dr, dv/dr), float depth (+inf empty),
 *     float4 albedo (linear RGBA).  Empty pixels: 0 everywhere, depth +inf.
 *     __global uint *stats         (-D OCLS_STATS only) OCLS_STATS_N counters, atomically added:
 *                                  [l] (l < 32) voxel tests (bisect), texel visits (dda) or samples
 *                                  (march) at level l; [32] exact patch tests; [33] pixels with a
 *                                  non-empty segment; [34] hits
 *   terrain_dilate(h, H, W, ext, ext_off, l, Rl, Cl, out, off)
 *   builds dilated max level l for bisect, once per map, launched for l = lmin..levels-1;
 *   global size (>= Cl, >= Rl), any local size; one work-item per output texel.
 *     h, H, W, ext, ext_off        as for terrain_cast
 *     int l                        the level written
 *     int Rl, Cl                   its rows, cols: ceil(Hp / 2^l), ceil(Wp / 2^l) with
 *                                  Hp, Wp = max(H-1, 1), max(W-1, 1)
 *     __global float *out          all dilated levels back to back (the dil of terrain_cast)
 *     int off                      offset of level l in out (floats); texel (R, C) at off + R*Cl + C
 *   terrain_normals(h, H, W, uv, position, r0, r1, r2, geo, cu, cv, n, normal)
 *   smooth shading normals of a G-buffer made by terrain_cast (see "Shading normals" below);
 *   global size >= n (1-D), any local size; one work-item per pixel.
 *     h, H, W, r0, r1, r2, geo, cu, cv   as for terrain_cast
 *     __global const float2 *uv    the G-buffer's uv field (heightmap coordinates of the hit)
 *     __global const float4 *position  the G-buffer's position field (w = 1 hit)
 *     int n                        pixel count
 *     __global float4 *normal      n view-space unit normals (w = 0); 0 on empty pixels
 *   -D options (all kernels; the host passes -cl-std=CL1.2 and nothing else, no fast-math):
 *     OCLS_METHOD    1 bisect (default), 2 march, 3 dda
 *     OCLS_ORTHO     orthographic camera (cam.xy = half extents) instead of pinhole
 *     OCLS_SPHERE    paraboloid base of a sphere (geo.zw = kx, ky) instead of the plane
 *     OCLS_COLOUR    albedo from the colour mip levels (tex, tex_levels, ntex), else a
 *                    hypsometric tint of the height
 *     OCLS_DESCEND   bisect: levels a split descends (int >= 1, default 3)
 *     OCLS_LEAF      bisect: the leaf level (int >= 0, default 2): a voxel spanning at most
 *                    2^OCLS_LEAF patches that is not rejected is walked patch by patch
 *     OCLS_STATS     profiling counters (the stats argument)
 *     OCLS_MARCH_STEP  march: step in cells (float, default 0.5f)
 *     OCLS_MAX_IT    iteration bound of every loop (default 65536; reaching it = empty pixel)
 *
 * Surface (paper 004 sec. 4-5, differential heightmap): a base surface plus
 * per-sample deviations h (relative float32 heights, NaN = hole), bilinear
 * over each patch between 4 samples; no surface over a patch with a hole
 * corner, nothing beyond the map.  Coordinates inside the kernel are centred
 * heightmap coordinates (u', v', z): u' = column - cu, v' = row - cv (the
 * centre sample (cv, cu) keeps float32 coordinates small), z = world height
 * minus the map's offset.  Base plane: the surface is z = h(u', v').  With
 * -D OCLS_SPHERE the base is the paraboloid z = -(kx u'^2 + ky v'^2)
 * (kx = dx^2 / 2R, ky = dy^2 / 2R), i.e. the ray's height above the base is
 * z + kx u'^2 + ky v'^2.
 *
 * Hit: the first t in the visible segment [near, far] (t = -z_view, "the
 * voxel" of paper 004) where the ray crosses the surface downwards (back faces
 * are culled, so a camera under the terrain or in a hole looks through the
 * underside).  Per patch f(t) = ray height - surface is a quadratic in t
 * (bilinear along a line, plus the paraboloid) solved in closed form, so the
 * hit is exact up to float32 rounding.
 *
 * Methods (-D OCLS_METHOD):
 *   1 bisect (paper 004): the segment, clipped to the map's box (and, on a
 *     plane, to the height slab [hmin, hmax]), is subdivided front to back
 *     into voxels [ta, tb], starting with the whole segment.  Per voxel: LOD
 *     from its projection on the map (the paper's footprint, measured in
 *     patches: n = max(c1 - c0, r1 - r0) over the patch columns c0..c1 and
 *     rows r0..r1 under its end points), l = ceil(log2 n), so the projection
 *     meets at most 2 x 2 tiles of extrema level l; their max is one texel
 *     of the dilated max level l (terrain_dilate below, derived from the
 *     extrema pyramid once per map), so each test is one read.  The voxel is
 *     rejected (discarded) when its lowest point is above that max, split
 *     otherwise; a voxel of level <= OCLS_LEAF that is not rejected has its
 *     patches tested exactly (a walk over the at most 2^(l+1) + 1 patches it crosses).
 *     Paper fix: the paper compares with "the max at that LOD under the
 *     voxel" without saying which texels; one texel under a point is not
 *     conservative, the 2 x 2 tiles of the bounding box are.
 *     Deviations, measured in bench/results/terrain_cast.md (fewer voxel tests
 *     per ray, and a time that grows less with the map size):
 *     - split (-D OCLS_DESCEND j, default 3): instead of halving, the near
 *       part of the voxel that lies above the max just read is discarded (on
 *       a plane the ray meets that max at a closed-form t, the paper's
 *       discarding of a voxel above the max applied to the part), and the next
 *       voxel starts there with the length of level l - j (the t-length of
 *       2^(l-j) cells along the ray's major axis, shrunk by 1e-3 so the
 *       footprint cannot round up to the next level); a leaf discards its near
 *       part the same way before its walk;
 *     - after a rejected voxel (or a leaf without a hit) the next voxel starts
 *       at its end with the length of its level: the subdivision is not
 *       dyadic, the walk needs no stack and no node indices, and neighbours
 *       share their end point t bit for bit (the next ta is the last tb);
 *     - leaves (-D OCLS_LEAF, default 2) are voxels of level <= 2, not 0: the
 *       exact patch tests read the heights themselves, so dilated levels 0
 *       and 1 (1.25 times the map's size in floats) are neither built nor read,
 *       a voxel of level < OCLS_LEAF is tested against its level-OCLS_LEAF
 *       texel (the tiles of level OCLS_LEAF under its end points contain its
 *       footprint), and large maps touch far less memory per ray.
 *     OCLS_LEAF = 0 and OCLS_DESCEND = 1 are the paper's finest leaf and a
 *     halving of the footprint per split.
 *   2 march: uniform steps of OCLS_MARCH_STEP cells, the sign of f sampled at
 *     the steps; the first step that goes from above to below is walked
 *     exactly.  Misses crossings between samples (a baseline).
 *   3 dda: max-mipmap traversal (Tevs et al. 2008): texel by texel at the
 *     current level, descend when the ray's lowest point over the texel is at
 *     or below its max, otherwise step to the next texel and climb one level
 *     when that leaves the parent; level 0 is the exact patch test.
 *   All loops are bounded by OCLS_MAX_IT iterations (not reached on valid
 *   input; reaching it reports an empty pixel).
 *
 * Shading normals (terrain_normals; not in paper 004): the G-buffer's normal is the bilinear
 * patch's own (geometric) normal, exact for the surface the rays hit, but its slope jumps at
 * every cell edge, so a smooth terrain shades as facets.  The shading normal interpolates
 * instead: per sample the slope by central differences, (h[c+1] - h[c-1]) / 2 along each axis
 * (one-sided where a neighbour is a hole or off the map, 0 where both are), bilinearly
 * interpolated at the hit's uv over the 4 samples of its patch (weights (1-s)(1-w), s(1-w),
 * (1-s)w, sw; a sample of weight 0 or a hole is left out and the weights renormalised, so a
 * hole beyond an edge the hit lies on does not matter), plus the paraboloid's exact slope on a sphere.  The interpolated slope is
 * continuous across cell edges (no facets) and exact where the heights are a quadratic
 * polynomial (central differences are exact for it, and its slope is linear).
 */
#include "common.h"

#ifndef OCLS_METHOD
#define OCLS_METHOD 1
#endif
#ifndef OCLS_MARCH_STEP
#define OCLS_MARCH_STEP 0.5f
#endif
#ifndef OCLS_MAX_IT
#define OCLS_MAX_IT 65536
#endif
#ifndef OCLS_DESCEND
#define OCLS_DESCEND 3
#endif
#ifndef OCLS_LEAF
#define OCLS_LEAF 2
#endif

/* min / max of two floats that are never NaN (fmin / fmax also handle NaN: 3 instructions
 * instead of 1 on x86; the hot loops use these). */
OCLS_INLINE float min_nn(float a, float b) { return a < b ? a : b; }
OCLS_INLINE float max_nn(float a, float b) { return a > b ? a : b; }

/* The map and the ray, read by every helper. */
typedef struct {
    int H, W, Hp, Wp, cu, cv;
    float3 o, d;        /* ray in centred heightmap coordinates, t = depth */
    float iu, iv;       /* 1 / d.x, 1 / d.y (INFINITY where 0: such boundaries are never met) */
    float kx, ky;       /* paraboloid (OCLS_SPHERE) */
    float ts;           /* the segment's start (patch_hit's expansion point is never before it) */
#ifdef OCLS_STATS
    uint *steps;        /* this work-item's counters (OCLS_STATS_N), added to stats at the end */
#endif
} Ray;

/* Profiling (-D OCLS_STATS): counters of the stats argument (see the ABI above). */
#define OCLS_STATS_N 35
#define OCLS_ST_PATCH 32
#define OCLS_ST_RAYS 33
#define OCLS_ST_HITS 34
#ifdef OCLS_STATS
#define OCLS_COUNT(ray, k) ((ray)->steps[k] += 1u)
#else
#define OCLS_COUNT(ray, k) ((void)0)
#endif

/* Ray height above the base at t (z, plus the paraboloid on a sphere). */
OCLS_INLINE float ray_height(const Ray *ray, float t)
{
    float z = ray->o.z + t * ray->d.z;
#ifdef OCLS_SPHERE
    const float u = ray->o.x + t * ray->d.x, v = ray->o.y + t * ray->d.y;
    z = z + (ray->kx * u * u + ray->ky * v * v);
#endif
    return z;
}

/* Lowest ray height above the base over [ta, tb] (convex on a sphere: ends or vertex). */
OCLS_INLINE float ray_low(const Ray *ray, float ta, float tb)
{
    float lo = min_nn(ray_height(ray, ta), ray_height(ray, tb));
#ifdef OCLS_SPHERE
    const float3 o = ray->o, d = ray->d;
    const float qa = ray->kx * d.x * d.x + ray->ky * d.y * d.y;
    if (qa > 0.0f) {
        const float tv = -(d.z + 2.0f * (ray->kx * o.x * d.x + ray->ky * o.y * d.y)) / (2.0f * qa);
        if (tv > ta && tv < tb) lo = min_nn(lo, ray_height(ray, tv));
    }
#endif
    return lo;
}

/* Exact test of patch (r, c) over [ta, tb]: the first downward crossing, or INFINITY.
 * f(t0 + tau) = a + b tau + cq tau^2, expanded about t0, the ray's entry into the patch (the
 * later of its two near-boundary crossings, not before the segment's start ts), to keep float32
 * precision.  Expanding about the entry rather than about ta makes the hit the same bits
 * however the traversal reached the patch: a bisection leaf or a DDA descent may start the
 * walk part-way into a patch (after a part proven above the max), so with an expansion about
 * ta the hit depended on OCLS_DESCEND / OCLS_LEAF (tuning knobs) in the last bits.  The entry
 * is used even where rounding puts it after ta (then lo = ta - t0 < 0, f is still evaluated
 * at ta): taking ta there instead made 4 pixels of a 97 x 61 frame differ in the last bit
 * between leaf levels 0 and 2 (tests/test_knobs.py, camera framed by frame_heightmap).
 * *above: in, whether the ray was above the surface at the end of the previous piece of the
 * walk (patch exit, or a voxel rejected above its max); out, the same at this patch's exit (0
 * over a hole).  Above before and not above at the entry is a crossing on the shared edge:
 * this makes the walk watertight without tolerances (rounding may put the root of the same
 * edge crossing just outside both neighbours' intervals).
 * Two early outs skip the roots (shared by every method): the ray's lowest point above the
 * patch's 4 samples (their max bounds the bilinear surface), and f > 0 at both ends with no
 * dip between (f concave or linear, or its vertex not inside the interval). */
OCLS_INLINE float patch_hit(__global const float *h, const Ray *ray, int r, int c, float ta, float tb, int *above)
{
    const int i = r * ray->W + c, W = ray->W;
    OCLS_COUNT(ray, OCLS_ST_PATCH);
    const float h00 = h[i], h01 = h[i + 1], h10 = h[i + W], h11 = h[i + W + 1];
    if (isnan(h00) || isnan(h01) || isnan(h10) || isnan(h11)) { *above = 0; return INFINITY; }
    if (ray_low(ray, ta, tb) > max_nn(max_nn(h00, h01), max_nn(h10, h11))) { *above = 1; return INFINITY; }
    const float3 o = ray->o, d = ray->d;
    const float eu = d.x != 0.0f ? ((float)(c - ray->cu + (d.x < 0.0f)) - o.x) * ray->iu : -INFINITY;
    const float ev = d.y != 0.0f ? ((float)(r - ray->cv + (d.y < 0.0f)) - o.y) * ray->iv : -INFINITY;
    const float t0 = fmax(fmax(eu, ev), ray->ts);
    const float px = o.x + t0 * d.x, py = o.y + t0 * d.y, pz = o.z + t0 * d.z;
    const float s = px - (float)(c - ray->cu), w = py - (float)(r - ray->cv);
    const float e = (h00 - h01) - (h10 - h11);
    const float hu = (h01 - h00) + e * w, hv = (h10 - h00) + e * s;
    float a = pz - (h00 + (h01 - h00) * s + ((h10 - h00) + e * s) * w);
    float b = d.z - (hu * d.x + hv * d.y);
    float cq = -(e * d.x) * d.y;
#ifdef OCLS_SPHERE
    a = a + (ray->kx * px * px + ray->ky * py * py);
    b = b + 2.0f * (ray->kx * px * d.x + ray->ky * py * d.y);
    cq = cq + (ray->kx * d.x * d.x + ray->ky * d.y * d.y);
#endif
    const float lo = ta - t0, len = tb - t0;             /* the interval, relative to t0 */
    if (*above && a + (b + cq * lo) * lo <= 0.0f) return ta;
    const float fe = a + (b + cq * len) * len;          /* f at the patch exit */
    /* above at both ends and no dip in between (concave or linear f, or a convex one whose
     * vertex is outside the interval or not descending into it): no crossing; skips the roots */
    if (a > 0.0f && fe > 0.0f && !(cq > 0.0f && b < 0.0f && b + 2.0f * cq * len > 0.0f)) {
        *above = 1;
        return INFINITY;
    }
    float best = INFINITY;
    if (cq == 0.0f) {
        if (b < 0.0f) {
            const float r1 = -a / b;
            if (r1 >= lo && r1 <= len) best = r1;
        }
    } else {
        const float disc = b * b - 4.0f * a * cq;
        if (disc >= 0.0f) {
            const float sq = sqrt(disc);
            const float q = -0.5f * (b + (b >= 0.0f ? sq : -sq));
            const float r1 = q / cq;
            const float r2 = q != 0.0f ? a / q : INFINITY;
            if (r1 >= lo && r1 <= len && b + 2.0f * cq * r1 < 0.0f) best = r1;
            if (r2 >= lo && r2 <= len && b + 2.0f * cq * r2 < 0.0f) best = min_nn(best, r2);
        }
    }
    *above = fe > 0.0f;
    return best < INFINITY ? t0 + best : INFINITY;
}

/* Walk the patches crossed over [ta, tb] (Amanatides-Woo, at most max_steps), exact test in each.
 * A start cell behind the ray (rounding at a boundary) gives one empty interval, then the step. */
OCLS_INLINE float walk(__global const float *h, const Ray *ray, float ta, float tb, int max_steps, int *above,
                       int2 *cell)
{
    const float3 o = ray->o, d = ray->d;
    int c = clamp(ocls_floor_int(o.x + ta * d.x) + ray->cu, 0, ray->Wp - 1);
    int r = clamp(ocls_floor_int(o.y + ta * d.y) + ray->cv, 0, ray->Hp - 1);
    const int sc = d.x > 0.0f ? 1 : -1, sr = d.y > 0.0f ? 1 : -1;
    float t = ta;
    for (int k = 0; k < max_steps; ++k) {
        const float tu = d.x != 0.0f ? ((float)(c - ray->cu + (sc > 0)) - o.x) * ray->iu : INFINITY;
        const float tv = d.y != 0.0f ? ((float)(r - ray->cv + (sr > 0)) - o.y) * ray->iv : INFINITY;
        const float tx = min_nn(min_nn(tu, tv), tb);
        const float t1 = max_nn(tx, t);
        const float th = patch_hit(h, ray, r, c, t, t1, above);
        if (th < INFINITY) { *cell = (int2)(r, c); return th; }
        if (tx >= tb) break;
        if (tu <= tv) c += sc;
        if (tv <= tu) r += sr;
        if (c < 0 || c >= ray->Wp || r < 0 || r >= ray->Hp) break;
        t = t1;
    }
    return INFINITY;
}

#if OCLS_METHOD == 1
/* ocls_floor_int on two lanes (convert_int2_rtn compiles to scalar library floors on PoCL). */
OCLS_INLINE int2 floor_int2(float2 p)
{
    const int2 i = convert_int2(p);                     /* truncates toward zero */
    return i + (convert_float2(i) > p);                 /* true is -1 in vector comparisons */
}

/* 2^k as a float, exact for -126 <= k <= 127 (ldexp is a library call on some devices). */
OCLS_INLINE float pow2i(int k) { return as_float((127 + k) << 23); }

/* Paper 004: voxel subdivision of the segment [ts, te] front to back, LOD from the voxel's
 * footprint, reject a voxel wholly above the max at that LOD, split it otherwise; leaves are
 * walked patch by patch.  See "Methods" above for the split and the voxel lengths.  Bounded:
 * every iteration rejects or walks a voxel (ta moves to tb > ta) or splits one; a split sets
 * the length to 2^m cell lengths, m = max(l - OCLS_DESCEND, lmin), shorter than the voxel split
 * (its footprint n > 2^(l-1) patches spans more than 2^(l-1) - 1 cells, 2^m <= 2^(l-1)), and a
 * voxel of the leaf length is a leaf whatever its rounded footprint says, so at most `top`
 * splits come between two advances. */
OCLS_INLINE float cast(__global const float *h, __global const float2 *ext, __global const int *ext_off,
                       __global const float *dil, __global const int2 *dil_lev,
                       int levels, const Ray *ray, float ts, float te, int2 *cell)
{
    const int top = levels - 1, lmin = min(OCLS_LEAF, top);
    const float3 o = ray->o, d = ray->d;
    const float4 o4 = (float4)(o, 0.0f), d4 = (float4)(d, 0.0f);
    /* t-length of one cell along the major axis, shrunk so that a voxel of 2^l such lengths
     * spans at most 2^l patches after rounding (INFINITY for a vertical ray: one voxel) */
    const float cell_t = 0.999f / fmax(fabs(d.x), fabs(d.y));
    const float leaf_t = cell_t * pow2i(lmin);
    const int2 lo = (int2)(0, 0), hi = (int2)(ray->Wp - 1, ray->Hp - 1), ctr = (int2)(ray->cu, ray->cv);
    float ta = ts, len = te - ts;
    float4 pa = o4 + ta * d4;
    int2 ia = floor_int2(pa.xy) + ctr;
    int above = 0;                                      /* the segment may start under the surface */
    for (int it = 0; it < OCLS_MAX_IT; ++it) {
        float tb = min_nn(ta + len, te);
        if (!(tb > ta)) tb = te;                        /* len below the rounding of ta: finish */
        const float4 pb = o4 + tb * d4;
        const int2 ib = floor_int2(pb.xy) + ctr;
        /* its projection on the map: patch columns c0..c1 (x), rows r0..r1 (y) */
        const int2 q0 = clamp(min(ia, ib), lo, hi), nq = clamp(max(ia, ib), lo, hi) - q0;
        /* LOD from the footprint: the smallest l with 2^l >= n = max(c1 - c0, r1 - r0), so the
         * projection meets at most 2 x 2 tiles of level l, all under one texel of the dilated
         * max level l (tiles (R..R+1, C..C+1), R = r0 >> l, C = c0 >> l): one read per test */
        const int n = max(nq.x, nq.y);
        const int l = clamp(n <= 1 ? 0 : 32 - (int)clz(n - 1), lmin, top);
        OCLS_COUNT(ray, l);
        const int2 lev = dil_lev[l];                                /* (offset, columns) */
        const float hmax = dil[lev.x + (q0.y >> l) * lev.y + (q0.x >> l)];
#ifdef OCLS_SPHERE
        const float low = ray_low(ray, ta, tb);
#else
        const float low = min_nn(pa.z, pb.z);
#endif
        if (low > hmax) {
            above = 1;                                  /* wholly above the max: discard */
        } else {
            /* discard the near part above hmax (a plane: the ray meets hmax at fraction g of the
             * voxel, 1e-5 short of it against rounding) */
            float tw = ta;
#ifndef OCLS_SPHERE
            if (pa.z > hmax) {
                tw = ta + (pa.z - hmax) / (pa.z - pb.z) * 0.99999f * (tb - ta);
                above = 1;                              /* the discarded part is above the surface */
            }
#endif
            if (l > lmin && len > leaf_t) {
                /* split: the next voxel starts there, with the length of level l - j */
                ta = tw;
                pa = o4 + ta * d4;
                ia = floor_int2(pa.xy) + ctr;
                len = cell_t * pow2i(max(l - OCLS_DESCEND, lmin));
                continue;
            }
            /* leaf: at most 2^(l+1) + 1 patches along the ray (one more if rounding puts the
             * first cell behind the ray), each tested exactly */
            const float th = walk(h, ray, tw, tb, (2 << l) + 2, &above, cell);
            if (th < INFINITY) return th;
        }
        if (tb >= te) break;                            /* past the segment's end */
        ta = tb; pa = pb; ia = ib;                      /* the next voxel, as long as this one's level */
        len = cell_t * pow2i(l);
    }
    return INFINITY;
}
#elif OCLS_METHOD == 2
/* Baseline: uniform ray march, exact walk over the step where the ray goes below. */
OCLS_INLINE float above(__global const float *h, const Ray *ray, float t)
{
    const float u = ray->o.x + t * ray->d.x, v = ray->o.y + t * ray->d.y;
    const int c = clamp(ocls_floor_int(u) + ray->cu, 0, ray->Wp - 1);
    const int r = clamp(ocls_floor_int(v) + ray->cv, 0, ray->Hp - 1);
    const int i = r * ray->W + c, W = ray->W;
    const float s = clamp(u - (float)(c - ray->cu), 0.0f, 1.0f), w = clamp(v - (float)(r - ray->cv), 0.0f, 1.0f);
    const float top = h[i] + (h[i + 1] - h[i]) * s, bottom = h[i + W] + (h[i + W + 1] - h[i + W]) * s;
    const float surf = top + (bottom - top) * w;
    return isnan(surf) ? 1.0f : ray_height(ray, t) - surf;   /* holes count as above */
}

OCLS_INLINE float cast(__global const float *h, __global const float2 *ext, __global const int *ext_off,
                       __global const float *dil, __global const int2 *dil_lev,
                       int levels, const Ray *ray, float ts, float te, int2 *cell)
{
    const float3 d = ray->d;
    const float span = te - ts;
    const float reach = fmax(fabs(d.x), fabs(d.y)) * span;          /* cells along the segment */
    const int n = clamp((int)ceil(reach / OCLS_MARCH_STEP), 1, OCLS_MAX_IT);
    const int steps = (int)(2.0f * OCLS_MARCH_STEP) + 4;
    float tp = ts;
    int was_above = above(h, ray, ts) > 0.0f;
    for (int k = 1; k <= n; ++k) {
        const float t = k == n ? te : ts + span * ((float)k / (float)n);
        OCLS_COUNT(ray, 0);
        const int is_above = above(h, ray, t) > 0.0f;
        if (was_above && !is_above) {
            int above = 1;
            const float th = walk(h, ray, tp, t, steps, &above, cell);
            if (th < INFINITY) return th;
        }
        was_above = is_above;
        tp = t;
    }
    return INFINITY;
}
#else
/* Baseline: max-mipmap DDA (Tevs, Ihrke, Seidel 2008). */
OCLS_INLINE float cast(__global const float *h, __global const float2 *ext, __global const int *ext_off,
                       __global const float *dil, __global const int2 *dil_lev,
                       int levels, const Ray *ray, float ts, float te, int2 *cell)
{
    const float3 o = ray->o, d = ray->d;
    const int sc = d.x > 0.0f ? 1 : -1, sr = d.y > 0.0f ? 1 : -1;
    const int top = levels - 1;
    int l = top, above = 0;
    float t = ts;
    int c = clamp(ocls_floor_int(o.x + t * d.x) + ray->cu, 0, ray->Wp - 1) >> l;
    int r = clamp(ocls_floor_int(o.y + t * d.y) + ray->cv, 0, ray->Hp - 1) >> l;
    for (int it = 0; it < OCLS_MAX_IT; ++it) {
        const float tu = d.x != 0.0f ? ((float)(((c + (sc > 0)) << l) - ray->cu) - o.x) * ray->iu : INFINITY;
        const float tv = d.y != 0.0f ? ((float)(((r + (sr > 0)) << l) - ray->cv) - o.y) * ray->iv : INFINITY;
        const float tx = fmin(fmin(tu, tv), te);
        const float t1 = fmax(tx, t);
        OCLS_COUNT(ray, l);
        if (l == 0) {
            const float th = patch_hit(h, ray, r, c, t, t1, &above);
            if (th < INFINITY) { *cell = (int2)(r, c); return th; }
        } else {
            const float hmax = ext[ext_off[l] + r * ocls_level_extent(ray->Wp, l) + c].x;
            if (ray_low(ray, t, t1) <= hmax) {          /* descend into the child under the ray */
                --l;
                const int pc = clamp(ocls_floor_int(o.x + t * d.x) + ray->cu, 0, ray->Wp - 1);
                const int pr = clamp(ocls_floor_int(o.y + t * d.y) + ray->cv, 0, ray->Hp - 1);
                c = min(clamp(pc >> l, 2 * c, 2 * c + 1), ocls_level_extent(ray->Wp, l) - 1);
                r = min(clamp(pr >> l, 2 * r, 2 * r + 1), ocls_level_extent(ray->Hp, l) - 1);
                continue;
            }
            above = 1;                                  /* skipped: wholly above the max */
        }
        if (tx >= te) break;
        t = t1;
        const int oc = c, orow = r;
        if (tu <= tv) c += sc;
        if (tv <= tu) r += sr;
        if (c < 0 || r < 0 || c >= ocls_level_extent(ray->Wp, l) || r >= ocls_level_extent(ray->Hp, l)) break;
        if (l < top && ((c >> 1) != (oc >> 1) || (r >> 1) != (orow >> 1))) { ++l; c >>= 1; r >>= 1; }
    }
    return INFINITY;
}
#endif

/* [t0, t1] clipped to lo <= o + t d <= hi along one axis. */
OCLS_INLINE void clip_axis(float o, float d, float lo, float hi, float *t0, float *t1)
{
    if (d == 0.0f) {
        if (o < lo || o > hi) *t0 = INFINITY;
        return;
    }
    const float ta = (lo - o) / d, tb = (hi - o) / d;
    *t0 = fmax(*t0, fmin(ta, tb));
    *t1 = fmin(*t1, fmax(ta, tb));
}

#ifdef OCLS_COLOUR
/* Bilinear sample of colour level m at level-0 texel coordinates (x0, y0), edges clamped. */
OCLS_INLINE float4 texel_bilinear(__global const float4 *tex, int4 lv, float x0, float y0, int m)
{
    const float scale = ldexp(1.0f, -m);
    const float x = (x0 + 0.5f) * scale - 0.5f, y = (y0 + 0.5f) * scale - 0.5f;
    const int xi = ocls_floor_int(x), yi = ocls_floor_int(y);
    const float fx = x - (float)xi, fy = y - (float)yi;
    const int xa = clamp(xi, 0, lv.y - 1), xb = clamp(xi + 1, 0, lv.y - 1);
    const int ya = clamp(yi, 0, lv.z - 1), yb = clamp(yi + 1, 0, lv.z - 1);
    __global const float4 *t = tex + lv.x;
    const float4 top = t[ya * lv.y + xa] + (t[ya * lv.y + xb] - t[ya * lv.y + xa]) * fx;
    const float4 bot = t[yb * lv.y + xa] + (t[yb * lv.y + xb] - t[yb * lv.y + xa]) * fx;
    return top + (bot - top) * fy;
}

/* Trilinear (mip-mapped) colour at heightmap coordinates (u, v), LOD from the uv derivatives. */
OCLS_INLINE float4 colour_at(__global const float4 *tex, __global const int4 *levels, int ntex,
                             int H, int W, float u, float v, float4 grad)
{
    const int4 l0 = levels[0];
    const float ax = (float)l0.y / (float)W, ay = (float)l0.z / (float)H;
    const float x0 = (u + 0.5f) * ax - 0.5f, y0 = (v + 0.5f) * ay - 0.5f;
    const float fc = fmax(fabs(grad.x * ax), fabs(grad.y * ay));
    const float fr = fmax(fabs(grad.z * ax), fabs(grad.w * ay));
    const float lod = clamp(log2(fmax(fmax(fc, fr), 1e-30f)), 0.0f, (float)(ntex - 1));
    const int m = min((int)lod, ntex - 1), m1 = min(m + 1, ntex - 1);
    const float4 a = texel_bilinear(tex, levels[m], x0, y0, m);
    const float4 b = texel_bilinear(tex, levels[m1], x0, y0, m1);
    return a + (b - a) * (lod - (float)m);
}
#else
/* Hypsometric tint (linear RGB) of a height normalised to [0, 1] over the map's range. */
OCLS_INLINE float4 hypsometric(float x)
{
    const float3 stops[5] = {(float3)(0.02f, 0.18f, 0.05f), (float3)(0.22f, 0.35f, 0.08f),
                             (float3)(0.40f, 0.28f, 0.13f), (float3)(0.38f, 0.36f, 0.34f),
                             (float3)(0.90f, 0.90f, 0.92f)};
    const float p = clamp(x, 0.0f, 1.0f) * 4.0f;
    const int k = min((int)p, 3);
    const float3 c = stops[k] + (stops[k + 1] - stops[k]) * (p - (float)k);
    return (float4)(c, 1.0f);
}
#endif

__kernel void terrain_cast(__global const float *h, const int H, const int W,
                           __global const float2 *ext, __global const int *ext_off, const int levels,
                           __global const float *dil, __global const int2 *dil_lev,
                           const float4 g0, const float4 g1, const float4 g2,
                           const float4 r0, const float4 r1, const float4 r2,
                           const float4 cam, const int IW, const int IH, const int cu, const int cv,
                           const float4 geo, const float4 hrange,
                           __global const float4 *tex, __global const int4 *tex_levels, const int ntex,
                           __global float4 *position, __global float4 *normal, __global float2 *uv,
                           __global float4 *uv_grad, __global float *depth, __global float4 *albedo
#ifdef OCLS_STATS
                           , __global uint *stats
#endif
                           )
{
    const int px = get_global_id(0), py = get_global_id(1);
    if (px >= IW || py >= IH) return;
    const int idx = py * IW + px;
    const float nx = (float)(2 * px + 1) / (float)IW - 1.0f;
    const float ny = 1.0f - (float)(2 * py + 1) / (float)IH;
#ifdef OCLS_ORTHO
    const float3 ov = (float3)(nx * cam.x, ny * cam.y, 0.0f), dv = (float3)(0.0f, 0.0f, -1.0f);
#else
    const float3 ov = (float3)(0.0f, 0.0f, 0.0f), dv = (float3)(nx * cam.x, ny * cam.y, -1.0f);
#endif
    Ray ray;
    ray.H = H; ray.W = W; ray.Hp = H - 1; ray.Wp = W - 1; ray.cu = cu; ray.cv = cv;
    ray.kx = geo.z; ray.ky = geo.w;
    ray.o = (float3)(dot(g0.xyz, ov) + g0.w, dot(g1.xyz, ov) + g1.w, dot(g2.xyz, ov) + g2.w);
    ray.d = (float3)(dot(g0.xyz, dv), dot(g1.xyz, dv), dot(g2.xyz, dv));
    ray.iu = 1.0f / ray.d.x;
    ray.iv = 1.0f / ray.d.y;
    /* the visible segment, clipped to the map's box (and the height slab on a plane) */
    float ts = cam.z, te = cam.w;
    clip_axis(ray.o.x, ray.d.x, (float)(-cu), (float)(W - 1 - cu), &ts, &te);
    clip_axis(ray.o.y, ray.d.y, (float)(-cv), (float)(H - 1 - cv), &ts, &te);
#ifndef OCLS_SPHERE
    if (ts <= te) {   /* a margin far above the rounding of o.z + t d.z: the clip only prunes */
        const float mh = 1e-3f * (hrange.y - hrange.x) + 1e-5f * (fabs(hrange.x) + fabs(hrange.y)
                         + fabs(ray.o.z) + fabs(ts * ray.d.z) + fabs(te * ray.d.z)) + 1e-30f;
        clip_axis(ray.o.z, ray.d.z, hrange.x - mh, hrange.y + mh, &ts, &te);
    }
#endif
#ifdef OCLS_STATS
    uint steps[OCLS_STATS_N];
    for (int k = 0; k < OCLS_STATS_N; ++k) steps[k] = 0u;
    ray.steps = steps;
#endif
    int2 cell = (int2)(0, 0);
    float th = INFINITY;
    ray.ts = ts;
    if (H >= 2 && W >= 2 && ts <= te) {
        OCLS_COUNT(&ray, OCLS_ST_RAYS);
        th = cast(h, ext, ext_off, dil, dil_lev, levels, &ray, ts, te, &cell);
    }
#ifdef OCLS_STATS
    if (th < INFINITY) OCLS_COUNT(&ray, OCLS_ST_HITS);
    for (int k = 0; k < OCLS_STATS_N; ++k)
        if (steps[k]) atomic_add(&stats[k], steps[k]);
#endif
    if (!(th < INFINITY)) {
        position[idx] = (float4)(0.0f); normal[idx] = (float4)(0.0f); uv[idx] = (float2)(0.0f);
        uv_grad[idx] = (float4)(0.0f); depth[idx] = INFINITY; albedo[idx] = (float4)(0.0f);
        return;
    }
    const float3 o = ray.o, d = ray.d;
    const int r = cell.x, c = cell.y;
    const float3 p = (float3)(o.x + th * d.x, o.y + th * d.y, o.z + th * d.z);
    const float s = clamp(p.x - (float)(c - cu), 0.0f, 1.0f), w = clamp(p.y - (float)(r - cv), 0.0f, 1.0f);
    const int i = r * W + c;
    const float h00 = h[i], h01 = h[i + 1], h10 = h[i + W], h11 = h[i + W + 1];
    const float e = (h00 - h01) - (h10 - h11);
    float hu = (h01 - h00) + e * w, hv = (h10 - h00) + e * s;
#ifdef OCLS_SPHERE
    hu = hu - 2.0f * ray.kx * p.x;
    hv = hv - 2.0f * ray.ky * p.y;
#endif
    /* view-space position and normal (world normal of the graph, rotated) */
    position[idx] = (float4)(ov.x + th * dv.x, ov.y + th * dv.y, ov.z + th * dv.z, 1.0f);
    const float3 nw = (float3)(-hu / geo.x, hv / geo.y, 1.0f);
    const float3 nv = normalize((float3)(dot(r0.xyz, nw), dot(r1.xyz, nw), dot(r2.xyz, nw)));
    normal[idx] = (float4)(nv, 0.0f);
    const float2 uvh = (float2)((float)c + s, (float)r + w);
    uv[idx] = uvh;
    depth[idx] = th;
    /* ray differentials against the tangent plane (gradient gr of z - surface) */
    const float3 gr = (float3)(-hu, -hv, 1.0f);
    float gd = dot(gr, d);
    const float tiny = 1e-6f * length(gr) * length(d);
    if (fabs(gd) < tiny) gd = gd < 0.0f ? -tiny : tiny;
    const float ddc = 2.0f * cam.x / (float)IW, ddr = -2.0f * cam.y / (float)IH;
    const float3 vc = (float3)(g0.x, g1.x, g2.x) * ddc, vr = (float3)(g0.y, g1.y, g2.y) * ddr;
#ifdef OCLS_ORTHO
    const float3 pc = vc - d * (dot(gr, vc) / gd), pr = vr - d * (dot(gr, vr) / gd);
#else
    const float3 pc = (vc - d * (dot(gr, vc) / gd)) * th, pr = (vr - d * (dot(gr, vr) / gd)) * th;
#endif
    const float4 grad = (float4)(pc.x, pc.y, pr.x, pr.y);
    uv_grad[idx] = grad;
#ifdef OCLS_COLOUR
    albedo[idx] = colour_at(tex, tex_levels, ntex, H, W, uvh.x, uvh.y, grad);
#else
    const float hs = h00 + (h01 - h00) * s + ((h10 - h00) + e * s) * w;
    albedo[idx] = hypsometric((hs - hrange.x) / fmax(hrange.y - hrange.x, 1e-30f));
#endif
}

/* Dilated max level l (built once per map, read by bisect): texel (R, C) = max of the extrema
 * level-l tiles (R..R+1, C..C+1), clamped to the level; level 0 = max of the valid samples
 * (R..R+2, C..C+2), i.e. of patches (R..R+1, C..C+1) (-INF where none).  Launched once per
 * level l = 0..levels-1 with global size (>= Cl, >= Rl), Rl x Cl = ceil(Hp / 2^l) x ceil(Wp / 2^l),
 * writing out[off + R * Cl + C]. */
__kernel void terrain_dilate(__global const float *h, const int H, const int W,
                             __global const float2 *ext, __global const int *ext_off, const int l,
                             const int Rl, const int Cl, __global float *out, const int off)
{
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= Cl || r >= Rl) return;
    float m = -INFINITY;
    if (l == 0) {
        for (int i = r; i <= min(r + 2, H - 1); ++i)
            for (int j = c; j <= min(c + 2, W - 1); ++j) {
                const float v = h[i * W + j];
                if (!isnan(v)) m = fmax(m, v);
            }
    } else {
        __global const float2 *lev = ext + ext_off[l];
        for (int i = r; i <= min(r + 1, Rl - 1); ++i)
            for (int j = c; j <= min(c + 1, Cl - 1); ++j) m = fmax(m, lev[i * Cl + j].x);
    }
    out[off + r * Cl + c] = m;
}

/* Slope (dh/du, dh/dv) at sample (r, c) by central differences, one-sided next to holes and
 * at the map's edges, 0 along an axis with neither neighbour (see "Shading normals"). */
OCLS_INLINE float2 sample_slope(__global const float *h, int H, int W, int r, int c)
{
    const float hc = h[r * W + c];
    const float hl = ocls_sample(h, H, W, r, c - 1), hr = ocls_sample(h, H, W, r, c + 1);
    const float ha = ocls_sample(h, H, W, r - 1, c), hb = ocls_sample(h, H, W, r + 1, c);
    const float gu = !isnan(hl) && !isnan(hr) ? 0.5f * (hr - hl) : !isnan(hr) ? hr - hc : !isnan(hl) ? hc - hl : 0.0f;
    const float gv = !isnan(ha) && !isnan(hb) ? 0.5f * (hb - ha) : !isnan(hb) ? hb - hc : !isnan(ha) ? hc - ha : 0.0f;
    return (float2)(gu, gv);
}

__kernel void terrain_normals(__global const float *h, const int H, const int W,
                              __global const float2 *uv, __global const float4 *position,
                              const float4 r0, const float4 r1, const float4 r2, const float4 geo,
                              const int cu, const int cv, const int n, __global float4 *normal)
{
    const int i = get_global_id(0);
    if (i >= n) return;
    if (!(position[i].w > 0.5f) || H < 2 || W < 2) { normal[i] = (float4)(0.0f); return; }
    const float2 p = uv[i];
    const int c = clamp(ocls_floor_int(p.x), 0, W - 2), r = clamp(ocls_floor_int(p.y), 0, H - 2);
    const float s = clamp(p.x - (float)c, 0.0f, 1.0f), w = clamp(p.y - (float)r, 0.0f, 1.0f);
    const float wt[4] = {(1.0f - s) * (1.0f - w), s * (1.0f - w), (1.0f - s) * w, s * w};
    float2 g = (float2)(0.0f);
    float sum = 0.0f;
    for (int k = 0; k < 4; ++k) {
        const int rk = r + (k >> 1), ck = c + (k & 1);
        if (wt[k] > 0.0f && !isnan(h[rk * W + ck])) {
            g = g + wt[k] * sample_slope(h, H, W, rk, ck);
            sum = sum + wt[k];
        }
    }
    if (sum > 0.0f) g = g / sum;                        /* 0: no valid sample (not from terrain_cast) */
#ifdef OCLS_SPHERE
    g = g - 2.0f * (float2)(geo.z * (p.x - (float)cu), geo.w * (p.y - (float)cv));
#endif
    const float3 nw = (float3)(-g.x / geo.x, g.y / geo.y, 1.0f);
    normal[i] = (float4)(normalize((float3)(dot(r0.xyz, nw), dot(r1.xyz, nw), dot(r2.xyz, nw))), 0.0f);
}
