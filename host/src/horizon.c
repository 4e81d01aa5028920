/* horizon.c — horizon angles and sky-view factor sums (kernels/horizon.cl horizon_cells;
 * oclshade/horizon/caster.py HorizonCaster), a geographic grid's per band of rows. */
#include "internal.h"

#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* kernels/horizon.cl's OCLS_SEED_STRIDE and ocls_seed_extent (HorizonCaster's SEED_STRIDE) */
#define SEED_STRIDE 8
static int seed_extent(int n) { return (n - 1) / SEED_STRIDE + 2; }


void oclshade_horizon_params_init(oclshade_horizon_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
    p->dx = p->dy = 1.0;
    p->svf_definition = OCLSHADE_SVF_COSINE;
}

/* A geographic grid's bands of rows (oclshade/solar/scale.py scale_bands: SCALE_TOLERANCE degrees,
 * SCALE_ALIGN rows) */
#define SCALE_TOLERANCE 0.01
#define SCALE_ALIGN 16

typedef struct scale_band {
    int row0, rows;
    double sx, sy;             /* the band's scale: the middle of its rows' (east, north) */
    double p, q;               /* and of their stretch by direction (0 without one) */
} scale_band;

typedef struct horizon_job {
    const oclshade_horizon_params *p;
    oclshade_pyramid_layout lay;
    cl_float4 ray;
    cl_float4 *rays;           /* n_azimuths > 0: each azimuth's ray (malloc'd; horizon_job_free) */
    scale_band *bands;         /* row_scales not one band of scale 1: its bands (malloc'd), else NULL */
    int nbands;
    cl_float4 seed_ray;        /* the seeds' ray: the grid's, or with bands the middle row's band's
                                  (HorizonCaster._seed_cell: the same bits, fewer steps) */
} horizon_job;

static void horizon_job_free(horizon_job *j)
{
    free(j->rays);
    free(j->bands);
    j->rays = NULL;
    j->bands = NULL;
}

/* Whether rows of these (east, north[, p, q]) extremes hold the tolerance's share (scale_bands' holds):
 * the scales' share plus half the stretch's (a quarter of the hypot of its ranges) */
static int scales_hold(const double lo[4], const double hi[4], int columns, double share)
{
    const double stretch = columns == 4 ? hypot(hi[2] - lo[2], hi[3] - lo[3]) / 4.0 : 0.0;
    return hi[0] - lo[0] + stretch * (hi[0] + lo[0]) <= share * (hi[0] + lo[0]) / 2.0 &&
           hi[1] - lo[1] + stretch * (hi[1] + lo[1]) <= share * (hi[1] + lo[1]) / 2.0;
}

/* lo, hi widened by rows r0 .. r1 - 1 of the (rows x columns) scales */
static void widen(double lo[4], double hi[4], const double *scales, int columns, int r0, int r1)
{
    for (int r = r0; r < r1; ++r)
        for (int c = 0; c < columns; ++c) {
            const double v = scales[columns * r + c];
            if (v < lo[c]) lo[c] = v;
            if (v > hi[c]) hi[c] = v;
        }
}

/* scale_bands of the checked row_scales: the most rows from each band's first that hold the
 * tolerance, in steps of SCALE_ALIGN where a first step of that many holds, else of 1 (the same
 * comparisons on the same doubles as the Python host, on running extremes); j->bands stays NULL
 * where the map is one band of scale 1 (traced as it is). */
