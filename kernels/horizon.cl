/* horizon.cl — horizon angles of a heightmap: per cell and azimuth, the
 * elevation angle of the highest terrain seen from the cell's surface point
 * over the bilinear surface, by a multilevel traversal of the extrema
 * pyramid that maximises instead of thresholding (issue 19: paper 000's
 * Algo 2 / 3 with a moving threshold).  Host: oclshade/horizon; float64
 * twin: oclshade.reference.horizon_tangents; definitions, exactness and
 * error: docs/methods.md "Horizons and sky-view factor".
 *
 * ABI summary (details under "ABI" below):
 *   horizon_seeds  one work-item per seed cell (every 8th row and column, see
 *                  "Seeds"), global size (Ws, Hs) rounded up to any local
 *                  size; the exact walk there into seeds (float2, Hs*Ws).
 *                  Enqueued before horizon_cells for each azimuth, except with
 *                  -D OCLS_MAX_DISTANCE or OCLS_CLAMP.
 *   horizon_sweep  within a short search radius, instead of both (see "The
 *                  sweep" at the end): -D OCLS_SWEEP=lanes, OCLS_LANES cells of
 *                  a row per work-item, arguments (h, H, W, ray, angle, svf)
 *                  (-D OCLS_SUN_TABLE: then band and the blocks' rays).
 *   horizon_cells  one work-item per cell, global size (W, H) rounded up to
 *                  any local size (the tuning knob `group`); arguments: the
 *                  H*W float32 relative heights (row-major, NaN = nodata), H,
 *                  W, the extrema pyramid (float2 levels 1..nlev-1 back to
 *                  back, int level offsets, nlev), the float4 ray (ux, uy, c,
 *                  R) of one azimuth, then the outputs angle (float, H*W,
 *                  degrees) and svf (float2 (sum, compensation), H*W), then
 *                  the seeds and the float2 cell size (dx, dy) in metres.
 *   -D options OCLS_OUT_ANGLE, OCLS_OUT_SVF=1|2 (cosine | solid-angle sky-view
 *   term), OCLS_CURVATURE (read c), OCLS_MAX_DISTANCE (read R: a search
 *   radius), OCLS_CLAMP (a trailing float2 argument: only T within [lo, hi]
 *   is wanted), OCLS_LEVEL_SCAN (how the walk finds its level: "Levels"),
 *   OCLS_SWEEP (lanes: the sweep's build), OCLS_SUN_TABLE (the rays, for the
 *   walk also bounds and cell sizes, of blocks from a table), OCLS_OWN_BUILTINS
 *   (common.h); no others.
 *
 * Geometry (as shadow.cl).  Sample (i, j) sits at x = j (east), y = i
 * (south) in cell units; the surface is bilinear over patches (pyramid.cl).
 * The ray of cell (i, j) at one azimuth starts at the surface point
 * (j, i, h[i,j]) and follows x(t) = j + ux t, y(t) = i + uy t, t >= 0 the
 * horizontal distance in metres, ux = sin(az)/dx, uy = -cos(az)/dy: shadow.cl's
 * sun ray with w = 0, so the patches, corner passes, grid-line profiles and
 * holes it meets are shadow.cl's (positions are measured from the cell,
 * (j - pc) + ux t, which keeps the float32 error of a position proportional
 * to the distance rather than to the column).  The horizon tangent is
 *     T = sup_{t > 0} (S(t) - z0 - c t^2) / t
 * over the valid surface inside the map, c = (1 - k) / (2 R) with
 * -D OCLS_CURVATURE (Earth radius R, refraction coefficient k), else 0.
 * With -D OCLS_MAX_DISTANCE the sup is over 0 < t <= R, the search radius in
 * metres (r.horizon's maxdistance, RVT's radius): the segment in the last
 * patch ends at min(t_out, R), a tile's bound uses that end, a corner pass
 * beyond R is not seen, and the walk stops at t >= R.
 * Without curvature shadow.cl's cell is in cast shadow at (az, e) iff
 * T > tan(e).
 *
 * Steps (paper 000 Algo 3, the threshold being the best tangent so far):
 *   level l > 0  the tile's max M can raise T only if, somewhere on the
 *                ray's segment [t, t_out] in it, M - z0 - c s^2 > T s; the
 *                threshold T s + c s^2 is at least T t_lo + c t^2 there
 *                (t_lo = t when T >= 0, else t_out), so the tile is skipped
 *                when M - z0 <= T t_lo + c t^2 (exact pruning); t is where
 *                the walk is, inside the tile or at its edge: the test holds
 *                for the rest of the ray in it (see "Levels");
 *   level 0      the patch's sup in closed form: along the ray the surface
 *                less the curvature drop is a quadratic f(t), and f(t) / t
 *                has its maximum at an end of the segment or at the one
 *                interior critical point t* = sqrt(A / C) (f = A + B t +
 *                C t^2, a maximum iff A, C < 0: the tangent from the eye to
 *                the surface), where f / t is evaluated (an error in t*
 *                changes the value only to second order);
 *   levels       at each step the walk skips the largest tile around its
 *                patch that passes the test, else evaluates the patch
 *                ("Levels" below);
 *   exit         when (z_top - z0) - c t^2 <= T t (nothing further can be
 *                higher: both terms of (z_top - z0) / s - c s decrease) or
 *                the ray leaves the map.
 * A ray that sees no surface has T = -inf: angle -90 degrees.
 *
 * Seeds (over the whole map: not with -D OCLS_MAX_DISTANCE, where a radius
 * keeps walks short and the seeds cost more than they save, nor OCLS_CLAMP,
 * whose caller gives the lower bound).  Most of a walk's cost is the proof
 * that nothing further is higher, and the pruning of that proof is as strong
 * as the threshold T it has so far.  So the walk starts from a lower bound:
 *   step 1       horizon_seeds walks exactly from the cells (S gi, S gj),
 *                S = OCLS_SEED_STRIDE = 8 (the last row and column clamped),
 *                and keeps T and a ray parameter t where T is reached (its
 *                horizon point);
 *   step 2       a cell takes the four seed cells around it; for each, the
 *                point of its own ray nearest that horizon point, and the
 *                surface there (bilinear), gives a tangent that is a lower
 *                bound of its own T (a point of the surface it sees); the
 *                bound less a margin for its float32 rounding (1e-5 relative
 *                plus 1e-6 of the heights over t);
 *   step 3       the walk starts from the largest bound: tiles that cannot
 *                beat it are pruned from the start.  The patch where T is
 *                reached still beats the bound, so the walk ends on the
 *                same patch values; if nothing beats it (the margin was too
 *                thin), the cell walks again from -inf.
 * T is exact either way; the order in which the walk meets patch boundaries
 * can change with the start (a tile skipped whole enters the next at the
 * tile's exit, not at a patch corner within it), so a few cells in a
 * million differ from the unseeded walk in their last float32 bits, all
 * within the float32 band of the float64 reference.  S is therefore part of
 * the algorithm (the hosts mirror it), not a tuning knob.  Measured:
 * docs/solar.md, "Seeded walks".
 *
 * Levels.  Paper 000's traversal (and shadow.cl's) descends one level per
 * step while a tile fails the test and climbs one level when the ray has just
 * entered the tile above too.  Here each step takes the largest tile around
 * the current patch that passes the test from the current t (prunable()),
 * whether or not the ray has just entered it: with the best tangent raised, a
 * tile the walk descended into can pass from where the walk now is.  Without
 * a search radius the test is monotone in the level (a larger tile has the
 * larger max and, for T < 0, the later exit and so the lower bar; float32
 * rounding is monotone too), so that tile is one tile, found two ways (the
 * tuning knob `scan`, -D OCLS_LEVEL_SCAN; the same bits either way): 0 moves
 * up or down from the last step's level, one read after the other (few reads:
 * CPUs); 1 reads every level's tile at once and keeps the largest that passes
 * (more reads but no chain of them, each waiting for the last: meant for GPUs,
 * where such a chain cost more than the reads).  With a search radius the
 * outputs are the sweep's whatever tiles are skipped ("The sweep").  Against
 * the walk before (one level a step; docs/solar.md, "Levels"): 39-59 % fewer
 * steps on the record's maps, a few angles in 10^4 different in their last
 * float32 bits, all within the float32 band of the float64 reference.
 *
 * Batches (the seeded walk alone).  One azimuth's launches leave a device
 * wide enough for hundreds of thousands of work-items mostly idle: the seed
 * grid's 1/64 of the cells walk alone (their walks, unseeded, are the longest),
 * and each launch ends on its slowest walks.  horizon_seeds_batch and
 * horizon_cells_batch take several azimuths per launch; each work-item
 * computes what horizon_seeds / horizon_cells compute for its azimuth (the
 * same functions), so the outputs are the same bits for any number per launch
 * (the tuning knob `batch`).  The angles: one work-item per cell and azimuth,
 * the azimuth the third global dimension.  The sky-view sums, which a cell
 * must add in azimuth order: one work-item per cell, walking the launch's
 * azimuths in order (no launch per azimuth either).
 *
 * Outputs (each compiled in by its -D option; an output not compiled in is
 * not written and its argument may be a 1-byte dummy buffer):
 *   OCLS_OUT_ANGLE  angle[idx] = atan(T) in degrees (float; ocls_atan_deg, the
 *                   same bits on every device), -90 when
 *                   nothing is seen, NaN = nodata
 *   OCLS_OUT_SVF=1  svf[idx] += sin^2(max(atan T, 0)) = T^2 / (1 + T^2)
 *                   (T > 0, else 0): the cosine-weighted sky-view factor's
 *                   term (1 - the mean of the terms over the azimuths)
 *   OCLS_OUT_SVF=2  svf[idx] += sin(max(atan T, 0)) = T / sqrt(1 + T^2):
 *                   the solid-angle (Zaksek / RVT) definition's term
 *   svf is float2 (sum, compensation) of a Kahan summation, so the sum's
 *   rounding does not grow with the number of azimuths; nodata cells are
 *   left untouched.
 *
 * ABI
 *   __kernel horizon_cells(h, H, W, ext, lvl_off, nlev, ray, angle, svf)
 *     __global const float *h        H*W heights relative to the host's offset,
 *                                    NaN = nodata (as shadow_cells)
 *     int H, W
 *     __global const float2 *ext     extrema pyramid levels 1..nlev-1 (pyramid.cl)
 *     __global const int *lvl_off    level offsets (as shadow_cells)
 *     int nlev                       levels counting level 0 (>= 2)
 *     float4 ray                     (ux, uy, c, R): ux, uy rounded to float32 as
 *                                    shadow.cl's ray (oclshade Sun(az, 0).ray);
 *                                    c the curvature per metre^2, read only with
 *                                    -D OCLS_CURVATURE; R > 0 the search radius in
 *                                    metres, read only with -D OCLS_MAX_DISTANCE
 *     __global float *angle          H*W (OCLS_OUT_ANGLE)
 *     __global float2 *svf           H*W (OCLS_OUT_SVF), zeroed by the host before
 *                                    the first azimuth
 *     __global const float2 *seeds   Hs*Ws (T, t) of the seed cells, Hs = (H - 1) / 8 + 2,
 *                                    Ws = (W - 1) / 8 + 2, written by horizon_seeds for
 *                                    this azimuth; not read with -D OCLS_MAX_DISTANCE or
 *                                    OCLS_CLAMP (then any buffer)
 *     float2 cell                    (dx, dy) cell size in metres (for the seeds)
 *     float2 bounds                  (lo, hi) tangents, only with -D OCLS_CLAMP: the
 *                                    traversal starts at T = lo (terrain below it is
 *                                    pruned as if already beaten) and stops once
 *                                    T >= hi, so T is exact where it lies in
 *                                    [lo, hi], lo where it is below (also where
 *                                    nothing is seen) and some value >= hi above:
 *                                    for a caller that clamps T to [lo, hi] anyway
 *                                    (soft shadows: each strip of the sun's disc,
 *                                    oclshade/horizon/disc.py), at about the cost
 *                                    of a cast-shadow ray
 *     -D OCLS_SUN_TABLE: each cell's ray, bounds and cell sizes from a table of
 *     blocks instead (the ray, cell and bounds arguments stay, unread; bounds is
 *     then passed without OCLS_CLAMP too), for a sun that varies over the map (the
 *     strip of each block's own disc in one launch, with OCLS_CLAMP) or a map
 *     traced in blocks of their own scale (each block's ray and cell sizes: a
 *     projected grid's blocks in one launch), after bounds:
 *       __global const int *band        H + W ints: cell (i, j) is in block
 *                                       b = band[i] + band[H + j] (shadow.cl's
 *                                       "sun tables")
 *       __global const float4 *strips   2 per block: its ray, then (lo, hi, dx, dy)
 *                                       (lo, hi read with OCLS_CLAMP only, the cell
 *                                       sizes by the seeds' bound only)
 *   global size (W, H) rounded up to any local size.
 *   __kernel horizon_seeds(h, H, W, ext, lvl_off, nlev, ray, seeds)
 *     arguments as horizon_cells; writes seeds[gi * Ws + gj] = (T, t) of cell
 *     (min(8 gi, H - 1), min(8 gj, W - 1)) (T = -inf at nodata or where nothing
 *     is seen); global size (Ws, Hs) rounded up to any local size.
 *
 *   __kernel horizon_seeds_batch(h, H, W, ext, lvl_off, nlev, rays, seeds, first)
 *   __kernel horizon_cells_batch(h, H, W, ext, lvl_off, nlev, rays, angle, svf, seeds, cell, stride,
 *                                first, count)
 *     (seeded builds only: neither OCLS_MAX_DISTANCE nor OCLS_CLAMP) as horizon_seeds /
 *     horizon_cells for the count azimuths first .. first + count - 1 of __global const float4
 *     *rays; seeds count*Hs*Ws (azimuth first + k's at k*Hs*Ws); angle bands int stride >= H*W
 *     floats apart (azimuth a's at a*stride: a stride that keeps each band at the device's
 *     base-address alignment lets a host hand out a band as a sub-buffer).  Global sizes
 *     (Ws, Hs, count) for the seeds; for the cells (W, H, count) (OCLS_OUT_ANGLE alone) or
 *     (W, H, 1) with OCLS_OUT_SVF (each work-item walks the count azimuths in order, adding
 *     to svf and writing the angles too with OCLS_OUT_ANGLE); the first two dimensions
 *     rounded up to any local size, the third's local size 1.  With -D OCLS_SUN_TABLE the
 *     cells' rays and cell sizes per block (the seeds keep rays; cell stays, unread), after
 *     count: __global const int *band (as horizon_cells'), __global const float4 *table,
 *     const int table_stride: block b's cell sizes (dx, dy, 0, 0) at table[b table_stride],
 *     its ray at azimuth first + k at table[b table_stride + 1 + k].
 *
 * Build options: -D OCLS_OUT_ANGLE, OCLS_OUT_SVF=1|2, OCLS_CURVATURE,
 *   OCLS_MAX_DISTANCE, OCLS_CLAMP, OCLS_LEVEL_SCAN=0|1 ("Levels"; default 0), OCLS_SWEEP=1|4|8|16
 *   (a build of horizon_sweep alone; the
 *   others build horizon_seeds and horizon_cells), OCLS_FORCE_SEED_FALLBACK (tests only: the
 *   seeded walk's bound is +inf, so every cell takes step 3's walk from -inf),
 *   OCLS_OWN_BUILTINS (common.h) and -cl-std=CL1.2, nothing else (no fast-math); the hosts
 *   paste common.h in place of its include.
 */
