/* shadow.cl — cast shadows of a heightmap by multilevel ray traversal of an
 * extrema pyramid (paper 000, Algo 1, 2 and 3): two entry points, one
 * traversal (trace(), shared by both).
 *
 * ABI summary (details under "ABI" below):
 *   shadow_cells   heightmap space, one work-item per cell, global size (W, H)
 *                  rounded up to any local size; arguments: the relative
 *                  float32 heights, their size and int2 origin in the whole map
 *                  (0 for a whole map), the extrema pyramid (float2 levels 1..L
 *                  and their offsets), the sun ray, sun vector, cell size,
 *                  eq. (1) constants and mode, then the mask / self / coef
 *                  outputs.
 *   shadow_pixels  screen space, one work-item per G-buffer pixel, global size
 *                  (width, height) rounded up to any local size; arguments: the
 *                  heights, the level-q grids, the extrema pyramid, the G-buffer
 *                  fields position / uv / uv_grad, the sun, eq. (1) constants,
 *                  mode and Algo 1 settings, then the flag / coef / lod outputs.
 *   shadow_certify with -D OCLS_CERT (EXACT / MAXMIP; the hosts' default):
 *                  one work-item per s x s tile of cells, run per sun before
 *                  shadow_cells; far-field certificates that let provably
 *                  lit rays stop early ("far-field certificates" below);
 *                  shadow_cells then takes the certificate buffer after coef.
 *   shadow_cells_packet with -D OCLS_PACKET=run and -D OCLS_LANES=4/8/16
 *                  (EXACT / MAXMIP; chosen per device by the tuning lookup,
 *                  usually on CPU devices): shadow_cells' results, OCLS_LANES
 *                  rays per work-item on vector lanes ("ray packets" below);
 *                  global size (ceil(W / run), H).
 *   -D OCLS_SUN_TABLE (shadow_cells, shadow_cells_packet, shadow_certify):
 *                  each cell's sun from a table of blocks (a sun that varies
 *                  over the map, traced in one launch; "sun tables" below).
 *   -D options OCLS_METHOD, OCLS_OUT_MASK, OCLS_OUT_SELF (cells only),
 *   OCLS_OUT_COEF, OCLS_OUT_LOD (pixels only), OCLS_STATS, OCLS_CERT (cells
 *   only, with OCLS_CERT_K / _D0 / _SUB / _SPAN), OCLS_CURVATURE (both),
 *   OCLS_IMAGES (shadow_cells and shadow_certify only, not with OCLS_PACKET;
 *   shadow_pixels is then not compiled): h is a __read_only image2d_t
 *   (CL_R / CL_FLOAT, W x H) and ext an atlas image2d_t (CL_RG or CL_RGBA /
 *   CL_FLOAT, .x max, .y min; level l at columns [0, cols_l), rows from
 *   lvl_off[l]), lvl_off holding atlas rows instead of offsets (layout in
 *   common.h; the Python host's shadow knob "images", oclshade/pyramid_images.py),
 *   OCLS_HW_GATHER (with OCLS_PACKET and 16 lanes, where clang defines
 *   __AVX512F__: the packet's lane reads as vgatherdps / vpgatherdd, the same
 *   values; the shadow knob "gather"; elsewhere no effect).
 *   Same outputs bit for bit: an image texel read at integer coordinates with
 *   nearest filtering is the stored float.
 *
 * Geometry (all methods).  Sample (i, j) sits at x = j (east), y = i (south)
 * in cell units; the surface is bilinear over patches (see pyramid.cl).  The
 * ray of cell (i, j) starts at the surface point (j, i, h[i,j]) and follows
 *     x(t) = j + ux t,  y(t) = i + uy t,  z(t) = h[i,j] + w t,   t >= 0,
 * t being the horizontal distance in metres, ux = sin(az)/dx, uy = -cos(az)/dy
 * (cells per metre) and w = tan(elevation).  The cell is in cast shadow iff
 * the surface rises strictly above the ray somewhere with t > 0 inside the
 * map.  Rays exactly along a grid line (ux == 0 or uy == 0) see the linear
 * profile between the samples of that line; a segment with a nodata end is a
 * hole.  Elsewhere a patch with a nodata corner is a hole.  A ray passing
 * through a patch corner (within OCLS_CORNER_EPS relative; the float64
 * reference snaps within 1e-12 and counts rays passing between the two as
 * ties, so az 45 with dx == dy is decided alike everywhere) moves diagonally; leaving a hole patch that way it tests the corner sample when
 * a side neighbour is a valid patch (the only surface it touches there).
 *
 * Curvature (-D OCLS_CURVATURE): the Earth's surface drops by c t^2 below the
 * cell's tangent plane at horizontal distance t (c = (1 - k) / (2 R), R the
 * radius, k the refraction coefficient: r.horizon's and HORAYZON's model), so
 * over the flat map the ray becomes z(t) = z0 + w t + c t^2 and a patch's
 * f(t) = S - z keeps its quadratic form (slope less 2 c t, curvature less c).
 * The traversal stays exact: z still rises with t, so a tile's lowest ray
 * point is its entry (the max test) and its highest its exit (the min early
 * exit), the global-max exit holds, and the far-field certificates, which
 * bound S - w t, bound S - w t - c t^2 too.  Without the option the plain
 * line is compiled and c is not read.
 *
 * Methods (-D OCLS_METHOD=...):
 *   OCLS_EXACT (1)  Algo 3 made conservative: a tile is skipped only when the
 *                   ray's lowest point in it (its entry, the ray rises) is at
 *                   or above the tile max; the min early exit fires only when
 *                   the ray's highest point in the tile (its exit) is strictly
 *                   below the tile min; in a patch the bilinear surface along
 *                   the ray is a quadratic in t, so its maximum against the
 *                   ray is found in closed form.  After a skip the traversal
 *                   climbs one level when the ray has just entered that
 *                   level's tile too, instead of the paper's restart at the
 *                   top level (climbing straight to the coarsest tile entered
 *                   took 13 % more packet iterations on Puget Sound 4096^2,
 *                   sun 37/20: rays near the terrain climbed only to descend).
 *   OCLS_PAPER (2)  Algo 3 as printed: start on the texel after the start,
 *                   min and max tests at the tile's exit point, bilinear
 *                   height at the segment midpoint P_s at level 0, restart at
 *                   the coarsest level after each skip.  Kept to measure its
 *                   error (the exit-point max test is not conservative).
 *   OCLS_MAXMIP (3) as EXACT without the min early exit (Tevs et al. 2008).
 *   OCLS_DDA (4)    no hierarchy: walk every patch (Amanatides & Woo) with
 *                   EXACT's patch test; global-max early exit.
 * All methods leave the loop lit when the ray is at or above the global max
 * or leaves the map; with -D OCLS_CERT also when it reaches the distance
 * beyond which its tile's certificate proves it lit.
 *
 * Outputs (-D OCLS_OUT_MASK, OCLS_OUT_SELF, OCLS_OUT_COEF; an output not
 * defined is neither computed nor written, its argument may be a 1-byte
 * dummy buffer):
 *   mask  uchar: 1 = cast shadow, 0 = lit, 255 = nodata
 *   self  uchar: 1 = sun at or below the local tangent plane (normal from
 *         central differences, one-sided next to holes and edges), 0 = not,
 *         255 = nodata
 *   coef  float: paper 000 eq. (1) with n = up: 1 when lit, else
 *         k_dark + (k_bright - k_dark) * max(sin(elevation), 0); NaN = nodata
 *
 * ABI
 *   __kernel shadow_cells(h, H, W, origin, ext, lvl_off, nlev, ray, sunvec, cell,
 *                         kcoef, mode, mask, self, coef)
 *     __global const float  *h       H*W heights, NaN = nodata; the hosts pass them
 *                                    relative to the map's mid-range (subtracted in
 *                                    float64) to keep float32 precision: any offset
 *                                    works, the same one gives the same results
 *     int H, W
 *     int2 origin    (column, row) of h's first cell in the whole map h is a
 *                    window of; (0, 0) for a whole map.  Cell coordinates are
 *                    formed in the whole map (the ray of cell (i, j) starts at
 *                    x0 = j + origin.x, patch column pc is at pc + origin.x,
 *                    see make_cell_ray), buffers are indexed in the window: so
 *                    every float32 value a cell's patch tests compute is the
 *                    whole map's, and a window holding every patch that can
 *                    rise above the cell's ray (and, for self, its neighbours)
 *                    gives the whole map's outputs bit for bit (oclshade.tiles;
 *                    docs/scale.md "Exactness").  origin + (W, H) <= 2^30
 *     __global const float2 *ext     extrema pyramid levels 1..nlev-1 back to back
 *                                    (level 0 is the heightmap itself, see pyramid.cl)
 *     __global const int    *lvl_off offset (in float2) of level l in ext at [l], [0] unused
 *     int nlev                       number of levels counting level 0 (>= 2)
 *     float4 ray     (ux, uy, w, c) as above, each rounded to float32 with
 *                    subnormals flushed to 0; sin/cos exact at multiples of
 *                    90 degrees (oclshade/sun.py Sun.ray, C: oclshade_sun_for);
 *                    c the curvature drop per square metre, read only with
 *                    -D OCLS_CURVATURE (the hosts pass 0 otherwise);
 *                    ignored (the hosts pass 0s) when mode != 0
 *     float4 sunvec  unit vector to the sun (east, north, up, 0)
 *     float2 cell    (dx, dy) in metres
 *     float2 kcoef   (k_dark, k_bright)
 *     int mode       0 trace; 1 sun at the zenith, elevation >= 90 (nothing
 *                    cast); 2 sun at or below the horizon, elevation <= 0
 *                    (everything shadowed)
 *     __global uchar *mask, __global uchar *self, __global float *coef  (H*W
 *                    elements each; an output not compiled in may be a NULL
 *                    cl_mem or a 1-byte dummy buffer)
 *   -D OCLS_CERT adds __global const float *cert after coef (the certificates
 *   of this sun from shadow_certify, see below).
 *   -D OCLS_STATS adds a last argument __global uint *stats (nlev counters,
 *   zeroed by the host): traversal iterations per pyramid level, summed over
 *   all cells (for the benchmarks; off by default).
 *   global size (W, H) rounded up to the local size; any local size.
 *
 *   __kernel shadow_pixels(h, coarse, coarse_off, H, W, ext, lvl_off, nlev,
 *                          position, uv, uv_grad, width, height, ray, sunvec,
 *                          kcoef, mode, lod, flag, coef, lod_out)
 *     h, H, W, ext, lvl_off, nlev, ray, sunvec, kcoef, mode  as for shadow_cells
 *                                     (no origin: the G-buffer's uv are h's own
 *                                     coordinates, and the rays are formed
 *                                     relative to their start patch, see Ray)
 *     __global const float *coarse    level-q grids for q = 1..nlev-1 back to
 *                                     back, each (ceil(Hp/2^q)+1) x (ceil(Wp/2^q)+1)
 *                                     floats: the surface at the level-q tile
 *                                     corners (Hp, Wp = max(H-1,1), max(W-1,1));
 *                                     the host fills them from the mip pyramid
 *     __global const int *coarse_off  offset (in floats) of grid q at [q], [0] unused
 *     __global const float4 *position width*height, row-major; w > 0.5 = the pixel
 *                                     sees terrain (G-buffer layout, oclshade/gbuffer.py)
 *     __global const float2 *uv       heightmap coordinates (u = column, v = row)
 *     __global const float4 *uv_grad  (du/dc, dv/dc, du/dr, dv/dr) per pixel
 *     int width, height               pixels
 *     int4 lod   (force_q, bias, n_a_max, 0): force_q >= 0 replaces Algo 1
 *                (clamped to nlev-1); else q = Algo 1 (minimal_lod) + bias,
 *                clamped to [0, nlev-1]
 *     __global uchar *flag     1 = cast shadow, 0 = lit, 255 = empty (no hit,
 *                              uv off the map or in a hole)
 *     __global float *coef     eq. (1) as for shadow_cells; 1 on empty pixels
 *     __global uchar *lod_out  the level q used; 255 = empty
 *   Per pixel: the ray starts on the level-q surface at (u, v) / 2^q (bilinear,
 *   see pixel_ray) and is traced by trace() in the units of the level-q grid
 *   (ray.xy / 2^q, the same w): at q = 0 exactly the heightmap-space
 *   definition from a real start point (positions and heights relative to the
 *   start patch's corner and nearest sample, the first patches within one cell
 *   tested on f carried from the start: see Ray); at q > 0 the finest test is
 *   on the level-q grid (approximate: a smoothed surface), the hierarchy above
 *   it the extrema of the heightmap.  -D OCLS_STATS as for shadow_cells.
 *
 * Levels.  trace() runs on a base grid h of level q (the heightmap for q = 0,
 * a level-q grid of shadow_pixels otherwise), whose patches are the level-q
 * tiles; inside it levels are counted from q (tile size 2^(l-q) base
 * patches), the extrema texel of level l is ext level l indexed by base patch
 * >> (l - q), since ceil(ceil(n / 2^q) / 2^m) = ceil(n / 2^(q+m)).
 *
 * Build options: the -D options above and -cl-std=CL1.2, nothing else (no
 *   fast-math); the hosts paste common.h in place of its include (a build of
 *   your own may instead pass -I <this folder>).  The C host API
 *   (host/include/oclshade.h) does all of this for embedding users.
 */
