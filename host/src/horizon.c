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

/* A scaled grid's blocks (oclshade/solar/scale.py scale_blocks: SCALE_TOLERANCE degrees,
 * SCALE_ALIGN rows and columns) */
#define SCALE_TOLERANCE 0.01
#define SCALE_ALIGN 16
#define SEGMENT_SHARE 0.5      /* oclshade/solar/scale.py: what column bands leave to their cells' spread */

typedef struct scale_band {    /* a block of cells (scale_blocks) */
    int row0, rows;
    int col0, cols;
    double sx, sy;             /* the block's scale: the middle of its rows' (east, north) */
    double p, q;               /* and of their stretch by direction (0 without one) */
} scale_band;

typedef struct horizon_job {
    const oclshade_horizon_params *p;
    oclshade_pyramid_layout lay;
    cl_float4 ray;
    cl_float4 *rays;           /* n_azimuths > 0: each azimuth's ray (malloc'd; horizon_job_free) */
    scale_band *bands;         /* row_scales not one block of scale 1: its blocks in raster order (malloc'd),
                                  else NULL */
    int nbands;
    cl_int *band;              /* with bands: kernels/horizon.cl's OCLS_SUN_TABLE band (rows + cols; malloc'd):
                                  cell (i, j) in block band[i] + band[rows + j] */
    cl_float4 seed_ray;        /* the seeds' ray: the grid's, or with bands the middle row's band's
                                  (HorizonCaster._seed_cell: the same bits, fewer steps) */
} horizon_job;

static void horizon_job_free(horizon_job *j)
{
    free(j->rays);
    free(j->bands);
    free(j->band);
    j->rays = NULL;
    j->bands = NULL;
    j->band = NULL;
}

/* stretch_share (oclshade/solar/scale.py): the most by which the stretch by direction may differ
 * as a share from that of the middle of these extremes of (p, q); 0 without them */
static double stretch_share(const double lo[4], const double hi[4], int columns)
{
    if (columns != 4) return 0.0;
    const double most = hypot(fmax(fabs(lo[2]), fabs(hi[2])), fmax(fabs(lo[3]), fabs(hi[3])));
    return most < 1.0 ? hypot(hi[2] - lo[2], hi[3] - lo[3]) / (4.0 * (1.0 - most)) : INFINITY;   /* (no bound) */
}

/* Whether rows of these (east, north[, p, q]) extremes hold the share (scale_blocks' holds):
 * the scales' share plus the stretch's, in each of `bands` column bands */
static int scales_hold(const double *lo, const double *hi, int bands, int columns, double share)
{
    for (int b = 0; b < bands; ++b) {
        const double *l = lo + 4 * b, *h = hi + 4 * b, stretch = stretch_share(l, h, columns);
        if (!(h[0] - l[0] + stretch * (h[0] + l[0]) <= share * (h[0] + l[0]) / 2.0 &&
              h[1] - l[1] + stretch * (h[1] + l[1]) <= share * (h[1] + l[1]) / 2.0))
            return 0;
    }
    return 1;
}

/* lo, hi (bands x 4) widened by rows r0 .. r1 - 1 of the (rows x bands x columns) scales */
static void widen(double *lo, double *hi, const double *scales, int bands, int columns, int r0, int r1)
{
    for (int r = r0; r < r1; ++r)
        for (int b = 0; b < bands; ++b)
            for (int c = 0; c < columns; ++c) {
                const double v = scales[(r * bands + b) * columns + c];
                if (v < lo[4 * b + c]) lo[4 * b + c] = v;
                if (v > hi[4 * b + c]) hi[4 * b + c] = v;
            }
}

/* oclshade.solar.scale.column_edges: the inner edges the multiples of column_alignment nearest
 * to b cols / bands (integer arithmetic): the largest of 1024, 256, 64 and 16 that bands at least
 * twice as wide leave, else SCALE_ALIGN */
static int column_edge(int cols, int bands, int b)
{
    static const long long alignments[] = {1024, 256, 64, 16};
    long long a = SCALE_ALIGN;
    if (b == bands) return cols;
    for (int k = 0; k < 4; ++k)
        if (2 * alignments[k] * bands <= cols) { a = alignments[k]; break; }
    return (int)(((long long)b * cols + a / 2 * bands) / (a * bands) * a);
}