#include "common.h"

#define OCLS_MAX_ITERATIONS 1000000
#define OCLS_SEED_STRIDE 8                 /* the seed grid's spacing in cells ("Seeds" above) */
#if !defined(OCLS_CLAMP) && !defined(OCLS_MAX_DISTANCE)
#define OCLS_SEEDED                        /* the whole-map walk starts from its seeds' bound */
#endif
#ifndef OCLS_LEVEL_SCAN
#define OCLS_LEVEL_SCAN 0                  /* how the walk finds its level ("Levels"): the tuning knob `scan` */
#endif
#define OCLS_CORNER_EPS (4.0f * FLT_EPSILON)
#define OCLS_SLACK 1e-6f                   /* prune_slack's relative margin */
#define OCLS_SIGN(u) ((u) > 0.0f ? 1 : ((u) < 0.0f ? -1 : 0))
#ifdef OCLS_CURVATURE
#define OCLS_DROP(c, t) ((c) * (t) * (t))
#else
#define OCLS_DROP(c, t) 0.0f
#endif

/* A ray of cell (i, j): direction, its reciprocals (0 along an axis it does
 * not move on), and whether it runs along the cell's grid row / column. */
typedef struct {
    int i, j, sx, sy, on_row, on_col;
    float ux, uy, ix, iy, c, radius;
} HRay;