#include "common.h"

#define OCLS_EXACT 1
#define OCLS_PAPER 2
#define OCLS_MAXMIP 3
#define OCLS_DDA 4
#ifndef OCLS_METHOD
#define OCLS_METHOD OCLS_EXACT
#endif
#define OCLS_MAX_ITERATIONS 1000000
#define OCLS_CORNER_EPS (4.0f * FLT_EPSILON)
#define OCLS_STATS_LEVELS 32

/* Earth curvature (-D OCLS_CURVATURE; see "Curvature" above): the ray's height
 * over the flat map z(t) = z0 + w t + c t^2, its slope at t and the curvature
 * of f = S - z; without the option the plain line, and c is never read. */
#ifdef OCLS_CURVATURE
#define OCLS_RAY_Z(z0, w, c, t) ((z0) + ((w) + (c) * (t)) * (t))
#define OCLS_RAY_SLOPE(w, c, t) ((w) + 2.0f * (c) * (t))
#define OCLS_BEND(s2, c) ((s2) - (c))
#else
#define OCLS_RAY_Z(z0, w, c, t) ((z0) + (w) * (t))
#define OCLS_RAY_SLOPE(w, c, t) (w)
#define OCLS_BEND(s2, c) (s2)
#endif

/* Direction signs of the sun ray (-1, 0, 1).  (Specialising builds per
 * direction octant with -D constants was measured: no gain on PoCL.) */
#define OCLS_SX(u) ((u) > 0.0f ? 1 : ((u) < 0.0f ? -1 : 0))
#define OCLS_SY(u) OCLS_SX(u)
/* Profiling (-D OCLS_STATS): each work-item counts its traversal iterations per
 * level in a private steps[] and adds them to the global counters at the end. */
#ifdef OCLS_STATS
#define OCLS_COUNT(l) (steps[l] += 1u)
#define OCLS_STEPS_BEGIN uint steps[OCLS_STATS_LEVELS]; \
    for (int l_ = 0; l_ < OCLS_STATS_LEVELS; ++l_) steps[l_] = 0u
#define OCLS_STEPS_END(n) for (int l_ = 0; l_ < (n); ++l_) \
    if (steps[l_]) atomic_add(&stats[l_], steps[l_])
#else
#define OCLS_COUNT(l) ((void)0)
#define OCLS_STEPS_BEGIN uint steps[1]
#define OCLS_STEPS_END(n) ((void)0)
#endif

/* A sun ray in the units of one level-q grid (see "Levels" above): it starts
 * at column xb + x0, row yb + y0 (any real point; integers for the cell
 * entry) at height hb + z0; ix, iy = 1/ux, 1/uy (0 when the ray does not move
 * along that axis); on_row / on_col: the ray runs exactly along a grid row /
 * column (it does not move along that axis and starts on the line), where it
 * sees the linear profile between the samples of that line.
 *
 * Bases (xb, yb, hb): every position is taken relative to the integer column
 * and row (xb, yb) and every height relative to hb before it meets the ray, so
 * rounding scales with the distance and the height differences the ray
 * actually travels, not with the map's coordinates or its relief.  A cell ray
 * has bases minus the window's origin (0 for a whole map: its operations are
 * then those of the plain formulas, bit for bit) and height base 0; a pixel
 * ray starts at a real point: bases its start patch's corner and the sample
 * nearest to it (pixel_ray).
 *
 * Near start (t < t_near, pixel rays only; cell rays have t_near = 0): the
 * first patches are tested on f(t) = S(t) - z(t) carried from patch to patch
 * in the relative form of the start patch's test (f(0) = 0, then f at each
 * exit from the slope and curvature of f along the segment), not from the
 * heights: a start a hair's breadth off a grid line would otherwise compare
 * two independently rounded heights (error a few ulps of them) at a distance
 * of a hair's breadth, and flip its verdict (the false shadows of issue 17).
 * t_near = one cell of the major axis: the ray crosses at most one grid line
 * of each axis before it, so at most 3 patches carry; beyond it heights are
 * compared directly (error divided by t >= one cell).  The traversal stays on
 * the finest level while near. */
typedef struct {
    float x0, y0, z0, ux, uy, w, c, ix, iy, hb, t_near;
    int xb, yb, on_row, on_col;
} Ray;

OCLS_INLINE Ray make_ray_based(int xb, int yb, float hb, float x0, float y0, float z0, float ux, float uy,
                               float w, float c, float t_near)
{
    Ray r;
    r.xb = xb; r.yb = yb; r.hb = hb; r.t_near = t_near;
    r.x0 = x0; r.y0 = y0; r.z0 = z0; r.ux = ux; r.uy = uy; r.w = w; r.c = c;
    r.ix = OCLS_SX(ux) != 0 ? 1.0f / ux : 0.0f;
    r.iy = OCLS_SY(uy) != 0 ? 1.0f / uy : 0.0f;
    r.on_row = OCLS_SY(uy) == 0 && y0 == (float)ocls_floor_int(y0);
    r.on_col = OCLS_SX(ux) == 0 && x0 == (float)ocls_floor_int(x0);
    return r;
}

/* The ray of cell (i, j) of a window whose first cell is (origin.y,
 * origin.x) in the whole map: bases -origin, so positions are the whole map's
 * columns and rows (x0 = j + origin.x, patch pc at pc + origin.x: every float32
 * value is the one the whole map computes for that cell, while buffers are
 * indexed in the window); height base 0, no near start; ray = (ux, uy, w, c). */
OCLS_INLINE Ray make_cell_ray(int i, int j, int2 origin, float z0, float4 ray)
{
    return make_ray_based(-origin.x, -origin.y, 0.0f, (float)(j + origin.x), (float)(i + origin.y), z0,
                          ray.x, ray.y, ray.z, ray.w, 0.0f);
}

/* Exact test of the ray against one patch (or grid-line segment) between ray
 * parameters t_in and t_out.  Returns 1 iff the surface rises strictly above
 * the ray on the segment.  first: the segment starts at the ray's origin,
 * where surface and ray meet: there f(t) = t (a + b t) and the test is on the
 * linear a + b t, which is exact even for t -> 0.  near: f(t_in) is *f (the
 * value carried from the previous patch, see Ray) instead of the heights'
 * difference, unless *f is NaN (after a hole).  *f gets f(t_out) (NaN in a
 * hole). */