static oclshade_status scale_bands(oclshade *lib, const oclshade_horizon_params *p, int columns, horizon_job *j)
{
    const double *s = p->row_scales, share = 2.0 * sqrt(2.0) * (SCALE_TOLERANCE * (3.141592653589793 / 180.0));
    const int rows = p->rows;
    const size_t row_bytes = sizeof(double) * (size_t)columns;
    j->bands = (scale_band *)malloc(sizeof *j->bands * (size_t)rows);
    if (j->bands == NULL) return ocls_fail(lib, OCLSHADE_OUT_OF_MEMORY, 0, "no host memory for %d bands of rows", rows);
    for (int r0 = 0; r0 < rows;) {
        double lo[4] = {0.0}, hi[4] = {0.0}, alo[4], ahi[4];
        memcpy(lo, s + columns * r0, row_bytes);
        memcpy(hi, lo, sizeof hi);
        const int end = r0 + SCALE_ALIGN < rows ? r0 + SCALE_ALIGN : rows;
        memcpy(alo, lo, sizeof alo);
        memcpy(ahi, hi, sizeof ahi);
        widen(alo, ahi, s, columns, r0 + 1, end);
        const int step = scales_hold(alo, ahi, columns, share) ? SCALE_ALIGN : 1;
        int r1 = r0 + 1;
        if (step == SCALE_ALIGN) {
            memcpy(lo, alo, sizeof lo);
            memcpy(hi, ahi, sizeof hi);
            r1 = end;
        }
        while (r1 < rows) {
            const int next = r1 + step < rows ? r1 + step : rows;
            double tlo[4], thi[4];
            memcpy(tlo, lo, sizeof tlo);
            memcpy(thi, hi, sizeof thi);
            widen(tlo, thi, s, columns, r1, next);
            if (!scales_hold(tlo, thi, columns, share)) break;
            memcpy(lo, tlo, sizeof lo);
            memcpy(hi, thi, sizeof hi);
            r1 = next;
        }
        j->bands[j->nbands++] = (scale_band){r0, r1 - r0, (lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0,
                                             (lo[2] + hi[2]) / 2.0, (lo[3] + hi[3]) / 2.0};
        r0 = r1;
    }
    const scale_band *one = &j->bands[0];
    if (j->nbands == 1 && one->sx == 1.0 && one->sy == 1.0 && one->p == 0.0 && one->q == 0.0) {   /* as it is */
        free(j->bands);
        j->bands = NULL;
        j->nbands = 0;
    }
    return OCLSHADE_OK;
}

/* The ray of `azimuth` with a band's cell sizes, times its stretch that way
 * (HorizonCaster._ray(azimuth, scales)) */
static cl_float4 band_ray(const horizon_job *j, const scale_band *b, double azimuth)
{
    cl_float u[2];
    cl_float4 ray = j->ray;
    const double stretch = ocls_direction_factor(b->p, b->q, azimuth);
    ocls_horizontal_ray(azimuth, j->p->dx * b->sx * stretch, j->p->dy * b->sy * stretch, u);
    ray.s[0] = u[0];
    ray.s[1] = u[1];
    return ray;
}

static cl_float2 band_cell(const horizon_job *j, const scale_band *b)
{
    const cl_float2 cell = {{(cl_float)(j->p->dx * b->sx), (cl_float)(j->p->dy * b->sy)}};
    return cell;
}

/* HorizonCaster's sweeps(): with a search radius, a ray crossing at most the knob sweep_cells patch
 * columns and rows within it (the same float64 product of the float32 ray) takes horizon_sweep
 * (kernels/horizon.cl, "The sweep": the same angles as the walk, bit for bit), on maps of 2 rows
 * and columns or more; past that reach, where the knob sweep_far is 2.  Its pilot (sweep_far 1,
 * oclshade/horizon/pilot.py) is the Python host's alone: it times both kernels and so waits for
 * the queue, while a call here only enqueues into the caller's pipeline; here 1 walks, as 0. */
static int sweeps(oclshade *lib, const horizon_job *j)
{
    const double ux = j->ray.s[0], uy = j->ray.s[1], radius = j->ray.s[3];
    return !j->p->clamped && j->p->rows >= 2 && j->p->cols >= 2 && radius > 0.0 &&
           (radius * (fabs(ux) + fabs(uy)) <= ocls_knob(lib, K_HORIZON_SWEEP_CELLS) ||
            ocls_knob(lib, K_HORIZON_SWEEP_FAR) == 2);
}

static oclshade_status horizon_job_for(oclshade *lib, const oclshade_horizon_params *p, horizon_job *j)
{
    oclshade_status st;
    memset(j, 0, sizeof *j);
    if (p == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params must point to oclshade_horizon_params, got NULL");
    if ((st = ocls_check_size(lib, "rows", p->rows, "cols", p->cols)) != OCLSHADE_OK) return st;
    if (!(isfinite(p->dx) && p->dx > 0.0 && isfinite(p->dy) && p->dy > 0.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "dx and dy must be positive finite cell sizes, got %g, %g", p->dx, p->dy);
    if (p->n_azimuths < 0)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "n_azimuths must be >= 0 (0: the one azimuth), got %d",
                         p->n_azimuths);
    if (p->n_azimuths == 0 && !isfinite(p->azimuth))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "azimuth must be finite degrees, got %g", p->azimuth);
    if (p->n_azimuths > 0) {
        if (p->azimuths == NULL)
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "azimuths must point to n_azimuths (%d) degrees, got NULL",
                             p->n_azimuths);
        for (int k = 0; k < p->n_azimuths; ++k)
            if (!isfinite(p->azimuths[k]))
                return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "azimuths[%d] must be finite degrees, got %g", k,
                                 p->azimuths[k]);
        if (p->max_distance != 0.0)
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "several azimuths in one call (n_azimuths %d) are the "
                             "whole map's walk: max_distance must be 0, got %g (call once per azimuth within a radius)",
                             p->n_azimuths, p->max_distance);
        if ((size_t)p->rows * (size_t)p->n_azimuths > (size_t)INT_MAX)
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "n_azimuths * rows must be at most %d (the angle "
                             "field's rows), got %d * %d", INT_MAX, p->n_azimuths, p->rows);
    }
    if (!(isfinite(p->curvature) && p->curvature >= 0.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "curvature must be a finite drop per square metre >= 0 "
                         "((1 - k) / (2 R)), got %g", p->curvature);
    if (!(isfinite(p->max_distance) && (p->max_distance == 0.0 ||
          ((cl_float)p->max_distance > 0.0f && (cl_float)p->max_distance < INFINITY))))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "max_distance must be a finite search radius in metres "
                         ">= 0 (0: the whole map), got %g", p->max_distance);
    if (p->angle.buffer == NULL && p->svf == NULL)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "at least one of angle, svf must have a buffer");
    if (p->svf != NULL && p->svf_definition != OCLSHADE_SVF_COSINE && p->svf_definition != OCLSHADE_SVF_SOLID_ANGLE)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "svf_definition must be OCLSHADE_SVF_COSINE (1) or "
                         "OCLSHADE_SVF_SOLID_ANGLE (2), got %d", (int)p->svf_definition);
    if (p->clamped != 0 && p->clamped != 1)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "clamped must be 0 or 1, got %d", p->clamped);
    if (p->clamped) {
        if (p->angle.buffer == NULL || p->svf != NULL || p->n_azimuths > 0 || p->row_scales != NULL)
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "clamped angles (a strip of the sun's disc) are one "
                             "azimuth's angle alone: angle needs a buffer, and svf NULL, n_azimuths 0, row_scales NULL");
        if (!(isfinite(p->clamp_bounds[0]) && isfinite(p->clamp_bounds[1]) && p->clamp_bounds[0] < p->clamp_bounds[1]))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "clamp_bounds must be finite tangents lo < hi, got "
                             "%g, %g", p->clamp_bounds[0], p->clamp_bounds[1]);
    }
    if (p->row_scales != NULL) {
        const int columns = p->row_scale_columns == 0 ? 2 : p->row_scale_columns;
        if (columns != 2 && columns != 4)
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "row_scale_columns must be 2 (east, north) or 4 "
                             "(east, north, p, q), got %d", p->row_scale_columns);
        for (int r = 0; r < p->rows; ++r) {
            const double *row = p->row_scales + columns * r;
            for (int c = 0; c < 2; ++c)
                if (!(isfinite(row[c]) && row[c] > 0.0))
                    return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "row_scales[%d] (row %d, %s) must be a positive "
                                     "finite scale, got %g", columns * r + c, r, c ? "north" : "east", row[c]);
            if (columns == 4 && !(isfinite(row[2]) && isfinite(row[3]) && hypot(row[2], row[3]) < 1.0 &&
                                  ((row[2] == 0.0 && row[3] == 0.0) || row[0] == row[1])))
                return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "row_scales row %d's stretch (p, q) = (%g, %g) must "
                                 "have p^2 + q^2 < 1, and be 0 where its east and north scales differ", r, row[2], row[3]);
        }
        if ((st = scale_bands(lib, p, columns, j)) != OCLSHADE_OK) return st;
    }
    oclshade_pyramid_layout_for(p->rows, p->cols, &j->lay);
    cl_float u[2];
    ocls_horizontal_ray(p->azimuth, p->dx, p->dy, u);
    j->ray.s[0] = u[0];
    j->ray.s[1] = u[1];
    j->ray.s[2] = (cl_float)p->curvature;
    j->ray.s[3] = (cl_float)p->max_distance;
    j->p = p;
    const scale_band *seed_band = NULL;   /* the band holding the middle row */
    for (int b = 0; b < j->nbands; ++b)
        if (j->bands[b].row0 <= p->rows / 2 && p->rows / 2 < j->bands[b].row0 + j->bands[b].rows) seed_band = &j->bands[b];
    j->seed_ray = seed_band ? band_ray(j, seed_band, p->azimuth) : j->ray;
    if (p->n_azimuths > 0) {   /* the seeds' rays (and the cells' without bands) */
        j->rays = (cl_float4 *)malloc(sizeof *j->rays * (size_t)p->n_azimuths);
        if (j->rays == NULL) return ocls_fail(lib, OCLSHADE_OUT_OF_MEMORY, 0, "no host memory for %d rays", p->n_azimuths);
        for (int k = 0; k < p->n_azimuths; ++k) {
            if (seed_band) {
                j->rays[k] = band_ray(j, seed_band, p->azimuths[k]);
                continue;
            }
            ocls_horizontal_ray(p->azimuths[k], p->dx * 1.0, p->dy * 1.0, u);
            j->rays[k] = j->ray;
            j->rays[k].s[0] = u[0];
            j->rays[k].s[1] = u[1];
        }
    }
    return OCLSHADE_OK;
}