/* The search radius R in metres (-D OCLS_MAX_DISTANCE; else the whole map). */
#ifdef OCLS_MAX_DISTANCE
#define OCLS_RADIUS(r) ((r)->radius)
#else
#define OCLS_RADIUS(r) INFINITY
#endif

/* Lanes: the sweep's build (-D OCLS_SWEEP=lanes, "The sweep") steps OCLS_LANES cells at once on
 * float / int vectors (ocls_floatv / ocls_intv); every other build has one (float / int).  The
 * surface and patch functions below are written once over these types: the walk's scalar code
 * and the sweep's lanes compute the same expressions. */
#ifdef OCLS_SWEEP
#if !defined(OCLS_MAX_DISTANCE) || defined(OCLS_CLAMP)
#error "OCLS_SWEEP is the search radius's sweep: with -D OCLS_MAX_DISTANCE and without OCLS_CLAMP"
#endif
#define OCLS_LANES OCLS_SWEEP
#else
#define OCLS_LANES 1
#endif
#if OCLS_LANES == 1
#define ocls_floatv float
#define ocls_intv int
#define OCLS_ROW_LOAD(p) (*(p))
#elif OCLS_LANES == 4 || OCLS_LANES == 8 || OCLS_LANES == 16
#define ocls_floatv OCLS_CAT(float, OCLS_LANES)
#define ocls_intv OCLS_CAT(int, OCLS_LANES)
#define OCLS_ROW_LOAD(p) OCLS_LANE_FN(vload, OCLS_LANES)(0, p)
#else
#error "OCLS_SWEEP (lanes) must be 1, 4, 8 or 16"
#endif

/* ocls_atan_deg(x): atan(x) in degrees from +, -, *, / alone (reduced at tan(pi/8) and tan(3 pi/8)
 * to |t| <= tan(pi/8), then t + t z P(z), z = t^2, P a cubic fitted for the least largest relative
 * error there, 2.1e-8 in float64; in degrees, 45 or 90 added last), so every device with
 * IEEE float32 and correctly rounded division gives the same bits: the built-in atan is allowed
 * 4 ulp and drivers differ (PoCL's and NVIDIA's angles differed in their last bits).  Within 2.5 ulp
 * of the float64 atan in degrees (tests/test_horizon.py); atan(+-inf) = +-90. */
OCLS_INLINE float ocls_atan_deg(float x)
{
    const float a = fabs(x);
    float y0 = 0.0f, t = a;
    if (a > 2.414213562373095f) {
        y0 = 90.0f;
        t = -1.0f / a;
    } else if (a > 0.4142135623730950f) {
        y0 = 45.0f;
        t = (a - 1.0f) / (a + 1.0f);
    }
    const float z = t * t;
    const float p = (((8.053527798e-02f * z - 1.387762118e-01f) * z + 1.997770540e-01f) * z
                     - 3.333294907e-01f) * z * t + t;
    const float deg = y0 + p * 57.29577951308232f;
    return x < 0.0f ? -deg : deg;
}

/* Ray parameter at which the ray leaves the tile [c0, c0+size] x [r0, r0+size]
 * (shadow.cl's tile_exit for a start on a sample: the same values, so the
 * same corner passes). */
OCLS_INLINE float exit_t(const HRay *r, int r0, int c0, int size, int *via_x, int *via_y)
{
    const float tx = r->sx ? (float)((r->sx > 0 ? c0 + size : c0) - r->j) * r->ix : INFINITY;
    const float ty = r->sy ? (float)((r->sy > 0 ? r0 + size : r0) - r->i) * r->iy : INFINITY;
    const int corner = r->sx && r->sy && fabs(tx - ty) <= OCLS_CORNER_EPS * fmax(tx, ty);
    *via_x = corner || tx < ty;
    *via_y = corner || ty < tx;
    return fmin(tx, ty);
}

/* Whether the step-by-step sequence has crossed the grid line at parameter x by the time it
 * crosses the other axis's line at t: before it, or with it as a corner pass (exit_t's test). */
OCLS_INLINE int crossed(float x, float t)
{
    return x < t || fabs(x - t) <= OCLS_CORNER_EPS * fmax(x, t);
}

/* Patch index along one axis (origin o, reciprocal iu, sign) just after the ray crosses the
 * other axis's grid line at *t, within [lo, hi].  The position o + u t, rounded, gives it.  With a
 * search radius (where the walk reproduces the sweep bit for bit, "The sweep") it is the patch the
 * step-by-step sequence of patches (the sweep's, and the walk's at level 0) is in there, so that a
 * tile skipped whole is left as stepping through it would: where the ray passes within float32
 * rounding of a corner (the rounded position is then off by at most one patch), the grid lines'
 * own parameters decide, as exit_t computes them, and a corner pass whose line comes first moves
 * *t back to it (exit_t's fmin). */