OCLS_INLINE int patch_hits(OCLS_HEIGHTS h, int H, int W, int pr, int pc, const Ray *ray,
                           float t_in, float t_out, int first, int near, float *f)
{
    const float ux = ray->ux, uy = ray->uy, w = ray->w, hb = ray->hb;
    const float fx = (ray->x0 + ux * t_in) - (float)(pc - ray->xb);  /* local coords at entry */
    const float fy = (ray->y0 + uy * t_in) - (float)(pr - ray->yb);
    const float len = t_out - t_in;
    const float carried = *f;
    float s_a, s1, s2;
    *f = NAN;
    if (ray->on_row) {             /* along row yb + y0 */
        const int y0 = ray->yb + (int)ray->y0;
        const float a = ocls_sample(h, H, W, y0, pc), b = ocls_sample(h, H, W, y0, pc + 1);
        if (isnan(a) || isnan(b)) return 0;
        s_a = (a - hb) + (b - a) * fx;
        s1 = (b - a) * ux;
        s2 = 0.0f;
    } else if (ray->on_col) {      /* along column xb + x0 */
        const int x0 = ray->xb + (int)ray->x0;
        const float a = ocls_sample(h, H, W, pr, x0), b = ocls_sample(h, H, W, pr + 1, x0);
        if (isnan(a) || isnan(b)) return 0;
        s_a = (a - hb) + (b - a) * fy;
        s1 = (b - a) * uy;
        s2 = 0.0f;
    } else {
        float h00, h01, h10, h11;
        if (H > 1 && W > 1) {          /* every patch has its four samples: no bounds checks */
            h00 = OCLS_H_AT(h, W, pr, pc); h01 = OCLS_H_AT(h, W, pr, pc + 1);
            h10 = OCLS_H_AT(h, W, pr + 1, pc); h11 = OCLS_H_AT(h, W, pr + 1, pc + 1);
        } else {
            h00 = ocls_sample(h, H, W, pr, pc); h01 = ocls_sample(h, H, W, pr, pc + 1);
            h10 = ocls_sample(h, H, W, pr + 1, pc); h11 = ocls_sample(h, H, W, pr + 1, pc + 1);
        }
        if (isnan(h00) || isnan(h01) || isnan(h10) || isnan(h11)) return 0;
        const float ex = h01 - h00, ey = h10 - h00, k = (h00 - h01) - (h10 - h11);
        s_a = (h00 - hb) + ex * fx + ey * fy + k * (fx * fy);
        s1 = (ex + k * fy) * ux + (ey + k * fx) * uy;
        s2 = k * (ux * uy);
    }
    /* f(tau) = S(t_in + tau) - z(t_in + tau) = f_a + a tau + b tau^2, tau in [0, len] */
    const float a = s1 - OCLS_RAY_SLOPE(w, ray->c, t_in), b = OCLS_BEND(s2, ray->c);
    if (first) {
        *f = (a + b * len) * len;
        return (a > 0.0f) || (a + b * len > 0.0f);
    }
    const float f_a = near && !isnan(carried) ? carried : s_a - OCLS_RAY_Z(ray->z0, w, ray->c, t_in);
    if (f_a > 0.0f) return 1;
    const float f_b = f_a + (a + b * len) * len;
    *f = f_b;
    if (f_b > 0.0f) return 1;
    if (b < 0.0f) {
        const float tau = -a / (2.0f * b);
        if (tau > 0.0f && tau < len && f_a - (a * a) / (4.0f * b) > 0.0f) return 1;
    }
    return 0;
}

/* Algo 2: ray parameter at which the ray leaves the axis-aligned tile
 * [c0, c0+size] x [r0, r0+size] (cell units); *via_x / *via_y tell which
 * sides it leaves through (both at a corner).  Computed from the origin, not
 * incrementally, so error does not accumulate along the ray. */
OCLS_INLINE float tile_exit(const Ray *ray, int r0, int c0, int size, int *via_x, int *via_y)
{
    const float tx = OCLS_SX(ray->ux) != 0 ? ((float)((OCLS_SX(ray->ux) > 0 ? c0 + size : c0) - ray->xb) - ray->x0) * ray->ix
                                           : INFINITY;
    const float ty = OCLS_SY(ray->uy) != 0 ? ((float)((OCLS_SY(ray->uy) > 0 ? r0 + size : r0) - ray->yb) - ray->y0) * ray->iy
                                           : INFINITY;
    /* a ray through a patch corner within rounding is a corner pass (both
     * sides at once), so every device and the float64 reference agree on it */
    const int corner = OCLS_SX(ray->ux) != 0 && OCLS_SY(ray->uy) != 0 && fabs(tx - ty) <= OCLS_CORNER_EPS * fmax(tx, ty);
    *via_x = corner || tx < ty;
    *via_y = corner || ty < tx;
    return fmin(tx, ty);
}

/* Patch index (along one axis) the ray occupies just after parameter t,
 * clamped to [lo, hi]: floor for a forward step, ceil - 1 for a backward one
 * (p0 relative to the integer base). */
OCLS_INLINE int patch_along(int base, float p0, float u, int sign, float t, int lo, int hi)
{
    const float p = p0 + u * t;
    const int idx = base + (sign > 0 ? ocls_floor_int(p) : ocls_ceil_int(p) - 1);
    return clamp(idx, lo, hi);
}

/* Move (pr, pc) into the next tile after leaving the level-l tile at (r0, c0)
 * at parameter t. */
OCLS_INLINE void step_out(int *pr, int *pc, const Ray *ray, float t, int r0, int c0, int size,
                     int via_x, int via_y)
{
    if (via_x) *pc = OCLS_SX(ray->ux) > 0 ? c0 + size : c0 - 1;
    else if (OCLS_SX(ray->ux) != 0) *pc = patch_along(ray->xb, ray->x0, ray->ux, OCLS_SX(ray->ux), t, c0, c0 + size - 1);
    if (via_y) *pr = OCLS_SY(ray->uy) > 0 ? r0 + size : r0 - 1;
    else if (OCLS_SY(ray->uy) != 0) *pr = patch_along(ray->yb, ray->y0, ray->uy, OCLS_SY(ray->uy), t, r0, r0 + size - 1);
}

OCLS_INLINE int patch_valid(OCLS_HEIGHTS h, int H, int W, int pr, int pc)
{
    return !(isnan(ocls_sample(h, H, W, pr, pc)) || isnan(ocls_sample(h, H, W, pr, pc + 1)) ||
             isnan(ocls_sample(h, H, W, pr + 1, pc)) || isnan(ocls_sample(h, H, W, pr + 1, pc + 1)));
}

/* Corner pass out of a hole patch (pr, pc): the ray touches the two side
 * neighbours only at the corner sample; it occludes if a side neighbour is a
 * valid patch and the sample is above the ray (z, relative to the height hb). */
OCLS_INLINE int corner_hits(OCLS_HEIGHTS h, int H, int W, int pr, int pc, float ux, float uy,
                            float hb, float z)
{
    const int vr = OCLS_SY(uy) > 0 ? pr + 1 : pr, vc = OCLS_SX(ux) > 0 ? pc + 1 : pc;
    const int br = pr, bc = OCLS_SX(ux) > 0 ? pc + 1 : pc - 1;      /* east/west neighbour */
    const int cr = OCLS_SY(uy) > 0 ? pr + 1 : pr - 1, cc = pc;      /* south/north neighbour */
    const int Hp = max(H - 1, 1), Wp = max(W - 1, 1);
    const int b_ok = bc >= 0 && bc < Wp && patch_valid(h, H, W, br, bc);
    const int c_ok = cr >= 0 && cr < Hp && patch_valid(h, H, W, cr, cc);
    return (b_ok || c_ok) && ocls_sample(h, H, W, vr, vc) - hb > z;
}

/* Extrema of the level-l tile holding patch (pr, pc), both counted from the
 * base level q of the traversal (l = 0 is level q; Wp = patch columns at q). */
OCLS_INLINE float2 ext_at(OCLS_EXTREMA ext, __global const int *lvl_off, int q, int Wp, int l,
                          int pr, int pc)
{
    return OCLS_EXT_AT(ext, lvl_off, q + l, ocls_level_extent(Wp, l), pr >> l, pc >> l);
}

/* Start patch of the ray (the patch it enters from its origin, which may sit
 * on a grid line); returns 0 if the ray leaves the map at once.  For an
 * integer start (x0, y0) this is the patch west/east, north/south of the
 * sample in the ray's direction. */
OCLS_INLINE int start_patch(int H, int W, const Ray *ray, int *pr, int *pc)
{
    const int Hp = max(H - 1, 1), Wp = max(W - 1, 1);
    const int sx = OCLS_SX(ray->ux), sy = OCLS_SY(ray->uy);
    const int fc = ray->xb + ocls_floor_int(ray->x0), fr = ray->yb + ocls_floor_int(ray->y0);
    *pc = sx < 0 ? ray->xb + ocls_ceil_int(ray->x0) - 1 : (sx > 0 ? fc : min(fc, Wp - 1));
    *pr = sy < 0 ? ray->yb + ocls_ceil_int(ray->y0) - 1 : (sy > 0 ? fr : min(fr, Hp - 1));
    return *pc >= 0 && *pc < Wp && *pr >= 0 && *pr < Hp;
}

/* trace(): 1 iff the ray is in cast shadow.  h (H x W) is the level-q grid
 * the finest test uses (q = 0: the heightmap; the ray in its units); levels
 * q+1 .. nlev-1 of the extrema pyramid are the hierarchy above it; z_top the
 * global max.  Levels inside are counted from q. */