/* scale_blocks (oclshade/solar/scale.py) of the checked row_scales (rows x bands x columns): bands
 * of rows from each band's first, the most that hold the tolerance in every column band, in steps
 * of SCALE_ALIGN where a first step of that many holds, else of 1 (the same comparisons on the
 * same doubles as the Python host, on running extremes), times the column bands; j->bands stays
 * NULL where the map is one block of scale 1 (traced as it is). */
static oclshade_status scale_blocks(oclshade *lib, const oclshade_horizon_params *p, int bands, int columns,
                                    horizon_job *j)
{
    const double *s = p->row_scales;
    double share = 2.0 * sqrt(2.0) * (SCALE_TOLERANCE * (3.141592653589793 / 180.0));
    const int rows = p->rows, nb = bands > 0 ? bands : 1;
    if (bands > 0) share *= 1.0 - SEGMENT_SHARE;
    double *ext = (double *)calloc((size_t)nb * 4 * 6, sizeof *ext);    /* lo, hi, alo, ahi, tlo, thi */
    j->bands = (scale_band *)malloc(sizeof *j->bands * (size_t)rows * (size_t)nb);
    if (j->bands == NULL || ext == NULL) {
        free(ext);
        return ocls_fail(lib, OCLSHADE_OUT_OF_MEMORY, 0, "no host memory for %d blocks of rows", rows * nb);
    }
    double *lo = ext, *hi = ext + 4 * nb, *alo = ext + 8 * nb, *ahi = ext + 12 * nb, *tlo = ext + 16 * nb,
           *thi = ext + 20 * nb;
    const size_t all = sizeof(double) * 4 * (size_t)nb;
    for (int r0 = 0; r0 < rows;) {
        for (int b = 0; b < nb; ++b)
            for (int c = 0; c < 4; ++c) lo[4 * b + c] = c < columns ? s[(r0 * nb + b) * columns + c] : 0.0;
        memcpy(hi, lo, all);
        const int end = r0 + SCALE_ALIGN < rows ? r0 + SCALE_ALIGN : rows;
        memcpy(alo, lo, all);
        memcpy(ahi, hi, all);
        widen(alo, ahi, s, nb, columns, r0 + 1, end);
        const int step = scales_hold(alo, ahi, nb, columns, share) ? SCALE_ALIGN : 1;
        int r1 = r0 + 1;
        if (step == SCALE_ALIGN) {
            memcpy(lo, alo, all);
            memcpy(hi, ahi, all);
            r1 = end;
        }
        while (r1 < rows) {
            const int next = r1 + step < rows ? r1 + step : rows;
            memcpy(tlo, lo, all);
            memcpy(thi, hi, all);
            widen(tlo, thi, s, nb, columns, r1, next);
            if (!scales_hold(tlo, thi, nb, columns, share)) break;
            memcpy(lo, tlo, all);
            memcpy(hi, thi, all);
            r1 = next;
        }
        for (int b = 0; b < nb; ++b) {
            const double *l = lo + 4 * b, *h = hi + 4 * b;
            const int c0 = column_edge(p->cols, nb, b);
            j->bands[j->nbands++] = (scale_band){r0, r1 - r0, c0, column_edge(p->cols, nb, b + 1) - c0,
                                                 (l[0] + h[0]) / 2.0, (l[1] + h[1]) / 2.0,
                                                 (l[2] + h[2]) / 2.0, (l[3] + h[3]) / 2.0};
        }
        r0 = r1;
    }
    free(ext);
    scale_band *fit = (scale_band *)realloc(j->bands, sizeof *j->bands * (size_t)j->nbands);   /* (rows x m at most) */
    if (fit != NULL) j->bands = fit;
    const scale_band *one = &j->bands[0];
    if (j->nbands == 1 && one->sx == 1.0 && one->sy == 1.0 && one->p == 0.0 && one->q == 0.0) {   /* as it is */
        free(j->bands);
        j->bands = NULL;
        j->nbands = 0;
        return OCLSHADE_OK;
    }
    j->band = (cl_int *)malloc(sizeof *j->band * ((size_t)rows + (size_t)p->cols));
    if (j->band == NULL) return ocls_fail(lib, OCLSHADE_OUT_OF_MEMORY, 0, "no host memory for the blocks' bands");
    for (int b = 0; b < j->nbands; b += nb)              /* each band of rows: its first block's number */
        for (int r = j->bands[b].row0; r < j->bands[b].row0 + j->bands[b].rows; ++r) j->band[r] = b;
    for (int b = 0; b < nb; ++b)                         /* each column band: its number in the row */
        for (int c = j->bands[b].col0; c < j->bands[b].col0 + j->bands[b].cols; ++c) j->band[rows + c] = b;
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
        const int most = p->cols / SCALE_ALIGN > 1 ? p->cols / SCALE_ALIGN : 1, bands = p->row_scale_bands;
        if (columns != 2 && columns != 4)
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "row_scale_columns must be 2 (east, north) or 4 "
                             "(east, north, p, q), got %d", p->row_scale_columns);
        if (bands < 0 || bands > most)
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "row_scale_bands must be 0 (one scale per row) or 1 to "
                             "%d (column bands of a map %d wide), got %d", most, p->cols, bands);
        const int nb = bands > 0 ? bands : 1;
        for (int r = 0; r < p->rows; ++r)
            for (int b = 0; b < nb; ++b) {
                const double *row = p->row_scales + columns * (r * nb + b);
                for (int c = 0; c < 2; ++c)
                    if (!(isfinite(row[c]) && row[c] > 0.0))
                        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "row_scales[%d] (row %d, column band %d, %s) "
                                         "must be a positive finite scale, got %g", columns * (r * nb + b) + c, r, b,
                                         c ? "north" : "east", row[c]);
                if (columns == 4 && !(isfinite(row[2]) && isfinite(row[3]) && hypot(row[2], row[3]) < 1.0 &&
                                      ((row[2] == 0.0 && row[3] == 0.0) || row[0] == row[1])))
                    return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "row_scales row %d column band %d's stretch (p, q) "
                                     "= (%g, %g) must have p^2 + q^2 < 1, and be 0 where its east and north scales "
                                     "differ", r, b, row[2], row[3]);
            }
        if ((st = scale_blocks(lib, p, bands, columns, j)) != OCLSHADE_OK) return st;
    }
    oclshade_pyramid_layout_for(p->rows, p->cols, &j->lay);
    cl_float u[2];
    ocls_horizontal_ray(p->azimuth, p->dx, p->dy, u);
    j->ray.s[0] = u[0];
    j->ray.s[1] = u[1];
    j->ray.s[2] = (cl_float)p->curvature;
    j->ray.s[3] = (cl_float)p->max_distance;
    j->p = p;
    const scale_band *seed_band = NULL;   /* the block holding the middle cell */
    for (int b = 0; b < j->nbands; ++b) {
        const scale_band *k = &j->bands[b];
        if (k->row0 <= p->rows / 2 && p->rows / 2 < k->row0 + k->rows && k->col0 <= p->cols / 2 &&
            p->cols / 2 < k->col0 + k->cols)
            seed_band = k;
    }
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