OCLS_INLINE int along(int o, float u, float iu, int sign, float *t, int lo, int hi)
{
    const float p = (float)o + u * *t;
    int k = clamp(sign > 0 ? ocls_floor_int(p) : ocls_ceil_int(p) - 1, lo, hi);
#ifdef OCLS_MAX_DISTANCE
    if (k != (sign > 0 ? hi : lo) && crossed((float)((sign > 0 ? k + 1 : k) - o) * iu, *t)) k += sign;
    else if (k != (sign > 0 ? lo : hi) && !crossed((float)((sign > 0 ? k : k + 1) - o) * iu, *t)) k -= sign;
    const float line = (float)((sign > 0 ? k : k + 1) - o) * iu;     /* the last line crossed */
    if (line > 0.0f && line < *t && *t - line <= OCLS_CORNER_EPS * *t) *t = line;   /* a corner pass */
#endif
    return k;
}

OCLS_INLINE int valid_patch(__global const float *h, int H, int W, int pr, int pc)
{
    return !(isnan(ocls_sample(h, H, W, pr, pc)) || isnan(ocls_sample(h, H, W, pr, pc + 1)) ||
             isnan(ocls_sample(h, H, W, pr + 1, pc)) || isnan(ocls_sample(h, H, W, pr + 1, pc + 1)));
}

/* sup over [t_in, t_out] of f(t) / t, f(t) = S(t) - z0 - c t^2 along the ray in one patch, from
 * the surface at t_in and its slope and curvature along the ray there (s_a, s1, s2: S(t_in + tau)
 * = s_a + s1 tau + s2 tau^2); NaN on a hole.  *t_at: a ray parameter where it is reached.  At
 * t_in = 0 (the cell itself, f(0) = 0) f / t is linear: the slope or the end's tangent; else the
 * ends' tangents and the one interior critical point t* = sqrt(A / C) (f = A + B t + C t^2, a
 * maximum iff A, C < 0: the tangent from the eye to the surface), where f / t is evaluated (an
 * error in t* changes the value only to second order). */
OCLS_INLINE ocls_floatv segment_sup(ocls_floatv s_a, ocls_floatv s1, ocls_floatv s2, ocls_floatv z0, const HRay *r,
                                    float t_in, float t_out, ocls_floatv *t_at)
{
    const float len = t_out - t_in;
#ifdef OCLS_CURVATURE
    const ocls_floatv a = s1 - 2.0f * r->c * t_in, b = s2 - r->c;   /* f(t_in + tau) = f_a + a tau + b tau^2 */
#else
    const ocls_floatv a = s1, b = s2;
#endif
    if (t_in == 0.0f) {                                    /* f = tau (a + b tau) from the cell itself */
        *t_at = (ocls_floatv)(t_out);
        return fmax(a, a + b * len);
    }
    const ocls_floatv f_a = (s_a - z0) - OCLS_DROP(r->c, t_in);
    const ocls_floatv at_in = f_a / t_in, at_out = (f_a + (a + b * len) * len) / t_out;
    const ocls_floatv best = fmax(at_in, at_out);
    *t_at = select((ocls_floatv)(t_in), (ocls_floatv)(t_out), at_out >= at_in);
#if OCLS_LANES == 1
    if (!(b < 0.0f)) return best;                          /* no interior maximum (the walk: skip its cost) */
#endif
    const ocls_floatv q = t_in * t_in + (f_a - a * t_in) / b;
    const ocls_floatv tau = select((ocls_floatv)(0.0f), sqrt(q) - t_in, q > 0.0f);
    const ocls_floatv at_tau = (f_a + (a + b * tau) * tau) / (t_in + tau);
    const ocls_intv inner = (b < 0.0f) & (tau > 0.0f) & (tau < len) & (at_tau > best);
    *t_at = select(*t_at, t_in + tau, inner);
    return select(best, at_tau, inner);
}

/* segment_sup in the patch with corners h00 (its north-west), h01, h10, h11, at offset (ox, oy) =
 * (j - pc, i - pr) from the cell (positions measured from the cell: the float32 error of a position
 * grows with the distance, not the column) */
OCLS_INLINE ocls_floatv patch_segment(ocls_floatv h00, ocls_floatv h01, ocls_floatv h10, ocls_floatv h11,
                                      ocls_floatv z0, const HRay *r, int ox, int oy, float t_in, float t_out,
                                      ocls_floatv *t_at)
{
    const float fx = (float)ox + r->ux * t_in, fy = (float)oy + r->uy * t_in;
    const ocls_floatv ex = h01 - h00, ey = h10 - h00, k = (h00 - h01) - (h10 - h11);
    return segment_sup(h00 + ex * fx + ey * fy + k * (fx * fy), (ex + k * fy) * r->ux + (ey + k * fx) * r->uy,
                       k * (r->ux * r->uy), z0, r, t_in, t_out, t_at);
}

/* segment_sup on the grid line of a ray along a row (on_row) or column, between its samples a and
 * b (a at the patch's west / north end) */
OCLS_INLINE ocls_floatv line_segment(ocls_floatv a, ocls_floatv b, ocls_floatv z0, const HRay *r, int ox, int oy,
                                     float t_in, float t_out, ocls_floatv *t_at)
{
    const float f = r->on_row ? (float)ox + r->ux * t_in : (float)oy + r->uy * t_in;
    return segment_sup(a + (b - a) * f, (b - a) * (r->on_row ? r->ux : r->uy), (ocls_floatv)(0.0f), z0, r, t_in,
                       t_out, t_at);
}

OCLS_INLINE void init_ray(HRay *r, int i, int j, float4 ray)
{
    r->i = i; r->j = j; r->ux = ray.x; r->uy = ray.y; r->c = ray.z; r->radius = ray.w;
    r->sx = OCLS_SIGN(ray.x); r->sy = OCLS_SIGN(ray.y);
    r->ix = r->sx ? 1.0f / ray.x : 0.0f;
    r->iy = r->sy ? 1.0f / ray.y : 0.0f;
    r->on_row = r->sy == 0;
    r->on_col = r->sx == 0 && !r->on_row;
}

/* The outputs of one cell (index idx, not nodata) from its tangent T ("Outputs" above). */
OCLS_INLINE void store_outputs(__global float *angle, __global float2 *svf, int idx, float T)
{
#ifdef OCLS_OUT_ANGLE
    angle[idx] = T == -INFINITY ? -90.0f : ocls_atan_deg(T);
#endif
#ifdef OCLS_OUT_SVF
    const float tp = fmax(T, 0.0f);
#if OCLS_OUT_SVF == 1
    const float term = (tp * tp) / (1.0f + tp * tp);
#else
    const float term = tp / sqrt(1.0f + tp * tp);
#endif
    ocls_kahan_add(svf, idx, term);
#endif
}