#if OCLS_METHOD == OCLS_PAPER
/* Algo 3 as printed in paper 000. */
OCLS_INLINE int trace(OCLS_HEIGHTS h, int H, int W, OCLS_EXTREMA ext,
                      __global const int *lvl_off, int nlev, int q, float z_top, float t_lim,
                      const Ray *ray, uint *steps)
{
    const int Hp = max(H - 1, 1), Wp = max(W - 1, 1), top = nlev - 1 - q;
    const float x0 = ray->x0, y0 = ray->y0, z0 = ray->z0, ux = ray->ux, uy = ray->uy, w = ray->w, hb = ray->hb;
    const float c = ray->c;
    int pr, pc, via_x, via_y;
    if (!start_patch(H, W, ray, &pr, &pc)) return 0;
    /* initialisation: leave the start texel */
    float t = tile_exit(ray, pr, pc, 1, &via_x, &via_y);
    step_out(&pr, &pc, ray, t, pr, pc, 1, via_x, via_y);
    int l = 0;
    for (int it = 0; it < OCLS_MAX_ITERATIONS; ++it) {
        if (pr < 0 || pr >= Hp || pc < 0 || pc >= Wp) return 0;
        OCLS_COUNT(q + l);
        const int size = 1 << l, r0 = (pr >> l) << l, c0 = (pc >> l) << l;
        const float t_out = tile_exit(ray, r0, c0, size, &via_x, &via_y);
        const float z_out = OCLS_RAY_Z(z0, w, c, t_out);
        const float2 e = l > 0 ? ext_at(ext, lvl_off, q, Wp, l, pr, pc) : (float2)(0.0f, 0.0f);
        if (l > 0 && e.y - hb >= z_out) return 1;     /* min test at the exit point */
        int reaches;
        if (l == 0) {                                  /* bilinear height at P_s */
            const float tm = 0.5f * (t + t_out);
            const float fx = (x0 + ux * tm) - (float)(pc - ray->xb), fy = (y0 + uy * tm) - (float)(pr - ray->yb);
            const float h00 = ocls_sample(h, H, W, pr, pc), h01 = ocls_sample(h, H, W, pr, pc + 1);
            const float h10 = ocls_sample(h, H, W, pr + 1, pc), h11 = ocls_sample(h, H, W, pr + 1, pc + 1);
            const float hs = (h00 * (1.0f - fx) + h01 * fx) * (1.0f - fy) + (h10 * (1.0f - fx) + h11 * fx) * fy;
            reaches = hs - hb >= OCLS_RAY_Z(z0, w, c, tm);  /* NaN (hole) compares false */
        } else {
            reaches = e.x - hb >= z_out;               /* max test at the exit point */
        }
        if (reaches) {
            if (l == 0) return 1;
            l -= 1;
        } else {
            step_out(&pr, &pc, ray, t_out, r0, c0, size, via_x, via_y);
            t = t_out;
            l = top;                                   /* restart from the coarsest level */
        }
    }
    return 0;
}
#else
/* EXACT / MAXMIP / DDA: conservative multilevel traversal with climbing. */
OCLS_INLINE int trace(OCLS_HEIGHTS h, int H, int W, OCLS_EXTREMA ext,
                      __global const int *lvl_off, int nlev, int q, float z_top, float t_lim,
                      const Ray *ray, uint *steps)
{
    const int Hp = max(H - 1, 1), Wp = max(W - 1, 1), top = nlev - 1 - q;
    const float z0 = ray->z0, w = ray->w, c = ray->c, hb = ray->hb, z_max = z_top - hb;
    int pr, pc, via_x, via_y;
    if (!start_patch(H, W, ray, &pr, &pc)) return 0;
    float t = 0.0f, f = 0.0f;                          /* f: f(t) carried while near (see Ray) */
    int l = 0;
    for (int it = 0; it < OCLS_MAX_ITERATIONS; ++it) {
        OCLS_COUNT(q + l);
        const int size = 1 << l, r0 = (pr >> l) << l, c0 = (pc >> l) << l;
        const float t_out = tile_exit(ray, r0, c0, size, &via_x, &via_y);
        const float z_in = OCLS_RAY_Z(z0, w, c, t);    /* lowest ray point in the tile (z rises) */
        const int near = t < ray->t_near;
        if (!near && z_in >= z_max) return 0;          /* (near: f is carried, see Ray) */
#ifdef OCLS_CERT
        if (t >= t_lim) return 0;                      /* the tile certificate covers the rest */
#endif
#if OCLS_METHOD == OCLS_DDA
        if (patch_hits(h, H, W, pr, pc, ray, t, t_out, t == 0.0f, near, &f)) return 1;
        if (via_x && via_y && !patch_valid(h, H, W, pr, pc) &&
            corner_hits(h, H, W, pr, pc, ray->ux, ray->uy, hb, OCLS_RAY_Z(z0, w, c, t_out))) return 1;
#else
        if (l > 0) {
            const float2 e = ext_at(ext, lvl_off, q, Wp, l, pr, pc);
            if (z_in < e.x - hb) {                     /* the tile may reach the ray */
#if OCLS_METHOD == OCLS_EXACT
                /* min early exit (Algo 3).  Provably inert at q = 0: the ray
                 * enters this tile at a point P of its boundary where the
                 * previous tile (skipped by a conservative max test, or tested
                 * exactly on a closed segment) showed S(P) <= z, and min <=
                 * S(P), so z_out < min never holds.  It can fire where earlier
                 * tests are approximate: per-pixel rays at q > 0, whose finest
                 * test is on the smoother mip surface while the extrema bound
                 * the heightmap (a valley floor below a cliff tile). */
                if (OCLS_RAY_Z(z0, w, c, t_out) < e.y - hb) return 1;
#endif
                l -= 1;                                /* descend; (pr, pc) stays inside */
                continue;
            }
        } else {                                       /* level q: the finest test */
            if (patch_hits(h, H, W, pr, pc, ray, t, t_out, t == 0.0f, near, &f)) return 1;
            if (via_x && via_y && !patch_valid(h, H, W, pr, pc) &&
                corner_hits(h, H, W, pr, pc, ray->ux, ray->uy, hb, OCLS_RAY_Z(z0, w, c, t_out))) return 1;
        }
#endif
        const int opr = pr, opc = pc;
        step_out(&pr, &pc, ray, t_out, r0, c0, size, via_x, via_y);
        t = t_out;
        if (pr < 0 || pr >= Hp || pc < 0 || pc >= Wp) return 0;
#if OCLS_METHOD != OCLS_DDA
        /* climb one level if the ray has just entered that level's tile too (not while near) */
        const int diff = (pr ^ opr) | (pc ^ opc);
        l = t_out < ray->t_near ? 0 : min(min(31 - (int)clz(diff), top), l + 1);
#endif
    }
    return 0;
}
#endif

/* ------------------------------------------------------------- sun tables
 * -D OCLS_SUN_TABLE (shadow_cells, shadow_cells_packet, shadow_certify): each
 * cell takes its sun from a table instead of the ray / sunvec / mode
 * arguments (which stay in the ABI, unread).  A map whose sun varies over it
 * (oclshade/sun.py SunField: rectangles of cells, each traced with its own
 * sun) is then traced in one launch instead of one launch per rectangle.  The
 * blocks form a grid of row bands and column bands (the host cuts any tiling
 * into one), and cell (i, j) is in block
 *     b = band[i] + band[H + j],
 * band[i] being the row band of row i times the number of column bands and
 * band[H + j] the column band of column j.  Block b's ray and sun vector are
 * sun_table[2 b] and sun_table[2 b + 1] (as the ray and sunvec arguments),
 * its mode sun_mode[b].  Extra arguments after cert (before stats):
 *     __global const int    *band       H + W ints
 *     __global const float4 *sun_table  2 per block
 *     __global const int    *sun_mode   1 per block
 * shadow_certify takes them after cert: it makes a tile's certificates for
 * the block holding the tile's first cell (row tr s, column tc s; nothing
 * when that block's mode is not 0), and a cell uses them only when it lies in
 * that block (cert_owned); other cells trace their rays in full, with the
 * same results (certificates only end provably lit rays early).  A packet
 * run must not cross a column band: the host makes OCLS_PACKET divide every
 * band's first column. */
#ifdef OCLS_SUN_TABLE
#define OCLS_SUN_PARAMS , __global const int *band, __global const float4 *sun_table, __global const int *sun_mode
#define OCLS_SUN_ARG(name) name##_unread
#define OCLS_BAND band
/* the sun of cell (i, j): declares ray, sunvec and mode */
#define OCLS_TABLE_SUN(i, j) \
    const int block_ = band[i] + band[H + (j)]; \
    const float4 ray = sun_table[2 * block_], sunvec = sun_table[2 * block_ + 1]; \
    const int mode = sun_mode[block_]
#else
#define OCLS_SUN_PARAMS
#define OCLS_SUN_ARG(name) name
#define OCLS_BAND 0
#define OCLS_TABLE_SUN(i, j) (void)0
#endif

/* ------------------------------------------------- far-field certificates
 * -D OCLS_CERT=s (a power of two >= 2; EXACT and MAXMIP only): one
 * certificate per s x s tile of cells, computed per sun by shadow_certify and
 * read by shadow_cells.  The rays of a tile's cells start in the box
 * B = [c0, c0+s-1] x [r0, r0+s-1] (clipped to the map) and at distance t
 * lie in B + t (ux, uy).  For the thresholds d_k = OCLS_CERT_D0 * 2^k
 * major-axis cells (k < OCLS_CERT_K; major = the larger of |ux|, |uy|, so
 * t_k = d_k / major), cert[k] bounds from above
 *     sup { S(p) - w t : t >= t_k, p in B + t (ux, uy) inside the map }
 * S being the bilinear surface: the ray's path from t_k on is cut into
 * segments (OCLS_CERT_SUB per octave [d, 2d]); the box swept over a segment
 * [ta, tb] has a bounding box whose surface max is at most the max of the
 * extrema texels covering it (at the finest level l >= 1 where it spans at
 * most OCLS_CERT_SPAN texels per axis), and S - w t <= that max - w ta there.  The march stops
 * when the box has left the map (outside it nothing occludes) or when
 * z_top - w ta falls to the tile's min (that value bounds everything beyond
 * and is folded in), so the bound holds for every t >= t_k.  Each value
 * carries a float32 margin of 64 eps (|max| + w tb).  A cell with height
 * z0 > cert[k] is therefore lit for every t >= t_k in exact arithmetic (the
 * float64 reference agrees up to its ties), and its trace only needs
 * t < t_k (times 1.001, so float rounding of the traversal's t cannot open a
 * gap).  The certificate is exact (it only skips provably lit parts of rays);
 * cells of tiles that can neither cast nor receive a shadow stop at once.
 *
 *   __kernel shadow_certify(H, W, origin, ext, lvl_off, nlev, ray, cert)
 *     H, W, origin, ext, lvl_off, nlev, ray as for shadow_cells (mode 0 only:
 *     the host does not launch it otherwise; the boxes B + t (ux, uy) are
 *     formed in the whole map's coordinates, then indexed in the window)
 *     __global float *cert   ceil(H/s) * ceil(W/s) * OCLS_CERT_K floats,
 *                            tile (tr, tc) at (tr * ceil(W/s) + tc) * K
 *   global size (ceil(W/s), ceil(H/s)) rounded up to any local size.
 *   Tuning defines (defaults measured on Puget Sound 4096^2 at 20 degrees,
 *   bench/results/shadow_masks.md): OCLS_CERT_K = 6 thresholds, OCLS_CERT_D0
 *   = 2 cells, OCLS_CERT_SUB = 4 segments per octave, OCLS_CERT_SPAN = 5;
 *   the hosts use s = 16.
 * shadow_cells then takes cert as an extra argument after coef (before
 * stats).  Without -D OCLS_CERT neither the kernel nor the argument exists. */
#ifdef OCLS_CERT
#ifndef OCLS_CERT_K
#define OCLS_CERT_K 6
#endif
#ifndef OCLS_CERT_D0
#define OCLS_CERT_D0 2
#endif
#ifndef OCLS_CERT_SUB
#define OCLS_CERT_SUB 4
#endif
#ifndef OCLS_CERT_SPAN
#define OCLS_CERT_SPAN 5
#endif