/* horizon_cells_batch (arguments `a`, the rays and cell sizes replaced) over each band of rows, its
 * rays for azimuths first .. first + count - 1 uploaded to band_rays at those places first. */
static oclshade_status batch_bands(ocls_pass *ps, const horizon_job *j, kernel_entry *walker, ocls_arg *a,
                                   cl_mem band_rays, cl_int first, cl_int count, size_t group, size_t width)
{
    const oclshade_horizon_params *p = j->p;
    cl_float4 *rays = (cl_float4 *)malloc(sizeof *rays * (size_t)count);
    oclshade_status st = OCLSHADE_OK;
    if (rays == NULL) return ocls_fail(ps->lib, OCLSHADE_OUT_OF_MEMORY, 0, "no host memory for %d rays", count);
    for (int b = 0; b < j->nbands && st == OCLSHADE_OK; ++b) {
        const scale_band *band = &j->bands[b];
        const cl_float2 cell = band_cell(j, band);
        for (int k = 0; k < count; ++k) rays[k] = band_ray(j, band, p->azimuths[first + k]);
        a[6] = (ocls_arg)OCLS_ARG(band_rays);
        a[10] = (ocls_arg)OCLS_ARG(cell);
        if ((st = ocls_upload(ps, band_rays, sizeof *rays * (size_t)first, rays, sizeof *rays * (size_t)count,
                              "a band's horizon rays")) == OCLSHADE_OK &&
            (st = ocls_set_args(ps, walker, a, 14)) == OCLSHADE_OK)
            st = ocls_launch_rows(ps, walker, p->cols, band->row0, band->rows, p->svf ? 1 : count, group, width);
    }
    free(rays);
    return st;
}