#ifndef OCLS_SWEEP
/* The walk's level 0: sup over [t_in, t_out] of f(t) / t in patch (pr, pc) (or on the grid line
 * the ray runs along); -INFINITY for a hole.  *t_at: as segment_sup (for the seeds; not written
 * for a hole). */
OCLS_INLINE float patch_sup(__global const float *h, int H, int W, int pr, int pc, const HRay *r, float z0,
                            float t_in, float t_out, float *t_at)
{
    const int ox = r->j - pc, oy = r->i - pr;
    if (r->on_row || r->on_col) {
        const float a = r->on_row ? ocls_sample(h, H, W, r->i, pc) : ocls_sample(h, H, W, pr, r->j);
        const float b = r->on_row ? ocls_sample(h, H, W, r->i, pc + 1) : ocls_sample(h, H, W, pr + 1, r->j);
        if (isnan(a) || isnan(b)) return -INFINITY;
        return line_segment(a, b, z0, r, ox, oy, t_in, t_out, t_at);
    }
    float h00, h01, h10, h11;
    if (H > 1 && W > 1) {
        __global const float *p = h + pr * W + pc;
        h00 = p[0]; h01 = p[1]; h10 = p[W]; h11 = p[W + 1];
    } else {
        h00 = ocls_sample(h, H, W, pr, pc); h01 = ocls_sample(h, H, W, pr, pc + 1);
        h10 = ocls_sample(h, H, W, pr + 1, pc); h11 = ocls_sample(h, H, W, pr + 1, pc + 1);
    }
    if (isnan(h00) || isnan(h01) || isnan(h10) || isnan(h11)) return -INFINITY;
    return patch_segment(h00, h01, h10, h11, z0, r, ox, oy, t_in, t_out, t_at);
}

/* Corner pass out of the hole patch (pr, pc) at t: the ray touches the corner
 * sample when a side neighbour is a valid patch (shadow.cl's corner_hits). */
OCLS_INLINE float corner_sup(__global const float *h, int H, int W, int pr, int pc, const HRay *r, float z0,
                             float t)
{
    const int Hp = max(H - 1, 1), Wp = max(W - 1, 1);
    const int bc = r->sx > 0 ? pc + 1 : pc - 1, cr = r->sy > 0 ? pr + 1 : pr - 1;
    const int side = (bc >= 0 && bc < Wp && valid_patch(h, H, W, pr, bc)) ||
                     (cr >= 0 && cr < Hp && valid_patch(h, H, W, cr, pc));
    const float v = ocls_sample(h, H, W, r->sy > 0 ? pr + 1 : pr, r->sx > 0 ? pc + 1 : pc);
    return (side && !isnan(v)) ? ((v - z0) - OCLS_DROP(r->c, t)) / t : -INFINITY;
}

/* A height margin above the float32 error of the patch values (segment_sup, corner_sup) in a
 * tile of extrema e = (max, min) out to ray parameter t_end, where the test compares e.x - z0 with
 * bar: with a search radius a tile is pruned (or the walk ends, e = the whole map's extrema) only
 * when its patches come out at most T in float32 too, not only in exact arithmetic, so that the
 * walk's T is the sweep's, the max over every patch within R, bit for bit ("The sweep").
 * OCLS_SLACK (8 ulp) relative to the magnitudes the patch arithmetic rounds: bar, the heights,
 * and the tile's relief times the positions' magnitude, t (|ux| + |uy|) cells; a flat tile's
 * patches are exact and get none (a flat's ties stay pruned).  Measured: docs/solar.md, "The
 * sweep and the walk: the same bits". */
OCLS_INLINE float prune_slack(const HRay *r, float2 e, float z0, float bar, float t_end)
{
#ifdef OCLS_MAX_DISTANCE
    const float relief = e.x - e.y;
    return OCLS_SLACK * (fabs(bar) + (relief > 0.0f ? fabs(e.x) + fabs(z0) +
                                      relief * (2.0f + t_end * (fabs(r->ux) + fabs(r->uy))) : 0.0f));
#else
    return 0.0f;      /* over the whole map there is no sweep to agree with */
#endif
}

/* Whether the level-k tile (k >= 1) around patch (pr, pc) cannot raise T from ray parameter t on,
 * best being T so far (step "level l > 0" above): its max M, less z0, is at most the bar best t + drop
 * (best >= 0; else best t_end + drop, t_end the ray's exit from the tile within the radius), with
 * prune_slack's margin within a search radius.  Without a radius this is monotone in k (a larger tile
 * has the larger max and, for best < 0, the later exit: the lower bar, float32 rounding being
 * monotone too), so "the largest such tile" is one tile however it is searched for. */
OCLS_INLINE int prunable(__global const float2 *ext, __global const int *lvl_off, int Wp, const HRay *r, float z0,
                         float best, float t, int pr, int pc, int k)
{
    const float2 e = ext[lvl_off[k] + (pr >> k) * ocls_level_extent(Wp, k) + (pc >> k)];
    float t_end = INFINITY;
#ifndef OCLS_MAX_DISTANCE
    if (best < 0.0f)
#endif
    {
        int via_x, via_y;
        t_end = fmin(exit_t(r, (pr >> k) << k, (pc >> k) << k, 1 << k, &via_x, &via_y), OCLS_RADIUS(r));
    }
    const float bar = best * (best >= 0.0f ? t : t_end) + OCLS_DROP(r->c, t);
    return !(e.x - z0 > bar || e.x - z0 + prune_slack(r, e, z0, bar, t_end) > bar);
}

/* T of cell (i, j) (height z0, not nodata), starting from lo; with -D OCLS_CLAMP
 * it stops once T >= hi.  *t_best: a ray parameter where T is reached (left as it
 * was when T = lo). */