__kernel void shadow_certify(const int H, const int W, const int2 origin, OCLS_EXTREMA ext,
                             __global const int *lvl_off, const int nlev, const float4 OCLS_SUN_ARG(ray),
                             __global float *cert OCLS_SUN_PARAMS)
{
    const int s = OCLS_CERT, nc = (W + s - 1) / s, nr = (H + s - 1) / s;
    const int tc = get_global_id(0), tr = get_global_id(1);
    if (tc >= nc || tr >= nr) return;
#ifdef OCLS_SUN_TABLE
    /* the sun of the block holding the tile's first cell (only its cells use these) */
    const int block = band[tr * s] + band[H + tc * s];
    if (sun_mode[block] != 0) return;
    const float4 ray = sun_table[2 * block];
#endif
    const int Hp = max(H - 1, 1), Wp = max(W - 1, 1), top = nlev - 1;
    const float ux = ray.x, uy = ray.y, w = ray.z, major = fmax(fabs(ux), fabs(uy));
    const float z_top = ext_at(ext, lvl_off, 0, Wp, top, 0, 0).x;
    /* the box in the whole map's columns and rows (origin: the window's first cell) */
    const float bx0 = (float)(tc * s + origin.x), bx1 = (float)(min(tc * s + s - 1, W - 1) + origin.x);
    const float by0 = (float)(tr * s + origin.y), by1 = (float)(min(tr * s + s - 1, H - 1) + origin.y);
    const float bx_org = (float)origin.x, by_org = (float)origin.y;
    const float x_end = (float)(W - 1 + origin.x), y_end = (float)(H - 1 + origin.y);
    /* a lower bound of the tile's heights: the min of its level-log2(s) texel
     * (patches [c0, c0+s-1] cover the tile's samples) */
    const int ls = min(31 - (int)clz(s), top);
    const float zmin = ext_at(ext, lvl_off, 0, Wp, ls, min(tr * s, Hp - 1), min(tc * s, Wp - 1)).y;
    float hk[OCLS_CERT_K];
    for (int k = 0; k < OCLS_CERT_K; ++k) hk[k] = -INFINITY;
    for (int o = 0; o < 31; ++o) {                     /* octaves [d, 2d] */
        const float d = (float)OCLS_CERT_D0 * (float)(1u << o), seg = d / (float)OCLS_CERT_SUB;
        for (int j = 0; j < OCLS_CERT_SUB; ++j) {
            const float ta = (d + seg * (float)j) / major, tb = (d + seg * (float)(j + 1)) / major;
            const float tail = z_top - w * ta;         /* bounds S - w t for all t >= ta */
            const float mt = 64.0f * FLT_EPSILON * (fabs(z_top) + w * tb);
            if (!(tail + mt > zmin)) {                 /* nothing beyond can matter */
                for (int k = 0; k < OCLS_CERT_K; ++k) hk[k] = fmax(hk[k], tail + mt);
                o = 31;
                break;
            }
            const float xa = fmin(ux * ta, ux * tb), xb = fmax(ux * ta, ux * tb);
            const float ya = fmin(uy * ta, uy * tb), yb = fmax(uy * ta, uy * tb);
            const float x_lo = bx0 + xa, x_hi = bx1 + xb, y_lo = by0 + ya, y_hi = by1 + yb;
            if (x_hi < bx_org || x_lo > x_end || y_hi < by_org || y_lo > y_end) {
                o = 31;                                /* the box has left the map for good */
                break;
            }
            const int c_lo = clamp(ocls_floor_int(x_lo) - origin.x, 0, Wp - 1);
            const int c_hi = clamp(ocls_floor_int(x_hi) - origin.x, 0, Wp - 1);
            const int r_lo = clamp(ocls_floor_int(y_lo) - origin.y, 0, Hp - 1);
            const int r_hi = clamp(ocls_floor_int(y_hi) - origin.y, 0, Hp - 1);
            int l = 1;
            while (l < top && ((c_hi >> l) - (c_lo >> l) >= OCLS_CERT_SPAN || (r_hi >> l) - (r_lo >> l) >= OCLS_CERT_SPAN)) ++l;
            float zmax = -INFINITY;
            for (int r = r_lo >> l; r <= r_hi >> l; ++r)
                for (int c = c_lo >> l; c <= c_hi >> l; ++c)
                    zmax = fmax(zmax, ext_at(ext, lvl_off, 0, Wp, l, r << l, c << l).x);
            const float v = zmax - w * ta + 64.0f * FLT_EPSILON * (fabs(zmax) + w * tb);
            for (int k = 0; k < OCLS_CERT_K; ++k)
                if (d >= (float)OCLS_CERT_D0 * (float)(1u << k)) hk[k] = fmax(hk[k], v);
        }
    }
    __global float *out = cert + (tr * nc + tc) * OCLS_CERT_K;
    for (int k = 0; k < OCLS_CERT_K; ++k) out[k] = hk[k];
}

/* t_k times 1.001: the traversal limit of a cell that clears certificate k. */
OCLS_INLINE float cert_distance(int k, float4 ray)
{
    return 1.001f * ((float)OCLS_CERT_D0 * (float)(1u << k) / fmax(fabs(ray.x), fabs(ray.y)));
}

/* Whether cell (i, j) may use its tile's certificates: always with one sun;
 * with a sun table (band, else 0) when the tile's first cell lies in the
 * cell's block, whose sun they were made for. */
OCLS_INLINE int cert_owned(__global const int *band, int H, int i, int j)
{
    return !band || (band[i / OCLS_CERT * OCLS_CERT] == band[i] && band[H + j / OCLS_CERT * OCLS_CERT] == band[H + j]);
}

/* The least k whose certificate cell (i, j) of height z0 clears, OCLS_CERT_K if none. */
OCLS_INLINE int cert_index(__global const float *cert, int W, int i, int j, float z0)
{
    const int nc = (W + OCLS_CERT - 1) / OCLS_CERT;
    __global const float *c = cert + ((i / OCLS_CERT) * nc + j / OCLS_CERT) * OCLS_CERT_K;
    int k = 0;
    while (k < OCLS_CERT_K && !(z0 > c[k])) ++k;
    return k;
}

/* The traversal limit of cell (i, j) of height z0: t_k (times 1.001) for the
 * least k whose certificate it clears (and owns, cert_owned), else infinity. */
OCLS_INLINE float cert_limit(__global const float *cert, __global const int *band, int H, int W, int i, int j,
                             float z0, float4 ray)
{
    if (!cert_owned(band, H, i, j)) return INFINITY;
    const int k = cert_index(cert, W, i, j, z0);
    return k < OCLS_CERT_K ? cert_distance(k, ray) : INFINITY;
}
#else
#define cert_limit(cert, band, H, W, i, j, z0, ray) INFINITY
#endif

/* Self-shadow: sun at or below the tangent plane of the central-difference
 * normal (one-sided next to holes and at the edges, 0 slope if neither;
 * ocls_gradient in common.h). */
OCLS_INLINE int self_shadowed(OCLS_HEIGHTS h, int H, int W, int i, int j, float2 cell, float4 s)
{
    const float2 g = ocls_gradient(h, H, W, i, j, cell);   /* dz/d(east), dz/d(south) */
    /* n ~ (-dz/dE, -dz/dN, 1) with dz/dN = -gy */
    return (s.z - g.x * s.x + g.y * s.y) <= 0.0f;
}

/* Cast shadow of cell (i, j) of height z0 (not nodata) by the scalar traversal. */
OCLS_INLINE int cell_shadow(OCLS_HEIGHTS h, int H, int W, int2 origin, OCLS_EXTREMA ext,
                            __global const int *lvl_off, int nlev, float4 ray, int mode,
                            __global const float *cert, __global const int *band, int i, int j, float z0,
                            uint *steps)
{
    if (mode != 0) return mode == 2;
    const Ray r = make_cell_ray(i, j, origin, z0, ray);
    return trace(h, H, W, ext, lvl_off, nlev, 0, ext_at(ext, lvl_off, 0, max(W - 1, 1), nlev - 1, 0, 0).x,
                 cert_limit(cert, band, H, W, i, j, z0, ray), &r, steps);
}

/* The outputs of cell (i, j) from its cast-shadow flag (ignored for nodata). */
OCLS_INLINE void write_cell(OCLS_HEIGHTS h, int H, int W, int i, int j, int shadow, int mode,
                            float4 sunvec, float2 cell, float2 kcoef,
                            __global uchar *mask, __global uchar *self, __global float *coef)
{
    const int idx = i * W + j;
    const int nodata = isnan(OCLS_H_AT(h, W, i, j));
#ifdef OCLS_OUT_MASK
    mask[idx] = nodata ? (uchar)255 : (uchar)shadow;
#endif
#ifdef OCLS_OUT_SELF
    self[idx] = nodata ? (uchar)255
              : (uchar)(mode == 2 ? 1 : (mode == 1 ? 0 : self_shadowed(h, H, W, i, j, cell, sunvec)));
#endif
#ifdef OCLS_OUT_COEF
    coef[idx] = nodata ? NAN
              : (shadow ? kcoef.x + (kcoef.y - kcoef.x) * fmax(sunvec.z, 0.0f) : 1.0f);
#endif
}

/* the certificate argument of the kernels below (a null pointer without -D
 * OCLS_CERT), and their common parameters (see ABI) */
#ifdef OCLS_CERT
#define OCLS_CERT_BUF cert
#define OCLS_CERT_PARAM , __global const float *cert
#else
#define OCLS_CERT_BUF 0
#define OCLS_CERT_PARAM
#endif
#define OCLS_CELLS_PARAMS \
    OCLS_HEIGHTS h, const int H, const int W, const int2 origin, OCLS_EXTREMA ext, \
    __global const int *lvl_off, const int nlev, const float4 OCLS_SUN_ARG(ray), \
    const float4 OCLS_SUN_ARG(sunvec), const float2 cell, const float2 kcoef, const int OCLS_SUN_ARG(mode), \
    __global uchar *mask, __global uchar *self, __global float *coef OCLS_CERT_PARAM OCLS_SUN_PARAMS

__kernel void shadow_cells(OCLS_CELLS_PARAMS
#ifdef OCLS_STATS
                           , __global uint *stats
#endif
                           )
{
    OCLS_STEPS_BEGIN;
    const int j = get_global_id(0), i = get_global_id(1);
    if (j >= W || i >= H) return;
    OCLS_TABLE_SUN(i, j);
    const float z0 = OCLS_H_AT(h, W, i, j);
    int shadow = 0;
#if defined(OCLS_OUT_MASK) || defined(OCLS_OUT_COEF)
    if (!isnan(z0)) shadow = cell_shadow(h, H, W, origin, ext, lvl_off, nlev, ray, mode, OCLS_CERT_BUF, OCLS_BAND,
                                         i, j, z0, steps);
#endif
    OCLS_STEPS_END(nlev);
    write_cell(h, H, W, i, j, shadow, mode, sunvec, cell, kcoef, mask, self, coef);
}