/* The blocks' table for horizon_cells_batch (-D OCLS_SUN_TABLE; HorizonCaster._batch_launcher):
 * per block its cell sizes, then its rays for azimuths first .. first + count - 1, uploaded to
 * `table` (table_stride = count + 1) */
static oclshade_status upload_batch_table(ocls_pass *ps, const horizon_job *j, cl_mem table, cl_int first,
                                          cl_int count)
{
    const size_t stride = (size_t)count + 1, bytes = sizeof(cl_float4) * stride * (size_t)j->nbands;
    cl_float4 *rows = (cl_float4 *)malloc(bytes);
    if (rows == NULL) return ocls_fail(ps->lib, OCLSHADE_OUT_OF_MEMORY, 0, "no host memory for the blocks' rays");
    for (int b = 0; b < j->nbands; ++b) {
        const cl_float2 cell = band_cell(j, &j->bands[b]);
        const cl_float4 head = {{cell.s[0], cell.s[1], 0.0f, 0.0f}};
        rows[b * stride] = head;
        for (int k = 0; k < count; ++k) rows[b * stride + 1 + k] = band_ray(j, &j->bands[b], j->p->azimuths[first + k]);
    }
    const oclshade_status st = ocls_upload(ps, table, 0, rows, bytes, "the blocks' horizon rays");
    free(rows);
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
    const size_t band_bytes = sizeof(cl_int) * ((size_t)p->rows + W);
    const size_t table_bytes = sizeof(cl_float4) * ((size_t)batch + 1) * (size_t)j->nbands;
    cl_mem angle, seeds, rays, band = NULL, table = NULL;
    oclshade_status st;
    if ((st = ocls_bind_out(ps, &p->angle, n * p->rows, 4 * W, "angle", &angle)) != OCLSHADE_OK ||
        (st = ocls_scratch(ps, 8 * seed_cells * (size_t)batch, "horizon seeds", &seeds)) != OCLSHADE_OK ||
        (st = ocls_scratch(ps, sizeof *j->rays * (size_t)n, "horizon rays", &rays)) != OCLSHADE_OK ||
        (j->bands && ((st = ocls_scratch(ps, band_bytes, "the blocks' bands", &band)) != OCLSHADE_OK ||
                      (st = ocls_scratch(ps, table_bytes, "the blocks' horizon rays", &table)) != OCLSHADE_OK)) ||
        !ps->run)
        return st;
    if ((st = ocls_upload(ps, rays, 0, j->rays, sizeof *j->rays * (size_t)n, "horizon rays")) != OCLSHADE_OK ||
        (j->bands && (st = ocls_upload(ps, band, 0, j->band, band_bytes, "the blocks' bands")) != OCLSHADE_OK))
        return st;
    ocls_defines tabled = *d;             /* blocks: each cell's rays and cell sizes from their table */
    ocls_def_flag(&tabled, "OCLS_SUN_TABLE", j->bands != NULL);
    kernel_entry *seeder, *walker;
    if ((st = ocls_kernel(ps, "horizon.cl", d, "horizon_seeds_batch", &seeder)) != OCLSHADE_OK ||
        (st = ocls_kernel(ps, "horizon.cl", &tabled, "horizon_cells_batch", &walker)) != OCLSHADE_OK)
        return st;
    const size_t group = (size_t)ocls_knob(lib, K_HORIZON_GROUP), width = (size_t)ocls_knob(lib, K_HORIZON_WIDTH);
    const cl_int H = p->rows, Wi = p->cols, nlev = j->lay.levels, stride = p->rows * p->cols;
    const cl_float2 cell = {{(cl_float)p->dx, (cl_float)p->dy}};
    cl_mem angle_arg = angle ? angle : h, svf = p->svf ? p->svf : h;
    for (cl_int first = 0; first < n; first += batch) {
        const cl_int count = n - first < batch ? n - first : batch;
        ocls_arg sa[9] = {OCLS_ARG(h), OCLS_ARG(H), OCLS_ARG(Wi), OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets),
                          OCLS_ARG(nlev), OCLS_ARG(rays), OCLS_ARG(seeds), OCLS_ARG(first)};
        const cl_int table_stride = count + 1;
        ocls_arg a[17] = {OCLS_ARG(h), OCLS_ARG(H), OCLS_ARG(Wi), OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets),
                          OCLS_ARG(nlev), OCLS_ARG(rays), OCLS_ARG(angle_arg), OCLS_ARG(svf), OCLS_ARG(seeds),
                          OCLS_ARG(cell), OCLS_ARG(stride), OCLS_ARG(first), OCLS_ARG(count), OCLS_ARG(band),
                          OCLS_ARG(table), OCLS_ARG(table_stride)};
        if ((st = ocls_set_args(ps, seeder, sa, 9)) != OCLSHADE_OK ||
            (st = ocls_launch_3d(ps, seeder, seed_extent(p->cols), seed_extent(p->rows),
                                 count, group, width)) != OCLSHADE_OK)
            return st;
        /* with blocks, each block's rays (the seeds keep the middle block's: kernels/horizon.cl, "Seeds") */
        if ((j->bands && (st = upload_batch_table(ps, j, table, first, count)) != OCLSHADE_OK) ||
            (st = ocls_set_args(ps, walker, a, j->bands ? 17 : 14)) != OCLSHADE_OK ||
            (st = ocls_launch_3d(ps, walker, Wi, H, p->svf ? 1 : count, group, width)) != OCLSHADE_OK)
            return st;
    }
    return OCLSHADE_OK;
}