OCLS_INLINE float horizon_tan(__global const float *h, int H, int W, __global const float2 *ext,
                              __global const int *lvl_off, int nlev, const HRay *r, float z0, float lo, float hi,
                              float *t_best)
{
    const int Hp = max(H - 1, 1), Wp = max(W - 1, 1), top = nlev - 1;
    int pc = r->sx < 0 ? r->j - 1 : (r->sx > 0 ? r->j : min(r->j, Wp - 1));
    int pr = r->sy < 0 ? r->i - 1 : (r->sy > 0 ? r->i : min(r->i, Hp - 1));
    if (pc < 0 || pc >= Wp || pr < 0 || pr >= Hp) return lo;
    const float2 e_top = ext[lvl_off[top]];
    const float rise = e_top.x - z0;                       /* z_top - z0 >= 0 */
    float best = lo, t = 0.0f;
    int l = 0;
    for (int it = 0; it < OCLS_MAX_ITERATIONS; ++it) {
        if (t > 0.0f && rise - OCLS_DROP(r->c, t) <= best * t &&        /* nothing further is higher */
            rise - OCLS_DROP(r->c, t) + prune_slack(r, e_top, z0, best * t, t) <= best * t) break;
#ifdef OCLS_MAX_DISTANCE
        if (t >= OCLS_RADIUS(r)) break;                    /* the search radius */
#endif
        /* the level: the largest tile around the patch that cannot raise T from here on (0: none,
         * the patch itself), "Levels" above; OCLS_LEVEL_SCAN tests every level at once, else the
         * search moves from the last step's level */
#if OCLS_LEVEL_SCAN
        l = 0;
        for (int k = 1; k <= top; ++k)
            if (prunable(ext, lvl_off, Wp, r, z0, best, t, pr, pc, k)) l = k;
#else
        if (l > 0 && !prunable(ext, lvl_off, Wp, r, z0, best, t, pr, pc, l)) {
            do --l; while (l > 0 && !prunable(ext, lvl_off, Wp, r, z0, best, t, pr, pc, l));
        } else {
            while (l < top && prunable(ext, lvl_off, Wp, r, z0, best, t, pr, pc, l + 1)) ++l;
        }
#endif
        const int size = 1 << l, r0 = (pr >> l) << l, c0 = (pc >> l) << l;
        int via_x, via_y;
        const float t_out = exit_t(r, r0, c0, size, &via_x, &via_y);
        if (l == 0) {                                      /* the patch: its sup (the tile's skipped) */
            float t_at = t;
            const float patch = patch_sup(h, H, W, pr, pc, r, z0, t, fmin(t_out, OCLS_RADIUS(r)), &t_at);
            if (patch > best) *t_best = t_at;
            best = fmax(best, patch);
            if (via_x && via_y && t_out <= OCLS_RADIUS(r) && !valid_patch(h, H, W, pr, pc)) {
                const float corner = corner_sup(h, H, W, pr, pc, r, z0, t_out);
                if (corner > best) *t_best = t_out;
                best = fmax(best, corner);
            }
#ifdef OCLS_CLAMP
            if (best >= hi) break;                         /* as high as the caller asks */
#endif
        }
        float t_next = t_out;
        if (via_x) pc = r->sx > 0 ? c0 + size : c0 - 1;
        else if (r->sx) pc = along(r->j, r->ux, r->ix, r->sx, &t_next, c0, c0 + size - 1);
        if (via_y) pr = r->sy > 0 ? r0 + size : r0 - 1;
        else if (r->sy) pr = along(r->i, r->uy, r->iy, r->sy, &t_next, r0, r0 + size - 1);
        t = t_next;
        if (pr < 0 || pr >= Hp || pc < 0 || pc >= Wp) break;
    }
    return best;
}


/* The seed grid: cells (min(S gi, H - 1), min(S gj, W - 1)), gi < ocls_seed_extent(H),
 * gj < ocls_seed_extent(W), S = OCLS_SEED_STRIDE (so every cell has seed cells on all four
 * sides of its S x S square, clamped at the map's last row and column). */
OCLS_INLINE int ocls_seed_extent(int n) { return (n - 1) / OCLS_SEED_STRIDE + 2; }

/* Seeds, step 1: the exact walk on the seed grid, (T, a ray parameter where T is reached), of seed
 * cell (gi, gj) at the azimuth of ray. */
OCLS_INLINE float2 seed_walk(__global const float *h, int H, int W, __global const float2 *ext,
                             __global const int *lvl_off, int nlev, float4 ray, int gi, int gj)
{
    const int i = min(gi * OCLS_SEED_STRIDE, H - 1), j = min(gj * OCLS_SEED_STRIDE, W - 1);
    const float z0 = h[i * W + j];
    float t_best = 0.0f, T = -INFINITY;
    if (!isnan(z0)) {
        HRay r;
        init_ray(&r, i, j, ray);
        T = horizon_tan(h, H, W, ext, lvl_off, nlev, &r, z0, -INFINITY, INFINITY, &t_best);
    }
    return (float2)(T, t_best);
}

__kernel void horizon_seeds(__global const float *h, const int H, const int W, __global const float2 *ext,
                            __global const int *lvl_off, const int nlev, const float4 ray, __global float2 *seeds)
{
    const int gj = get_global_id(0), gi = get_global_id(1), Hs = ocls_seed_extent(H), Ws = ocls_seed_extent(W);
    if (gj >= Ws || gi >= Hs) return;
    seeds[gi * Ws + gj] = seed_walk(h, H, W, ext, lvl_off, nlev, ray, gi, gj);
}

/* Seeds, step 2: a lower bound on T of the ray r (cell (i, j), height z0) from the horizon
 * point of seed cell (iq, jq) (seed: its T and parameter tq): the surface on r's ray at the
 * parameter nearest that point, less a margin for the float32 rounding of this estimate; -inf
 * when there is none (no horizon, behind the cell, past the radius, off the map, a hole). */
OCLS_INLINE float seed_bound(__global const float *h, int H, int W, const HRay *r, float z0, float2 cell,
                             int iq, int jq, float2 seed)
{
    if (!(seed.x > -INFINITY)) return -INFINITY;
    /* (x, y) in metres advance by (ux dx^2, uy dy^2) per metre of t: a unit vector */
    const float t = seed.y + (float)(jq - r->j) * (r->ux * cell.x * cell.x) +
                    (float)(iq - r->i) * (r->uy * cell.y * cell.y);
    if (!(t > 0.0f) || t > OCLS_RADIUS(r)) return -INFINITY;
    const float x = (float)r->j + r->ux * t, y = (float)r->i + r->uy * t;
    const int pc = ocls_floor_int(x), pr = ocls_floor_int(y);
    if (pc < 0 || pr < 0 || pc >= W - 1 || pr >= H - 1) return -INFINITY;
    __global const float *p = h + pr * W + pc;
    const float fx = x - (float)pc, fy = y - (float)pr;
    const float s = (p[0] * (1.0f - fx) + p[1] * fx) * (1.0f - fy) + (p[W] * (1.0f - fx) + p[W + 1] * fx) * fy;
    if (isnan(s)) return -INFINITY;
    const float v = ((s - z0) - OCLS_DROP(r->c, t)) / t;
    return v - (fabs(v) * 1e-5f + (fabs(s) + fabs(z0) + 1.0f) * 1e-6f / t);
}


/* The outputs of cell (i, j) at the azimuth of ray (bounds: OCLS_CLAMP's (lo, hi), else unread). */
OCLS_INLINE void cell_walk(__global const float *h, int H, int W, __global const float2 *ext,
                           __global const int *lvl_off, int nlev, float4 ray, __global float *angle,
                           __global float2 *svf, __global const float2 *seeds, float2 cell, float2 bounds,
                           int i, int j)
{
    const int idx = i * W + j;
    const float z0 = h[idx];
    if (isnan(z0)) {
#ifdef OCLS_OUT_ANGLE
        angle[idx] = NAN;
#endif
        return;
    }
    HRay r;
    init_ray(&r, i, j, ray);
    float t_best = 0.0f;
#if defined(OCLS_CLAMP)
    const float T = horizon_tan(h, H, W, ext, lvl_off, nlev, &r, z0, bounds.x, bounds.y, &t_best);
#elif !defined(OCLS_SEEDED)
    const float T = horizon_tan(h, H, W, ext, lvl_off, nlev, &r, z0, -INFINITY, INFINITY, &t_best);
#else
    /* Seeds, step 3: the walk from the best bound of the four seed cells around (i, j), again
     * from -inf in the rare case that nothing beats it (the bound's margin was too thin) */
    const int Ws = ocls_seed_extent(W);
    const int gi = i / OCLS_SEED_STRIDE, gj = j / OCLS_SEED_STRIDE;
    float lo = -INFINITY;
    for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b) {
            const int qi = gi + a, qj = gj + b;
            lo = fmax(lo, seed_bound(h, H, W, &r, z0, cell, min(qi * OCLS_SEED_STRIDE, H - 1),
                                     min(qj * OCLS_SEED_STRIDE, W - 1), seeds[qi * Ws + qj]));
        }