/* ------------------------------------------------------ ray packets (CPU)
 * shadow_cells_packet (EXACT and MAXMIP): the outputs of shadow_cells, bit
 * for bit, faster on CPU devices.  PoCL vectorises the work-item loop only
 * around straight-line code, so shadow_cells runs one ray at a time on
 * scalar code.  Here one work-item traces a run of OCLS_RUN cells of a row
 * with OCLS_LANES rays in flight, one per lane of float / int vectors
 * (ocls_floatv / ocls_intv; 8 lanes fill an AVX2 register, 16 an AVX-512
 * one): a lane holds one ray in trace()'s state (t, level,
 * patch); one lockstep iteration takes one traversal step on every lane (the
 * extrema test of its tile and the patch test are both computed, from
 * gathered loads, and blended by lane masks into the descent, the step out
 * and climb, or the end of the ray); a lane whose ray has ended takes the
 * run's next cell at once, so lanes stay busy until the run's last rays
 * (96 % of lane-steps did work on Puget Sound 4096^2, measured with 8 lanes
 * and runs of 256).  Each ray's first iteration (level 0, its start patch,
 * t = 0) is straight-line code over contiguous heights: first_steps runs it
 * for OCLS_LANES cells at a time before their rays enter the packet, where only the
 * rays it does not end go (on Puget Sound, sun 37/20, 3.5 M of the 4.0 M
 * shadowed cells end there; 13 % fewer packet iterations).  Per lane the
 * operations are trace()'s (EXACT / MAXMIP branch) in the same order, in
 * float32 without contraction, so the results are the scalar kernel's.  The
 * rare cases run the scalar code: rays along a grid axis (ux == 0 or
 * uy == 0), maps one sample wide or high, modes 1 and 2, and a lane passing a
 * patch corner out of a hole (corner_hits).  On GPUs shadow_cells is the
 * kernel to use (there the hardware runs work-items in lockstep already).
 *
 *   __kernel shadow_cells_packet(...)  built with -D OCLS_PACKET=run (cells
 *     per work-item, a multiple of the lane count), -D OCLS_LANES=4, 8 or 16
 *     (rays in flight; 16 when not given), EXACT or MAXMIP, without
 *     -D OCLS_STATS, and -D OCLS_CERT a multiple of the lane count if given;
 *     the arguments of shadow_cells (with -D OCLS_CERT the certificate buffer;
 *     the origin forms the lanes' coordinates as make_cell_ray does)
 *   global size (ceil(W / run), H) rounded up to any local size.
 *   The hosts take run and lanes from the device's tuning entry
 *   (oclshade.tuning); the results never depend on them. */
#if defined(OCLS_PACKET) && (OCLS_METHOD == OCLS_EXACT || OCLS_METHOD == OCLS_MAXMIP) && !defined(OCLS_STATS)
#ifdef OCLS_IMAGES
#error "OCLS_IMAGES is for the one-ray kernel: the packets read buffers (do not define both)"
#endif
#define OCLS_RUN OCLS_PACKET
#ifndef OCLS_LANES
#define OCLS_LANES 16
#endif
#if OCLS_LANES != 4 && OCLS_LANES != 8 && OCLS_LANES != 16
#error "OCLS_LANES must be 4, 8 or 16"
#endif
#if OCLS_RUN % OCLS_LANES != 0 || (defined(OCLS_CERT) && OCLS_CERT % OCLS_LANES != 0)
#error "OCLS_PACKET and OCLS_CERT must be multiples of OCLS_LANES (a chunk of lanes lies in one certificate tile)"
#endif

/* the lane vector types and their built-ins, OCLS_LANES wide (common.h) */
#define ocls_floatv OCLS_CAT(float, OCLS_LANES)
#define ocls_intv OCLS_CAT(int, OCLS_LANES)
#define OCLS_CONVERT_FLOAT(x) OCLS_CONVERT_TO(ocls_floatv, x)
#define OCLS_CONVERT_INT(x) OCLS_CONVERT_TO(ocls_intv, x)
#define OCLS_VLOAD OCLS_LANE_FN(vload, OCLS_LANES)
#define OCLS_VSTORE OCLS_LANE_FN(vstore, OCLS_LANES)

/* start_patch's column for the ray of cell column j (an integer start) */
OCLS_INLINE int start_col(int j, int east) { return east ? j : j - 1; }

/* base[idx] on the lanes, and the lane numbers 0 .. OCLS_LANES - 1.  LLVM 15 (Debian's PoCL
 * 3.1) turns the lane-by-lane reads into gather instructions, LLVM 14 (the PyPI wheel) does
 * not: -D OCLS_HW_GATHER asks for AVX-512's gathers by name (x86 clang built-ins; the
 * global pointer goes through an integer because the built-ins take a private one, and CPU
 * devices have one address space).  Measured 1.19x faster on the packet kernel with the wheel
 * on a Rocket Lake Xeon (docs/tuning.md). */
#define OCLS_G4(base, idx, a, b, c, d) (base)[(idx).a], (base)[(idx).b], (base)[(idx).c], (base)[(idx).d]
#if OCLS_LANES == 4
#define OCLS_GATHER(T, base, idx) (T)(OCLS_G4(base, idx, s0, s1, s2, s3))
#define OCLS_LANE_IDS ((ocls_intv)(0, 1, 2, 3))
#elif OCLS_LANES == 8
#define OCLS_GATHER(T, base, idx) (T)(OCLS_G4(base, idx, s0, s1, s2, s3), OCLS_G4(base, idx, s4, s5, s6, s7))
#define OCLS_LANE_IDS ((ocls_intv)(0, 1, 2, 3, 4, 5, 6, 7))
#else
#if defined(OCLS_HW_GATHER) && defined(__AVX512F__) && defined(__clang__)
OCLS_OVL float16 ocls_gather(__global const float *base, int16 idx)
{ return __builtin_ia32_gathersiv16sf((float16)(0.0f), (const void *)(size_t)base, idx, (ushort)0xffff, 4); }
OCLS_OVL int16 ocls_gather(__global const int *base, int16 idx)
{ return __builtin_ia32_gathersiv16si((int16)(0), (const void *)(size_t)base, idx, (ushort)0xffff, 4); }
#define OCLS_GATHER(T, base, idx) ocls_gather(base, idx)   /* the overload of base's type is T */
#else
#define OCLS_GATHER(T, base, idx) \
    (T)(OCLS_G4(base, idx, s0, s1, s2, s3), OCLS_G4(base, idx, s4, s5, s6, s7), \
        OCLS_G4(base, idx, s8, s9, sa, sb), OCLS_G4(base, idx, sc, sd, se, sf))
#endif
#define OCLS_LANE_IDS ((ocls_intv)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#endif

/* floor / ceil of float lanes as ints (ocls_floor_int / ocls_ceil_int; a true
 * comparison is -1) */
#define OCLS_FLOORV(p, i) ((i) + (OCLS_CONVERT_FLOAT(i) > (p)))
#define OCLS_CEILV(p, i) ((i) - (OCLS_CONVERT_FLOAT(i) < (p)))

/* Bit k set iff lane k of the mask m is true. */
OCLS_INLINE int lane_bits(ocls_intv m)
{
    int bits = 0;
    int v[OCLS_LANES];
    OCLS_VSTORE(m, 0, v);
    for (int k = 0; k < OCLS_LANES; ++k) bits |= (v[k] & 1) << k;
    return bits;
}

/* row[col0 + k], k = 0..OCLS_LANES-1, NaN where the column is outside [0, W) */
OCLS_INLINE ocls_floatv row_lanes(__global const float *row, int col0, int W)
{
    if (col0 >= 0 && col0 + OCLS_LANES <= W) return OCLS_VLOAD(0, row + col0);
    float v[OCLS_LANES];
    for (int k = 0; k < OCLS_LANES; ++k) v[k] = col0 + k >= 0 && col0 + k < W ? row[col0 + k] : NAN;
    return OCLS_VLOAD(0, v);
}

/* The rays of a packet: OCLS_LANES lanes of trace()'s state (EXACT / MAXMIP), all in
 * the cell units of the heightmap (q = 0), in row y0 = i (mode 0, ux != 0,
 * uy != 0, H, W > 1). */
typedef struct {
    ocls_floatv x0, z0, t, t_lim;     /* start column and height, ray parameter, certificate limit */
    ocls_intv pr, pc, l, it;          /* patch, level, iterations done */
} Packet;

/* One iteration of trace()'s loop on the lanes in act, from the extrema
 * (emax, emin) of each lane's level-l tile (levels >= 1) and the corners
 * h00 .. h11 of its patch (level 0): returns the lanes whose ray ends, with
 * *shadow their result (-1 = cast shadow); the others descend, or step out
 * and climb (their state updated in *p). */