/* Several azimuths (n_azimuths > 0; HorizonCaster._batch_launcher): per knob `batch` of them,
 * horizon_seeds_batch into scratch, then horizon_cells_batch into their angle bands (one
 * work-item per cell and azimuth), or with svf one work-item per cell over them in order. */
static oclshade_status horizon_batch_body(ocls_pass *ps, const horizon_job *j, cl_mem h, const ocls_defines *d)
{
    const oclshade_horizon_params *p = j->p;
    oclshade *lib = ps->lib;
    const int n = p->n_azimuths, batch = ocls_knob(lib, K_HORIZON_BATCH) < n ? ocls_knob(lib, K_HORIZON_BATCH) : n;
    const size_t W = (size_t)p->cols, seed_cells = (size_t)seed_extent(p->rows) * (size_t)seed_extent(p->cols);
    cl_mem angle, seeds, rays, band_rays = NULL;
    oclshade_status st;
    if ((st = ocls_bind_out(ps, &p->angle, n * p->rows, 4 * W, "angle", &angle)) != OCLSHADE_OK ||
        (st = ocls_scratch(ps, 8 * seed_cells * (size_t)batch, "horizon seeds", &seeds)) != OCLSHADE_OK ||
        (st = ocls_scratch(ps, sizeof *j->rays * (size_t)n, "horizon rays", &rays)) != OCLSHADE_OK ||
        (j->bands && (st = ocls_scratch(ps, sizeof *j->rays * (size_t)n, "a band's horizon rays", &band_rays))
                     != OCLSHADE_OK) || !ps->run)
        return st;
    if ((st = ocls_upload(ps, rays, 0, j->rays, sizeof *j->rays * (size_t)n, "horizon rays")) != OCLSHADE_OK) return st;
    kernel_entry *seeder, *walker;
    if ((st = ocls_kernel(ps, "horizon.cl", d, "horizon_seeds_batch", &seeder)) != OCLSHADE_OK ||
        (st = ocls_kernel(ps, "horizon.cl", d, "horizon_cells_batch", &walker)) != OCLSHADE_OK)
        return st;
    const size_t group = (size_t)ocls_knob(lib, K_HORIZON_GROUP), width = (size_t)ocls_knob(lib, K_HORIZON_WIDTH);
    const cl_int H = p->rows, Wi = p->cols, nlev = j->lay.levels, stride = p->rows * p->cols;
    const cl_float2 cell = {{(cl_float)p->dx, (cl_float)p->dy}};
    cl_mem angle_arg = angle ? angle : h, svf = p->svf ? p->svf : h;
    for (cl_int first = 0; first < n; first += batch) {
        const cl_int count = n - first < batch ? n - first : batch;
        ocls_arg sa[9] = {OCLS_ARG(h), OCLS_ARG(H), OCLS_ARG(Wi), OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets),
                          OCLS_ARG(nlev), OCLS_ARG(rays), OCLS_ARG(seeds), OCLS_ARG(first)};
        ocls_arg a[14] = {OCLS_ARG(h), OCLS_ARG(H), OCLS_ARG(Wi), OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets),
                          OCLS_ARG(nlev), OCLS_ARG(rays), OCLS_ARG(angle_arg), OCLS_ARG(svf), OCLS_ARG(seeds),
                          OCLS_ARG(cell), OCLS_ARG(stride), OCLS_ARG(first), OCLS_ARG(count)};
        if ((st = ocls_set_args(ps, seeder, sa, 9)) != OCLSHADE_OK ||
            (st = ocls_launch_3d(ps, seeder, seed_extent(p->cols), seed_extent(p->rows),
                                 count, group, width)) != OCLSHADE_OK)
            return st;
        if (j->bands == NULL) {
            if ((st = ocls_set_args(ps, walker, a, 14)) != OCLSHADE_OK ||
                (st = ocls_launch_3d(ps, walker, Wi, H, p->svf ? 1 : count, group, width)) != OCLSHADE_OK)
                return st;
            continue;
        }
        /* each band's cells with its rays, at the batch's places in a buffer of their own (the seeds
         * keep the grid's rays: kernels/horizon.cl, "Seeds") */
        if ((st = batch_bands(ps, j, walker, a, band_rays, first, count, group, width)) != OCLSHADE_OK) return st;
    }
    return OCLSHADE_OK;
}