#ifdef OCLS_FORCE_SEED_FALLBACK
    lo = INFINITY;                                     /* tests only: nothing beats it, every cell falls back */
#endif
    float T = horizon_tan(h, H, W, ext, lvl_off, nlev, &r, z0, lo, INFINITY, &t_best);
    if (T == lo && lo > -INFINITY) T = horizon_tan(h, H, W, ext, lvl_off, nlev, &r, z0, -INFINITY, INFINITY, &t_best);
#endif
    store_outputs(angle, svf, idx, T);
}

#ifdef OCLS_SUN_TABLE
#define OCLS_TABLE_RAY ray_unread
#define OCLS_TABLE_CELL cell_unread
#else
#define OCLS_TABLE_RAY ray
#define OCLS_TABLE_CELL cell
#endif
__kernel void horizon_cells(__global const float *h, const int H, const int W, __global const float2 *ext,
                            __global const int *lvl_off, const int nlev, const float4 OCLS_TABLE_RAY,
                            __global float *angle, __global float2 *svf, __global const float2 *seeds,
                            const float2 OCLS_TABLE_CELL
#if defined(OCLS_SUN_TABLE)
                            , const float2 bounds_unread, __global const int *band,
                            __global const float4 *strips
#elif defined(OCLS_CLAMP)
                            , const float2 bounds
#endif
                            )
{
    const int j = get_global_id(0), i = get_global_id(1);
    if (j >= W || i >= H) return;
#if defined(OCLS_SUN_TABLE)
    const int block = band[i] + band[H + j];
    const float4 ray = strips[2 * block], more = strips[2 * block + 1];
    const float2 cell = more.zw;
#if defined(OCLS_CLAMP)
    const float2 bounds = more.xy;
#else
    const float2 bounds = (float2)(-INFINITY, INFINITY);
#endif
#elif !defined(OCLS_CLAMP)
    const float2 bounds = (float2)(-INFINITY, INFINITY);
#endif
    cell_walk(h, H, W, ext, lvl_off, nlev, ray, angle, svf, seeds, cell, bounds, i, j);
}

#ifdef OCLS_SEEDED
/* Batches ("Batches" above): the whole map's seeded walk for several azimuths per launch, azimuth
 * first + k with ray rays[first + k], its seeds at seeds + k Hs Ws and its angles at
 * angle + (first + k) stride. */
__kernel void horizon_seeds_batch(__global const float *h, const int H, const int W, __global const float2 *ext,
                                  __global const int *lvl_off, const int nlev, __global const float4 *rays,
                                  __global float2 *seeds, const int first)
{
    const int gj = get_global_id(0), gi = get_global_id(1), k = get_global_id(2);
    const int Hs = ocls_seed_extent(H), Ws = ocls_seed_extent(W);
    if (gj >= Ws || gi >= Hs) return;
    seeds[((size_t)k * Hs + gi) * Ws + gj] = seed_walk(h, H, W, ext, lvl_off, nlev, rays[first + k], gi, gj);
}

__kernel void horizon_cells_batch(__global const float *h, const int H, const int W, __global const float2 *ext,
                                  __global const int *lvl_off, const int nlev, __global const float4 *rays,
                                  __global float *angle, __global float2 *svf, __global const float2 *seeds,
                                  const float2 OCLS_TABLE_CELL, const int stride, const int first, const int count
#ifdef OCLS_SUN_TABLE
                                  , __global const int *band, __global const float4 *table, const int table_stride
#endif
                                  )
{
    const int j = get_global_id(0), i = get_global_id(1);
    if (j >= W || i >= H) return;
#ifdef OCLS_SUN_TABLE
    __global const float4 *own = table + (size_t)(band[i] + band[H + j]) * table_stride;   /* the cell's block's */
    const float2 cell = own[0].xy;
#define OCLS_BATCH_RAY(k) own[1 + (k)]
#else
#define OCLS_BATCH_RAY(k) rays[first + (k)]
#endif
#ifdef OCLS_OUT_SVF
    const int k0 = 0, k1 = count;                      /* a cell's sums in azimuth order */
#else
    const int k0 = get_global_id(2), k1 = k0 + 1;
#endif
    const size_t seed_cells = (size_t)ocls_seed_extent(H) * ocls_seed_extent(W);
    for (int k = k0; k < k1; ++k)
        cell_walk(h, H, W, ext, lvl_off, nlev, OCLS_BATCH_RAY(k),
#ifdef OCLS_OUT_ANGLE
                  angle + (size_t)(first + k) * stride,
#else
                  angle,
#endif
                  svf, seeds + (size_t)k * seed_cells, cell, (float2)(-INFINITY, INFINITY), i, j);
}
#endif
#endif /* the walk */

/* ---------------------------------------------------------------- the sweep
 * horizon_sweep (-D OCLS_SWEEP=lanes, with OCLS_MAX_DISTANCE): the outputs of
 * horizon_cells within a search radius R, from the walk's level-0 steps
 * without the pyramid, OCLS_LANES cells of a row per work-item on vector
 * lanes.  Within a short radius the pyramid prunes little, and the walk's
 * cost is its data-dependent branches (descend or step, patch or tile, the
 * ray's end).  But the ray of every cell at one azimuth crosses the same
 * sequence of patches relative to the cell (positions are measured from the
 * cell, so the exits (dc + 1) / ux, the corner passes and the in-patch
 * positions are the same float32 values for every cell): the cells of a run
 * step through it together.  Each step is the walk's level 0 on the lanes:
 * patch_segment / line_segment on the patch's corners (a hole or a patch off
 * the map gives NaN, which fmax ignores: the rays leave the map for good, and
 * their corner passes beyond it meet no sample) and, at a corner pass out of
 * a hole, corner_sup's sample.  The walk skips the tiles whose bound cannot
 * beat its best tangent; the sweep evaluates every patch within R.  So the
 * outputs are horizon_cells' with the same radius bit for bit, because the
 * walk with -D OCLS_MAX_DISTANCE closes the two gaps between them: a skipped
 * tile whose bound tied the best tangent in float32 could hold patches whose
 * evaluation comes out a few ulp higher (a patch edge's point is evaluated
 * from both patches, and the entry (j - pc) + ux t cancels near 0 or 1: up to
 * 40 ulp), so a tile is pruned, and the walk ends, only with prune_slack's
 * margin; and a walk leaving a skipped tile entered the next patch at a
 * position rounded from the map's columns, which can differ from the
 * step-by-step sequence where the ray passes within float32 rounding of a
 * patch corner, so along() follows the step-by-step decisions there.  Before
 * (measured): 962 of 11.5 million angles differed on SRTM N22W160 at 10 cells,
 * up to 9.5e-6 degrees; since, none on four maps at 5-120 cells (SRTM N22W160
 * to 200), flat and curved (tests/test_horizon.py and bench/horizon_sweep.py
 * fail on one).  The
 * whole-map walk keeps the plain tests (there is no sweep to agree with, and
 * the margins cost it 50 % on N22W160).
 * So which of the two runs is free to follow the device: the hosts sweep where
 * the ray crosses at most the tuning knob sweep_cells patch columns and
 * rows within R (oclshade/horizon/caster.py, host/src/horizon.c: R (|ux| +
 * |uy|) in float64 from the float32 ray) on maps of 2 rows and columns or
 * more; measured: docs/solar.md, "The sweep".
 *
 *   __kernel horizon_sweep(h, H, W, ray, angle, svf)  arguments as horizon_cells
 *     (R = ray.w > 0); built with -D OCLS_SWEEP = 1, 4, 8 or 16 (cells per
 *     work-item: the tuning knob `lanes`) and OCLS_MAX_DISTANCE, not OCLS_CLAMP;
 *     global size (ceil(W / OCLS_LANES), H) rounded up to any local size.  A
 *     work-item takes columns j0 .. j0 + OCLS_LANES - 1, j0 = OCLS_LANES gid(0),
 *     shifted left to end at column W - 1 at the right edge (it writes the
 *     columns from j0 on).  With -D OCLS_SUN_TABLE (a map traced in blocks of
 *     their own scale, in one launch; ray stays, unread) two more arguments:
 *       __global const int *band     as horizon_cells'
 *       __global const float4 *rays  one per block: its ray
 *     a run takes the ray of the block holding row i and column j0, the first
 *     it writes (the inner column edges are multiples of 16, so the columns a
 *     run writes are in one block; the last run's shifted lanes are not
 *     written). */