OCLS_INLINE ocls_intv packet_step(__global const float *h, int H, int W, int2 origin, float4 ray, float y0, float z_top,
                              int top, ocls_intv act, Packet *p, ocls_floatv emax, ocls_floatv emin, ocls_floatv h00,
                              ocls_floatv h01, ocls_floatv h10, ocls_floatv h11, ocls_intv *shadow_out)
{
    const int Hp = H - 1, Wp = W - 1;
    const float ux = ray.x, uy = ray.y, w = ray.z, c = ray.w, ix = 1.0f / ux, iy = 1.0f / uy;
    const int east = ux > 0.0f, south = uy > 0.0f;
    const ocls_floatv X0 = p->x0, Z0 = p->z0, T = p->t;
    const ocls_intv PR = p->pr, PC = p->pc, L = p->l;
    /* tile_exit of the level-L tile */
    const ocls_intv size = (ocls_intv)(1) << L, r0 = (PR >> L) << L, c0 = (PC >> L) << L;
    const ocls_floatv tx = (OCLS_CONVERT_FLOAT((east ? c0 + size : c0) + origin.x) - X0) * ix;
    const ocls_floatv ty = (OCLS_CONVERT_FLOAT((south ? r0 + size : r0) + origin.y) - y0) * iy;
    const ocls_intv corner = fabs(tx - ty) <= OCLS_CORNER_EPS * fmax(tx, ty);
    const ocls_intv via_x = corner | (tx < ty), via_y = corner | (ty < tx);
    const ocls_floatv t_out = fmin(tx, ty);
    /* lit: above the global max, past the certificate's limit, or out of iterations */
    const ocls_floatv z_in = OCLS_RAY_Z(Z0, w, c, T), z_out = OCLS_RAY_Z(Z0, w, c, t_out);
    ocls_intv lit = (z_in >= z_top) | (p->it >= OCLS_MAX_ITERATIONS);
#ifdef OCLS_CERT
    lit |= T >= p->t_lim;
#endif
    /* levels >= 1: the extrema test */
    const ocls_intv reach = (L > 0) & (z_in < emax);
#if OCLS_METHOD == OCLS_EXACT
    const ocls_intv min_hit = reach & (z_out < emin);
#else
    const ocls_intv min_hit = (ocls_intv)(0);
#endif
    /* level 0: patch_hits (the bilinear case) */
    const ocls_intv valid = ~(isnan(h00) | isnan(h01) | isnan(h10) | isnan(h11));
    const ocls_floatv fx = (X0 + ux * T) - OCLS_CONVERT_FLOAT(PC + origin.x);
    const ocls_floatv fy = (y0 + uy * T) - OCLS_CONVERT_FLOAT(PR + origin.y);
    const ocls_floatv len = t_out - T;
    const ocls_floatv ex = h01 - h00, ey = h10 - h00, kk = (h00 - h01) - (h10 - h11);
    const ocls_floatv s_a = h00 + ex * fx + ey * fy + kk * (fx * fy);
    const ocls_floatv s1 = (ex + kk * fy) * ux + (ey + kk * fx) * uy;
    const ocls_floatv b = OCLS_BEND(kk * (ux * uy), c);
    const ocls_floatv a = s1 - OCLS_RAY_SLOPE(w, c, T), slope_b = a + b * len;
    const ocls_floatv f_a = s_a - z_in;
    const ocls_floatv f_b = f_a + slope_b * len;
    const ocls_floatv tau = -a / (2.0f * b);
    const ocls_intv inner = (b < 0.0f) & (tau > 0.0f) & (tau < len) & (f_a - (a * a) / (4.0f * b) > 0.0f);
    const ocls_intv hit = valid & select((f_a > 0.0f) | (f_b > 0.0f) | inner, (a > 0.0f) | (slope_b > 0.0f), T == 0.0f);
    ocls_intv shadow = act & ~lit & (min_hit | ((L == 0) & hit));
    const ocls_intv hole_corner = act & ~lit & (L == 0) & ~valid & via_x & via_y;
    if (any(hole_corner)) {                            /* rare: corner_hits per lane */
        int hc[OCLS_LANES], sh[OCLS_LANES], pr[OCLS_LANES], pc[OCLS_LANES];
        float zo[OCLS_LANES];
        OCLS_VSTORE(hole_corner, 0, hc); OCLS_VSTORE(shadow, 0, sh); OCLS_VSTORE(z_out, 0, zo);
        OCLS_VSTORE(PR, 0, pr); OCLS_VSTORE(PC, 0, pc);
        for (int k = 0; k < OCLS_LANES; ++k)
            if (hc[k]) sh[k] = -corner_hits(h, H, W, pr[k], pc[k], ux, uy, 0.0f, zo[k]);
        shadow = OCLS_VLOAD(0, sh);
    }
    /* step_out, then climb; a reaching tile is descended instead */
    const ocls_floatv px = X0 + ux * t_out, py = y0 + uy * t_out;
    const ocls_intv ipx = OCLS_CONVERT_INT(px), ipy = OCLS_CONVERT_INT(py);
    const ocls_intv along_c = clamp((east ? OCLS_FLOORV(px, ipx) : OCLS_CEILV(px, ipx) - 1) - origin.x, c0,
                                    c0 + size - 1);
    const ocls_intv along_r = clamp((south ? OCLS_FLOORV(py, ipy) : OCLS_CEILV(py, ipy) - 1) - origin.y, r0,
                                    r0 + size - 1);
    const ocls_intv npc = select(along_c, east ? c0 + size : c0 - 1, via_x);
    const ocls_intv npr = select(along_r, south ? r0 + size : r0 - 1, via_y);
    const ocls_intv moves = act & ~lit & ~shadow & ~reach;
    const ocls_intv out = (npr < 0) | (npr >= Hp) | (npc < 0) | (npc >= Wp);
    const ocls_intv stays = moves & ~out;
    const ocls_intv climb = min(min(31 - OCLS_CONVERT_INT(clz((npr ^ PR) | (npc ^ PC))), top), L + 1);
    p->l = select(select(L, L - 1, reach), climb, stays);
    p->pr = select(PR, npr, stays);
    p->pc = select(PC, npc, stays);
    p->t = select(T, t_out, stays);
    p->it += 1;
    *shadow_out = shadow;
    return act & (lit | shadow | (moves & out));
}

/* The rays of cells j0 + c .. j0 + c + OCLS_LANES - 1 of row i (those with c < n) after
 * their first iteration, which is straight-line code (level 0, the start
 * patch, t = 0) and reads contiguous heights: OCLS_LANES at a time here, outside the
 * packet loop.  The rays that end in it (and cells that are nodata or whose
 * ray leaves the map at once) get res[] now; the others get their state in
 * *s and their bit in the returned mask. */
OCLS_INLINE int first_steps(__global const float *h, int H, int W, int2 origin, float4 ray, float z_top, int top,
                            __global const float *cert, __global const int *band, const float *tk, int i, int j0,
                            int c, int n, uchar *res, Packet *s)
{
    const int Wp = W - 1, east = ray.x > 0.0f, pr0 = ray.y > 0.0f ? i : i - 1;
    const ocls_intv cells = c + OCLS_LANE_IDS, j = j0 + cells, pc = east ? j : j - 1;
    s->x0 = OCLS_CONVERT_FLOAT(j + origin.x);
    s->z0 = row_lanes(h + i * W, j0 + c, W);
    s->t = 0.0f;
    s->t_lim = INFINITY;
    s->pr = pr0;
    s->pc = pc;
    s->l = 0;
    s->it = 0;
    /* start_patch's test (the start patch inside the map), and the cell not nodata */
    const ocls_intv start = (pr0 >= 0 && pr0 < H - 1) ? (cells < n) & (pc >= 0) & (pc < Wp) & ~isnan(s->z0) : (ocls_intv)(0);
    ocls_intv ended = (ocls_intv)(0), shadow = (ocls_intv)(0);
    if (any(start)) {
#ifdef OCLS_CERT
        /* cert_index for the chunk's one certificate tile (OCLS_CERT % OCLS_LANES == 0), in the
         * run's one block */
        __global const float *ck = cert + ((i / OCLS_CERT) * ((W + OCLS_CERT - 1) / OCLS_CERT) +
                                           (j0 + c) / OCLS_CERT) * OCLS_CERT_K;
        if (cert_owned(band, H, i, j0 + c))
            for (int k = OCLS_CERT_K - 1; k >= 0; --k) s->t_lim = select(s->t_lim, (ocls_floatv)(tk[k]), s->z0 > ck[k]);
#endif
        const int col = start_col(j0 + c, east);
        __global const float *r0 = h + pr0 * W, *r1 = r0 + W;
        ended = packet_step(h, H, W, origin, ray, (float)(i + origin.y), z_top, top, start, s,
                            (ocls_floatv)(0.0f), (ocls_floatv)(0.0f), row_lanes(r0, col, W), row_lanes(r0, col + 1, W),
                            row_lanes(r1, col, W), row_lanes(r1, col + 1, W), &shadow);
    }
    int e[OCLS_LANES], sh[OCLS_LANES];
    OCLS_VSTORE(ended | ~start, 0, e); OCLS_VSTORE(shadow, 0, sh);
    for (int k = 0; k < OCLS_LANES && c + k < n; ++k)
        if (e[k]) res[c + k] = sh[k] != 0;
    return lane_bits(start & ~ended);
}

/* Trace the cells j0 .. j0+n-1 of row i (mode 0, ux != 0, uy != 0, H, W > 1):
 * res[c] = 1 iff cell j0 + c is in cast shadow (0 for nodata).  The rays that
 * outlive their first iteration (first_steps) go through the packet: a lane
 * whose ray has ended is refilled by blending in the next ray's state. */