/* The blocks' bands and table for one azimuth (-D OCLS_SUN_TABLE; HorizonCaster._enqueuer): per
 * block its ray, then for the walk (not `swept`) (-inf, inf, its cell sizes) (clamped: never in
 * blocks) */
static oclshade_status upload_block_rays(ocls_pass *ps, const horizon_job *j, cl_mem band, cl_mem table, int swept)
{
    const size_t per = swept ? 1 : 2, bytes = sizeof(cl_float4) * per * (size_t)j->nbands;
    cl_float4 *rows = (cl_float4 *)malloc(bytes);
    if (rows == NULL) return ocls_fail(ps->lib, OCLSHADE_OUT_OF_MEMORY, 0, "no host memory for the blocks' rays");
    for (int b = 0; b < j->nbands; ++b) {
        const cl_float2 block_cell = band_cell(j, &j->bands[b]);
        const cl_float4 more = {{-INFINITY, INFINITY, block_cell.s[0], block_cell.s[1]}};
        rows[per * b] = band_ray(j, &j->bands[b], j->p->azimuth);
        if (!swept) rows[per * b + 1] = more;
    }
    oclshade_status st = ocls_upload(ps, table, 0, rows, bytes, "the blocks' horizon rays");
    free(rows);
    if (st == OCLSHADE_OK)
        st = ocls_upload(ps, band, 0, j->band, sizeof(cl_int) * ((size_t)j->p->rows + (size_t)j->p->cols),
                         "the blocks' bands");
    return st;
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
    const int tabled = j->bands != NULL;   /* blocks walked or swept in one launch from their table */
    const size_t band_bytes = sizeof(cl_int) * ((size_t)p->rows + W), strips_bytes = sizeof(cl_float4) * 2 * (size_t)j->nbands;
    cl_mem band = NULL, strips = NULL;
    if ((st = ocls_bind_out(ps, &p->angle, p->rows, 4 * W, "angle", &angle)) != OCLSHADE_OK ||
        (seeded && (st = ocls_scratch(ps, 8 * (size_t)seed_rows * (size_t)seed_cols, "horizon seeds", &seeds)) != OCLSHADE_OK) ||
        (tabled && ((st = ocls_scratch(ps, band_bytes, "the blocks' bands", &band)) != OCLSHADE_OK ||
                    (st = ocls_scratch(ps, strips_bytes, "the blocks' horizon rays", &strips)) != OCLSHADE_OK)) ||
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
        ocls_def_flag(&d, "OCLS_SUN_TABLE", tabled);
        if ((st = ocls_kernel(ps, "horizon.cl", &d, "horizon_sweep", &sweeper)) != OCLSHADE_OK ||
            (tabled && (st = upload_block_rays(ps, j, band, strips, 1)) != OCLSHADE_OK))
            return st;
        ocls_arg a[8] = {OCLS_ARG(h), OCLS_ARG(H), OCLS_ARG(Wi), OCLS_ARG(j->ray), OCLS_ARG(angle_arg), OCLS_ARG(svf),
                         OCLS_ARG(band), OCLS_ARG(strips)};
        return (st = ocls_set_args(ps, sweeper, a, tabled ? 8 : 6)) != OCLSHADE_OK ? st :
               ocls_launch(ps, sweeper, (p->cols + lanes - 1) / lanes, H, group, width);
    }
    kernel_entry *k, *seeder = NULL;
    ocls_defines table_defines = d;
    ocls_def_flag(&table_defines, "OCLS_SUN_TABLE", tabled);
    if ((st = ocls_kernel(ps, "horizon.cl", &table_defines, "horizon_cells", &k)) != OCLSHADE_OK ||
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
    ocls_arg a[14] = {OCLS_ARG(h), OCLS_ARG(H), OCLS_ARG(Wi), OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets),
                      OCLS_ARG(nlev), OCLS_ARG(j->ray), OCLS_ARG(angle_arg), OCLS_ARG(svf), OCLS_ARG(seeds_arg),
                      OCLS_ARG(cell), OCLS_ARG(bounds), OCLS_ARG(band), OCLS_ARG(strips)};
    if (tabled && (st = upload_block_rays(ps, j, band, strips, 0)) != OCLSHADE_OK) return st;
    return (st = ocls_set_args(ps, k, a, tabled ? 14 : p->clamped ? 12 : 11)) != OCLSHADE_OK ? st :
           ocls_launch(ps, k, Wi, H, group, width);
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
