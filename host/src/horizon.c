/* horizon.c — horizon angles and sky-view factor sums (kernels/horizon.cl horizon_cells;
 * oclshade/horizon/caster.py HorizonCaster). */
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

typedef struct horizon_job {
    const oclshade_horizon_params *p;
    oclshade_pyramid_layout lay;
    cl_float4 ray;
    cl_float4 *rays;           /* n_azimuths > 0: each azimuth's ray (malloc'd; horizon_job_free) */
} horizon_job;

static void horizon_job_free(horizon_job *j) { free(j->rays); j->rays = NULL; }

/* HorizonCaster's sweeps(): with a search radius, a ray crossing at most the knob sweep_cells patch
 * columns and rows within it (the same float64 product of the float32 ray) takes horizon_sweep
 * (kernels/horizon.cl, "The sweep": the same angles as the walk, bit for bit), on maps of 2 rows
 * and columns or more; past that reach, where the knob sweep_far is 2.  Its pilot (sweep_far 1,
 * oclshade/horizon/pilot.py) is the Python host's alone: it times both kernels and so waits for
 * the queue, while a call here only enqueues into the caller's pipeline; here 1 walks, as 0. */
static int sweeps(oclshade *lib, const horizon_job *j)
{
    const double ux = j->ray.s[0], uy = j->ray.s[1], radius = j->ray.s[3];
    return j->p->rows >= 2 && j->p->cols >= 2 && radius > 0.0 &&
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
    oclshade_pyramid_layout_for(p->rows, p->cols, &j->lay);
    cl_float u[2];
    ocls_horizontal_ray(p->azimuth, p->dx, p->dy, u);
    j->ray.s[0] = u[0];
    j->ray.s[1] = u[1];
    j->ray.s[2] = (cl_float)p->curvature;
    j->ray.s[3] = (cl_float)p->max_distance;
    j->p = p;
    if (p->n_azimuths > 0) {
        j->rays = (cl_float4 *)malloc(sizeof *j->rays * (size_t)p->n_azimuths);
        if (j->rays == NULL) return ocls_fail(lib, OCLSHADE_OUT_OF_MEMORY, 0, "no host memory for %d rays", p->n_azimuths);
        for (int k = 0; k < p->n_azimuths; ++k) {
            ocls_horizontal_ray(p->azimuths[k], p->dx, p->dy, u);
            j->rays[k] = j->ray;
            j->rays[k].s[0] = u[0];
            j->rays[k].s[1] = u[1];
        }
    }
    return OCLSHADE_OK;
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
    cl_mem angle, seeds, rays;
    oclshade_status st;
    if ((st = ocls_bind_out(ps, &p->angle, n * p->rows, 4 * W, "angle", &angle)) != OCLSHADE_OK ||
        (st = ocls_scratch(ps, 8 * seed_cells * (size_t)batch, "horizon seeds", &seeds)) != OCLSHADE_OK ||
        (st = ocls_scratch(ps, sizeof *j->rays * (size_t)n, "horizon rays", &rays)) != OCLSHADE_OK || !ps->run)
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
                                 count, group, width)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, walker, a, 14)) != OCLSHADE_OK ||
            (st = ocls_launch_3d(ps, walker, Wi, H, p->svf ? 1 : count, group, width)) != OCLSHADE_OK)
            return st;
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
    const int sweep = sweeps(lib, j), seeded = j->ray.s[3] == 0.0f;
    const int seed_rows = seeded ? seed_extent(p->rows) : 0, seed_cols = seeded ? seed_extent(p->cols) : 0;
    cl_mem h, angle, seeds = NULL;
    oclshade_status st;
    ocls_defines d = {0};
    ocls_def_flag(&d, "OCLS_OUT_ANGLE", p->angle.buffer != NULL);
    if (p->svf != NULL) ocls_def_int(&d, "OCLS_OUT_SVF", (int)p->svf_definition);
    ocls_def_flag(&d, "OCLS_CURVATURE", p->curvature > 0.0);
    ocls_def_flag(&d, "OCLS_MAX_DISTANCE", j->ray.s[3] > 0.0f);   /* never with n_azimuths (checked) */
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
        if ((st = ocls_set_args(ps, sweeper, a, 6)) != OCLSHADE_OK) return st;
        return ocls_launch(ps, sweeper, (p->cols + lanes - 1) / lanes, H, group, width);
    }
    kernel_entry *k, *seeder = NULL;
    if ((st = ocls_kernel(ps, "horizon.cl", &d, "horizon_cells", &k)) != OCLSHADE_OK ||
        (seeded && (st = ocls_kernel(ps, "horizon.cl", &d, "horizon_seeds", &seeder)) != OCLSHADE_OK))
        return st;
    const cl_int nlev = j->lay.levels;
    const cl_float2 cell = {{(cl_float)p->dx, (cl_float)p->dy}};
    ocls_arg sa[8] = {OCLS_ARG(h), OCLS_ARG(H), OCLS_ARG(Wi), OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets),
                      OCLS_ARG(nlev), OCLS_ARG(j->ray), OCLS_ARG(seeds)};
    if (seeded && ((st = ocls_set_args(ps, seeder, sa, 8)) != OCLSHADE_OK ||
                   (st = ocls_launch(ps, seeder, seed_cols, seed_rows, group, width)) != OCLSHADE_OK))
        return st;
    ocls_arg a[11] = {OCLS_ARG(h), OCLS_ARG(H), OCLS_ARG(Wi), OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets),
                      OCLS_ARG(nlev), OCLS_ARG(j->ray), OCLS_ARG(angle_arg), OCLS_ARG(svf), OCLS_ARG(seeds_arg),
                      OCLS_ARG(cell)};
    if ((st = ocls_set_args(ps, k, a, 11)) != OCLSHADE_OK) return st;
    return ocls_launch(ps, k, Wi, H, group, width);
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