/* HorizonCaster._enqueuer: within a short search radius horizon_sweep; else horizon_seeds on the
 * seed grid into scratch (over the whole map, no search radius), then horizon_cells. */
static oclshade_status horizon_body(ocls_pass *ps, const void *params)
{
    const horizon_job *j = (const horizon_job *)params;
    const oclshade_horizon_params *p = j->p;
    oclshade *lib = ps->lib;
    const size_t W = (size_t)p->cols;
    const int sweep = sweeps(lib, j), seeded = j->ray.s[3] == 0.0f && !p->clamped;
    const int seed_rows = seeded ? seed_extent(p->rows) : 0, seed_cols = seeded ? seed_extent(p->cols) : 0;
    cl_mem h, angle, seeds = NULL;
    oclshade_status st;
    ocls_defines d = {0};
    ocls_def_flag(&d, "OCLS_OUT_ANGLE", p->angle.buffer != NULL);
    if (p->svf != NULL) ocls_def_int(&d, "OCLS_OUT_SVF", (int)p->svf_definition);
    ocls_def_flag(&d, "OCLS_CURVATURE", p->curvature > 0.0);
    ocls_def_flag(&d, "OCLS_MAX_DISTANCE", j->ray.s[3] > 0.0f);   /* never with n_azimuths (checked) */
    ocls_def_flag(&d, "OCLS_CLAMP", p->clamped);
    ocls_def_flag(&d, "OCLS_OWN_BUILTINS", ocls_knob(lib, K_HORIZON_OWN_BUILTINS));
    if (ocls_knob(lib, K_HORIZON_SCAN)) ocls_def_int(&d, "OCLS_LEVEL_SCAN", 1);
    if ((st = ocls_bind_in(ps, &p->heights, p->rows, 4 * W, "heights", &h)) != OCLSHADE_OK) return st;
    if (p->n_azimuths > 0) return horizon_batch_body(ps, j, h, &d);
    if ((st = ocls_bind_out(ps, &p->angle, p->rows, 4 * W, "angle", &angle)) != OCLSHADE_OK ||
        (seeded && (st = ocls_scratch(ps, 8 * (size_t)seed_rows * (size_t)seed_cols, "horizon seeds", &seeds)) != OCLSHADE_OK) ||
        !ps->run)
        return st;
    const size_t group = (size_t)ocls_knob(lib, K_HORIZON_GROUP), width = (size_t)ocls_knob(lib, K_HORIZON_WIDTH);
    const cl_int H = p->rows, Wi = p->cols;
    /* an output not compiled in is not written (nor are the seeds read with a search radius): its
     * argument is any buffer of the call */
    cl_mem angle_arg = angle ? angle : h, svf = p->svf ? p->svf : h, seeds_arg = seeds ? seeds : h;
    if (sweep) {
        const int lanes = ocls_knob(lib, K_HORIZON_LANES);
        kernel_entry *sweeper;
        ocls_def_int(&d, "OCLS_SWEEP", lanes);
        if ((st = ocls_kernel(ps, "horizon.cl", &d, "horizon_sweep", &sweeper)) != OCLSHADE_OK) return st;
        ocls_arg a[6] = {OCLS_ARG(h), OCLS_ARG(H), OCLS_ARG(Wi), OCLS_ARG(j->ray), OCLS_ARG(angle_arg), OCLS_ARG(svf)};
        if (j->bands == NULL)
            return (st = ocls_set_args(ps, sweeper, a, 6)) != OCLSHADE_OK ? st :
                   ocls_launch(ps, sweeper, (p->cols + lanes - 1) / lanes, H, group, width);
        for (int b = 0; b < j->nbands && st == OCLSHADE_OK; ++b) {   /* each band with its ray */
            const cl_float4 ray = band_ray(j, &j->bands[b], p->azimuth);
            a[3] = (ocls_arg)OCLS_ARG(ray);
            if ((st = ocls_set_args(ps, sweeper, a, 6)) == OCLSHADE_OK)
                st = ocls_launch_rows(ps, sweeper, (p->cols + lanes - 1) / lanes, j->bands[b].row0, j->bands[b].rows,
                                      0, group, width);
        }
        return st;
    }
    kernel_entry *k, *seeder = NULL;
    if ((st = ocls_kernel(ps, "horizon.cl", &d, "horizon_cells", &k)) != OCLSHADE_OK ||
        (seeded && (st = ocls_kernel(ps, "horizon.cl", &d, "horizon_seeds", &seeder)) != OCLSHADE_OK))
        return st;
    const cl_int nlev = j->lay.levels;
    const cl_float2 cell = {{(cl_float)p->dx, (cl_float)p->dy}};
    ocls_arg sa[8] = {OCLS_ARG(h), OCLS_ARG(H), OCLS_ARG(Wi), OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets),
                      OCLS_ARG(nlev), OCLS_ARG(j->seed_ray), OCLS_ARG(seeds)};
    if (seeded && ((st = ocls_set_args(ps, seeder, sa, 8)) != OCLSHADE_OK ||
                   (st = ocls_launch(ps, seeder, seed_cols, seed_rows, group, width)) != OCLSHADE_OK))
        return st;
    const cl_float2 bounds = {{(cl_float)p->clamp_bounds[0], (cl_float)p->clamp_bounds[1]}};
    ocls_arg a[12] = {OCLS_ARG(h), OCLS_ARG(H), OCLS_ARG(Wi), OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets),
                      OCLS_ARG(nlev), OCLS_ARG(j->ray), OCLS_ARG(angle_arg), OCLS_ARG(svf), OCLS_ARG(seeds_arg),
                      OCLS_ARG(cell), OCLS_ARG(bounds)};
    if (j->bands == NULL)      /* (clamped: the bounds too, never in bands) */
        return (st = ocls_set_args(ps, k, a, p->clamped ? 12 : 11)) != OCLSHADE_OK ? st :
               ocls_launch(ps, k, Wi, H, group, width);
    for (int b = 0; b < j->nbands && st == OCLSHADE_OK; ++b) {   /* each band with its ray and cells */
        const cl_float4 ray = band_ray(j, &j->bands[b], p->azimuth);
        const cl_float2 band_cells = band_cell(j, &j->bands[b]);
        a[6] = (ocls_arg)OCLS_ARG(ray);
        a[10] = (ocls_arg)OCLS_ARG(band_cells);
        if ((st = ocls_set_args(ps, k, a, 11)) == OCLSHADE_OK)
            st = ocls_launch_rows(ps, k, Wi, j->bands[b].row0, j->bands[b].rows, 0, group, width);
    }
    return st;
}