#ifdef OCLS_SWEEP

/* h[row, col0 + k] on lane k, NaN off the map */
OCLS_INLINE ocls_floatv row_at(__global const float *h, int H, int W, int row, int col0)
{
    if (row < 0 || row >= H) return (ocls_floatv)(NAN);
    __global const float *p = h + row * W;
    if (col0 >= 0 && col0 + OCLS_LANES <= W) return OCLS_ROW_LOAD(p + col0);
    float v[OCLS_LANES];
    for (int k = 0; k < OCLS_LANES; ++k) v[k] = col0 + k >= 0 && col0 + k < W ? p[col0 + k] : NAN;
#if OCLS_LANES == 1
    return v[0];
#else
    return OCLS_LANE_FN(vload, OCLS_LANES)(0, v);
#endif
}

/* a lane mask: patch (row, col0 + k) is on the map and not a hole (valid_patch) */
OCLS_INLINE ocls_intv valid_lanes(__global const float *h, int H, int W, int row, int col0)
{
    return !isnan(row_at(h, H, W, row, col0) + row_at(h, H, W, row, col0 + 1) + row_at(h, H, W, row + 1, col0) +
                  row_at(h, H, W, row + 1, col0 + 1));
}

#ifdef OCLS_SUN_TABLE
__kernel void horizon_sweep(__global const float *h, const int H, const int W, const float4 ray_unread,
                            __global float *angle, __global float2 *svf, __global const int *band,
                            __global const float4 *rays)
#else
__kernel void horizon_sweep(__global const float *h, const int H, const int W, const float4 ray,
                            __global float *angle, __global float2 *svf)
#endif
{
    const int j0 = get_global_id(0) * OCLS_LANES, i = get_global_id(1);
    if (j0 >= W || i >= H) return;
    const int jc = max(min(j0, W - OCLS_LANES), 0);        /* the run's first column */
#ifdef OCLS_SUN_TABLE
    const float4 ray = rays[band[i] + band[H + j0]];     /* the block of the columns it writes */
#endif
    HRay r;                                                 /* the ray of a cell at (0, 0): the steps */
    init_ray(&r, 0, 0, ray);
    const ocls_floatv z0 = row_at(h, H, W, i, jc);
    const float R = r.radius;
    int dc = r.sx < 0 ? -1 : 0, dr = r.sy < 0 ? -1 : 0;     /* the patch, from the cell */
    ocls_floatv best = (ocls_floatv)(-INFINITY), t_at;
    for (float t = 0.0f; t < R;) {
        int via_x, via_y;                                   /* the exit from patch (i + dr, j + dc) of every lane */
        const float t_out = exit_t(&r, dr, dc, 1, &via_x, &via_y), t_end = fmin(t_out, R);
        const int pr = i + dr, pc = jc + dc;               /* lane k: patch (pr, pc + k) */
        ocls_floatv h00, h01, h10, h11, patch;
        if (r.on_row || r.on_col) {
            const ocls_floatv a = r.on_row ? row_at(h, H, W, i, pc) : row_at(h, H, W, pr, jc);
            const ocls_floatv b = r.on_row ? row_at(h, H, W, i, pc + 1) : row_at(h, H, W, pr + 1, jc);
            patch = line_segment(a, b, z0, &r, -dc, -dr, t, t_end, &t_at);
        } else {
            if (pr >= 0 && pr < H - 1 && pc >= 0 && pc + OCLS_LANES < W) {   /* the run's patches on the map */
                __global const float *p = h + pr * W + pc;
                h00 = OCLS_ROW_LOAD(p); h01 = OCLS_ROW_LOAD(p + 1);
                h10 = OCLS_ROW_LOAD(p + W); h11 = OCLS_ROW_LOAD(p + W + 1);
            } else {
                h00 = row_at(h, H, W, pr, pc); h01 = row_at(h, H, W, pr, pc + 1);
                h10 = row_at(h, H, W, pr + 1, pc); h11 = row_at(h, H, W, pr + 1, pc + 1);
            }
            patch = patch_segment(h00, h01, h10, h11, z0, &r, -dc, -dr, t, t_end, &t_at);
            if (via_x && via_y && t_out <= R) {             /* corner_sup out of a hole patch */
                const ocls_intv hole = isnan(h00 + h01 + h10 + h11);
                const ocls_intv side = valid_lanes(h, H, W, pr, pc + r.sx) | valid_lanes(h, H, W, pr + r.sy, pc);
                const ocls_floatv v = r.sy > 0 ? (r.sx > 0 ? h11 : h10) : (r.sx > 0 ? h01 : h00);
                const ocls_floatv at_corner = ((v - z0) - OCLS_DROP(r.c, t_out)) / t_out;
                best = select(best, fmax(best, at_corner), hole & side);
            }
        }
        best = fmax(best, patch);                          /* NaN (a hole, off the map): ignored */
        if (via_x) dc += r.sx;
        if (via_y) dr += r.sy;
        t = t_out;
    }
    float T[OCLS_LANES], z[OCLS_LANES];
#if OCLS_LANES == 1
    T[0] = best;
    z[0] = z0;
#else
    OCLS_LANE_FN(vstore, OCLS_LANES)(best, 0, T);
    OCLS_LANE_FN(vstore, OCLS_LANES)(z0, 0, z);
#endif
    for (int k = j0 - jc; k < OCLS_LANES && jc + k < W; ++k) {
        const int idx = i * W + jc + k;
        if (isnan(z[k])) {
#ifdef OCLS_OUT_ANGLE
            angle[idx] = NAN;
#endif
        } else {
            store_outputs(angle, svf, idx, T[k]);
        }
    }
}
#endif