OCLS_INLINE void trace_run(__global const float *h, int H, int W, int2 origin, __global const float2 *ext,
                           __global const int *lvl_off, int nlev, float4 ray,
                           __global const float *cert, __global const int *band, int i, int j0, int n, uchar *res)
{
    const int Wp = W - 1, top = nlev - 1;
    const float z_top = ext[lvl_off[top]].x;
    __global const float *ext1 = (__global const float *)ext;
#ifdef OCLS_CERT
    float tk[OCLS_CERT_K];                             /* the certificates' limits t_k */
    for (int k = 0; k < OCLS_CERT_K; ++k) tk[k] = cert_distance(k, ray);
#else
    float tk[1];                                       /* unused */
#endif
    const ocls_intv lane_id = OCLS_LANE_IDS;
    Packet p, chunk;
    p.x0 = p.z0 = p.t = p.t_lim = 0.0f;
    p.pr = p.pc = p.l = p.it = 0;
    ocls_intv CELL = -1;
    int next = 0, pending = 0, live = 0, refill = (1 << OCLS_LANES) - 1;
    float cz0[OCLS_LANES], ct[OCLS_LANES], ctl[OCLS_LANES];
    int cpr[OCLS_LANES], cpc[OCLS_LANES], cl[OCLS_LANES];
    for (;;) {
        while (refill) {                               /* new rays into the lanes that ended */
            while (!pending && next < n) {             /* the next chunk's first iterations */
                pending = first_steps(h, H, W, origin, ray, z_top, top, cert, band, tk, i, j0, next, n, res, &chunk);
                OCLS_VSTORE(chunk.z0, 0, cz0); OCLS_VSTORE(chunk.t, 0, ct);
                OCLS_VSTORE(chunk.t_lim, 0, ctl); OCLS_VSTORE(chunk.pr, 0, cpr); OCLS_VSTORE(chunk.pc, 0, cpc);
                OCLS_VSTORE(chunk.l, 0, cl);
                next += OCLS_LANES;
            }
            const int k = popcount((refill & -refill) - 1);
            refill &= refill - 1;
            const ocls_intv lane = lane_id == k;
            if (!pending) {                            /* the lane stays idle */
                CELL = select(CELL, (ocls_intv)(-1), lane);
                continue;
            }
            const int b = popcount((pending & -pending) - 1);
            pending &= pending - 1;
            live += 1;
            const int c = next - OCLS_LANES + b;
            CELL = select(CELL, (ocls_intv)(c), lane);
            p.x0 = select(p.x0, (ocls_floatv)((float)(j0 + c + origin.x)), lane);
            p.z0 = select(p.z0, (ocls_floatv)(cz0[b]), lane);
            p.t = select(p.t, (ocls_floatv)(ct[b]), lane);
            p.t_lim = select(p.t_lim, (ocls_floatv)(ctl[b]), lane);
            p.pr = select(p.pr, (ocls_intv)(cpr[b]), lane);
            p.pc = select(p.pc, (ocls_intv)(cpc[b]), lane);
            p.l = select(p.l, (ocls_intv)(cl[b]), lane);
            p.it = select(p.it, (ocls_intv)(1), lane);       /* first_steps took its first iteration */
        }
        if (live == 0) return;
        const ocls_intv act = CELL >= 0;
        /* the extrema texel of each lane's tile (at level max(L, 1), so level-0 lanes read a valid
         * one) and its patch corners */
        const ocls_intv lq = max(p.l, 1);
        const ocls_intv eidx = 2 * (OCLS_GATHER(ocls_intv, lvl_off, lq) + (p.pr >> lq) * (((ocls_intv)(Wp - 1) >> lq) + 1) +
                                (p.pc >> lq));
        const ocls_intv pidx = p.pr * W + p.pc;
        ocls_intv shadow;
        const ocls_intv ended = packet_step(h, H, W, origin, ray, (float)(i + origin.y), z_top, top, act, &p,
                                        OCLS_GATHER(ocls_floatv, ext1, eidx), OCLS_GATHER(ocls_floatv, ext1 + 1, eidx),
                                        OCLS_GATHER(ocls_floatv, h, pidx), OCLS_GATHER(ocls_floatv, h + 1, pidx),
                                        OCLS_GATHER(ocls_floatv, h + W, pidx), OCLS_GATHER(ocls_floatv, h + W + 1, pidx),
                                        &shadow);
        refill = lane_bits(ended);
        if (refill) {                                  /* record the ended rays */
            int cells[OCLS_LANES], sh[OCLS_LANES];
            OCLS_VSTORE(CELL, 0, cells); OCLS_VSTORE(shadow, 0, sh);
            for (int b = refill; b; b &= b - 1) {
                const int k = popcount((b & -b) - 1);
                res[cells[k]] = sh[k] != 0;
                live -= 1;
            }
        }
    }
}

__kernel void shadow_cells_packet(OCLS_CELLS_PARAMS)
{
    const int i = get_global_id(1), j0 = get_global_id(0) * OCLS_RUN;
    if (i >= H || j0 >= W) return;
    OCLS_TABLE_SUN(i, j0);                             /* the run lies in one block */
    const int n = min(OCLS_RUN, W - j0);
    uchar res[OCLS_RUN];
#if defined(OCLS_OUT_MASK) || defined(OCLS_OUT_COEF)
    if (mode == 0 && ray.x != 0.0f && ray.y != 0.0f && H > 1 && W > 1) {
        trace_run(h, H, W, origin, ext, lvl_off, nlev, ray, OCLS_CERT_BUF, OCLS_BAND, i, j0, n, res);
    } else {
        for (int c = 0; c < n; ++c) {
            const float z0 = h[i * W + j0 + c];
            uint steps[1];
            res[c] = !isnan(z0) && cell_shadow(h, H, W, origin, ext, lvl_off, nlev, ray, mode, OCLS_CERT_BUF,
                                                OCLS_BAND, i, j0 + c, z0, steps);
        }
    }
#else
    for (int c = 0; c < n; ++c) res[c] = 0;
#endif
    for (int c = 0; c < n; ++c)
        write_cell(h, H, W, i, j0 + c, res[c], mode, sunvec, cell, kcoef, mask, self, coef);
}
#endif

/* ---------------------------------------------------------------- per pixel
 * (not compiled with -D OCLS_IMAGES: the level-q grids are buffers) */
#ifndef OCLS_IMAGES

/* Algo 1: minimal LOD q of a pixel from its heightmap-coordinate derivatives
 * g = (du/dc, dv/dc, du/dr, dv/dr) (sample units per pixel, so the paper's
 * w ds/dx ... are g itself): |a|^2, |b|^2 the squared footprints along the
 * screen axes, n_a = min(ceil(sqrt(d2max / d2min)), n_a_max),
 * q = floor(0.5 log2(d2max) - log2(n_a)) + bias, clamped to [0, top].
 * Computed as floor(log2(y) / 2) with y = d2max / n_a^2, i.e. the binary
 * exponent of y shifted right once (exact, no log2 rounding; a subnormal y
 * gives q < 0, inf gives q > top).  d2max = 0 (or NaN) gives q = 0
 * (log2 0 = -inf); d2min = 0 gives n_a = n_a_max. */
OCLS_INLINE int minimal_lod(float4 g, int n_a_max, int bias, int top)
{
    const float a2 = g.x * g.x + g.y * g.y, b2 = g.z * g.z + g.w * g.w;
    const float dmax = fmax(a2, b2), dmin = fmin(a2, b2);
    if (isnan(a2) || isnan(b2) || !(dmax > 0.0f)) return 0;
    int n = n_a_max;
    const float ratio = dmax / dmin;                   /* inf when dmin == 0 */
    if (ratio < (float)(n_a_max * n_a_max)) {
        /* least n with n^2 >= ratio; the rounded sqrt is within an ulp, so the
         * floor of it is that n or one less */
        const int n0 = (int)sqrt(ratio);
        n = (float)(n0 * n0) >= ratio ? max(n0, 1) : n0 + 1;
    }
    const float y = dmax / (float)(n * n);
    const int e = ((as_int(y) >> 23) & 0xff) - 127;   /* floor(log2 y) for normal y */
    return clamp((e >> 1) + bias, 0, top);
}

/* a + (b - a) f, leaving out the sample whose weight is exactly 0 */
OCLS_INLINE float lerp_skip(float a, float b, float f)
{
    return f == 0.0f ? a : (f == 1.0f ? b : a + (b - a) * f);
}

/* The ray of a pixel whose surface point is (x, y) (column, row) inside grid
 * g (Hg x Wg), ray = (ux, uy, w, c) in g's units: bases (see Ray) the
 * corner (c, r) of the patch holding the point (x - c, y - r exact) and hb,
 * the sample of largest bilinear weight (not NaN when the point is not in a
 * hole); the start height relative to hb is the bilinear interpolation of the
 * samples minus hb (a sample of weight exactly 0 does not count, so a point
 * on a grid line sees that line only).  Its z0 is NaN inside a hole patch. */
OCLS_INLINE Ray pixel_ray(__global const float *g, int Hg, int Wg, float x, float y, float4 ray)
{
    const int c = clamp(ocls_floor_int(x), 0, max(Wg - 2, 0)), r = clamp(ocls_floor_int(y), 0, max(Hg - 2, 0));
    const float fx = x - (float)c, fy = y - (float)r;
    const float hb = ocls_sample(g, Hg, Wg, r + (fy > 0.5f), c + (fx > 0.5f));
    const float a = lerp_skip(ocls_sample(g, Hg, Wg, r, c) - hb, ocls_sample(g, Hg, Wg, r, c + 1) - hb, fx);
    const float b = lerp_skip(ocls_sample(g, Hg, Wg, r + 1, c) - hb, ocls_sample(g, Hg, Wg, r + 1, c + 1) - hb, fx);
    return make_ray_based(c, r, hb, fx, fy, lerp_skip(a, b, fy), ray.x, ray.y, ray.z, ray.w,
                          1.0f / fmax(fabs(ray.x), fabs(ray.y)));
}

__kernel void shadow_pixels(__global const float *h, __global const float *coarse,
                            __global const int *coarse_off, const int H, const int W,
                            __global const float2 *ext, __global const int *lvl_off, const int nlev,
                            __global const float4 *position, __global const float2 *uv,
                            __global const float4 *uv_grad, const int width, const int height,
                            const float4 ray, const float4 sunvec, const float2 kcoef,
                            const int mode, const int4 lod,
                            __global uchar *flag, __global float *coef, __global uchar *lod_out
#ifdef OCLS_STATS
                            , __global uint *stats
#endif
                            )
{
    OCLS_STEPS_BEGIN;
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= width || r >= height) return;
    const int idx = r * width + c;
    const int top = nlev - 1;
    const float2 p = uv[idx];
    int q = 0, valid = position[idx].w > 0.5f && p.x >= 0.0f && p.x <= (float)(W - 1) &&
                       p.y >= 0.0f && p.y <= (float)(H - 1);       /* false for NaN uv too */
    int shadow = 0;
    if (valid) {
        q = lod.x >= 0 ? min(lod.x, top) : minimal_lod(uv_grad[idx], lod.z, lod.y, top);
        /* the level-q grid: the heightmap, or the tile-corner grid of mip level q */
        const int Hp = max(H - 1, 1), Wp = max(W - 1, 1);
        const int Hq = q == 0 ? H : ocls_level_extent(Hp, q) + 1, Wq = q == 0 ? W : ocls_level_extent(Wp, q) + 1;
        __global const float *g = q == 0 ? h : coarse + coarse_off[q];
        const float scale = 1.0f / (float)(1 << q);    /* exact: a power of two */
        const Ray rr = pixel_ray(g, Hq, Wq, p.x * scale, p.y * scale, (float4)(ray.x * scale, ray.y * scale, ray.z, ray.w));
        valid = !isnan(rr.z0);
#if defined(OCLS_OUT_MASK) || defined(OCLS_OUT_COEF)
        if (valid) {
            if (mode == 2) shadow = 1;
            else if (mode == 0)
                shadow = trace(g, Hq, Wq, ext, lvl_off, nlev, q, ext[lvl_off[top]].x, INFINITY, &rr, steps);
        }
#endif
    }
    OCLS_STEPS_END(nlev);
#ifdef OCLS_OUT_MASK
    flag[idx] = valid ? (uchar)shadow : (uchar)255;
#endif
#ifdef OCLS_OUT_COEF
    coef[idx] = (valid && shadow) ? kcoef.x + (kcoef.y - kcoef.x) * fmax(sunvec.z, 0.0f) : 1.0f;
#endif
#ifdef OCLS_OUT_LOD
    lod_out[idx] = valid ? (uchar)q : (uchar)255;
#endif
}
#endif