oclshade_status oclshade_horizon_scratch_size(oclshade *lib, const oclshade_horizon_params *params, size_t *bytes)
{
    horizon_job j = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st == OCLSHADE_OK) st = horizon_job_for(lib, params, &j);
    if (st == OCLSHADE_OK) st = ocls_plan(lib, horizon_body, &j, bytes);
    horizon_job_free(&j);
    return st;
}

oclshade_status oclshade_enqueue_horizon(oclshade *lib, cl_command_queue queue, const oclshade_horizon_params *p,
                                         cl_uint num_events_in_wait_list, const cl_event *event_wait_list, cl_event *event)
{
    horizon_job j = {0};
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = horizon_job_for(lib, p, &j);
    if (st != OCLSHADE_OK) {
        horizon_job_free(&j);
        return st;
    }
    const size_t W = (size_t)p->cols;
    const int bands = p->n_azimuths > 0 ? p->n_azimuths : 1;
    if ((st = ocls_use_field(lib, &uses, "heights", &p->heights, p->rows, 4 * W, OCLS_IN)) == OCLSHADE_OK &&
        (st = ocls_use_buffer(lib, &uses, "pyramid", p->pyramid, j.lay.pyramid_bytes, OCLS_IN)) == OCLSHADE_OK &&
        (st = ocls_use_buffer(lib, &uses, "offsets", p->offsets, j.lay.offsets_bytes, OCLS_IN)) == OCLSHADE_OK &&
        (!p->angle.buffer ||
         (st = ocls_use_field(lib, &uses, "angle", &p->angle, bands * p->rows, 4 * W, OCLS_OUT)) == OCLSHADE_OK) &&
        (!p->svf || (st = ocls_use_buffer(lib, &uses, "svf", p->svf, 8 * W * (size_t)p->rows, OCLS_INOUT)) == OCLSHADE_OK))
        st = ocls_enqueue(lib, queue, p->scratch, &uses, horizon_body, &j, num_events_in_wait_list, event_wait_list, event);
    horizon_job_free(&j);
    return st;
}
