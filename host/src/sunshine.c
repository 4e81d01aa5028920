/* sunshine.c — sunshine over time (kernels/sunshine.cl sunshine_masks / sunshine_horizons;
 * oclshade/sunshine/accumulate.py SunshineCaster) and the zeroing of accumulators. */
#include "internal.h"

#include <math.h>
#include <string.h>

void oclshade_sunshine_params_init(oclshade_sunshine_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
    p->dx = p->dy = 1.0;
    p->elevation = 45.0;
    p->seconds = 1;
}

typedef struct sunshine_job {
    const oclshade_sunshine_params *p;
    int horizons;          /* 1: sunshine_horizons (low, high), 0: sunshine_masks (mask) */
    cl_float2 cell;
    cl_float4 sunvec;
    cl_float hours, frac, elevation;
} sunshine_job;

static oclshade_status sunshine_job_for(oclshade *lib, const oclshade_sunshine_params *p, sunshine_job *j)
{
    oclshade_status st;
    memset(j, 0, sizeof *j);
    if (p == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params must point to oclshade_sunshine_params, got NULL");
    if ((st = ocls_check_size(lib, "rows", p->rows, "cols", p->cols)) != OCLSHADE_OK) return st;
    if (!(isfinite(p->dx) && p->dx > 0.0 && isfinite(p->dy) && p->dy > 0.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "dx and dy must be positive finite cell sizes, got %g, %g", p->dx, p->dy);
    double v[3];
    if (oclshade_sun_vector(p->azimuth, p->elevation, v) != OCLSHADE_OK || !(p->elevation > 0.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "azimuth must be finite and elevation in (0, 90] degrees "
                         "(daylight suns only), got %g, %g", p->azimuth, p->elevation);
    if (p->seconds < 1)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "seconds must be >= 1 (the sun's weight), got %lu",
                         (unsigned long)p->seconds);
    if (p->sun == NULL && p->cast == NULL && p->beam == NULL)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "at least one of sun, cast, beam must be a buffer");
    const int has_mask = p->mask.buffer != NULL, has_low = p->low.buffer != NULL, has_high = p->high.buffer != NULL;
    if (has_mask == (has_low || has_high) || has_low != has_high)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "give either mask (the shadow pass's) or both low and high "
                         "(horizon angles), got mask %s, low %s, high %s", has_mask ? "set" : "NULL",
                         has_low ? "set" : "NULL", has_high ? "set" : "NULL");
    j->horizons = has_low;
    if (j->horizons && !(p->fraction >= 0.0 && p->fraction <= 1.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "fraction must be in [0, 1] (the sun's azimuth between "
                         "low's and high's), got %g", p->fraction);
    for (int i = 0; i < 3; ++i) j->sunvec.s[i] = (cl_float)v[i];   /* _sun_args: Sun.vector as float32 */
    j->sunvec.s[3] = 0.0f;
    j->cell.s[0] = (cl_float)p->dx;
    j->cell.s[1] = (cl_float)p->dy;
    j->hours = (cl_float)((double)p->seconds / 3600.0);
    j->frac = (cl_float)p->fraction;
    j->elevation = (cl_float)p->elevation;
    j->p = p;
    return OCLSHADE_OK;
}

static oclshade_status sunshine_body(ocls_pass *ps, const void *params)
{
    const sunshine_job *j = (const sunshine_job *)params;
    const oclshade_sunshine_params *p = j->p;
    const size_t W = (size_t)p->cols;
    cl_mem h, mask = NULL, low = NULL, high = NULL;
    oclshade_status st;
    if ((st = ocls_bind_in(ps, &p->heights, p->rows, 4 * W, "heights", &h)) != OCLSHADE_OK ||
        (!j->horizons && (st = ocls_bind_in(ps, &p->mask, p->rows, W, "mask", &mask)) != OCLSHADE_OK) ||
        (j->horizons && (st = ocls_bind_in(ps, &p->low, p->rows, 4 * W, "low", &low)) != OCLSHADE_OK) ||
        (j->horizons && (st = ocls_bind_in(ps, &p->high, p->rows, 4 * W, "high", &high)) != OCLSHADE_OK) || !ps->run)
        return st;
    /* an output not compiled in is not written: its argument is any buffer of the call */
    cl_mem sun = p->sun ? p->sun : h, cast = p->cast ? p->cast : h, beam = p->beam ? p->beam : h;
    ocls_defines d = {0};   /* SunshineCaster._kernel */
    ocls_def_flag(&d, "OCLS_OUT_SUN", p->sun != NULL);
    ocls_def_flag(&d, "OCLS_OUT_CAST", p->cast != NULL);
    ocls_def_flag(&d, "OCLS_OUT_BEAM", p->beam != NULL);
    kernel_entry *k;
    if ((st = ocls_kernel(ps, "sunshine.cl", &d, j->horizons ? "sunshine_horizons" : "sunshine_masks", &k)) != OCLSHADE_OK)
        return st;
    const cl_int H = p->rows, Wi = p->cols;
    const cl_uint weight = p->seconds;
    ocls_arg a[14] = {OCLS_ARG(h), OCLS_ARG(H), OCLS_ARG(Wi), OCLS_ARG(j->cell)};
    int na = 4;
    if (j->horizons) {
        ocls_arg more[4] = {OCLS_ARG(low), OCLS_ARG(high), OCLS_ARG(j->frac), OCLS_ARG(j->elevation)};
        memcpy(a + na, more, sizeof more);
        na += 4;
    } else {
        ocls_arg more[1] = {OCLS_ARG(mask)};
        a[na++] = more[0];
    }
    ocls_arg tail[6] = {OCLS_ARG(j->sunvec), OCLS_ARG(weight), OCLS_ARG(j->hours), OCLS_ARG(sun), OCLS_ARG(cast),
                        OCLS_ARG(beam)};
    memcpy(a + na, tail, sizeof tail);
    na += 6;
    if ((st = ocls_set_args(ps, k, a, na)) != OCLSHADE_OK) return st;
    return ocls_launch(ps, k, Wi, H, 64, 16);   /* Runtime.grid_2d(kernel, W, H) */
}

oclshade_status oclshade_sunshine_scratch_size(oclshade *lib, const oclshade_sunshine_params *params, size_t *bytes)
{
    sunshine_job j;
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st == OCLSHADE_OK) st = sunshine_job_for(lib, params, &j);
    return st != OCLSHADE_OK ? st : ocls_plan(lib, sunshine_body, &j, bytes);
}

oclshade_status oclshade_enqueue_sunshine(oclshade *lib, cl_command_queue queue, const oclshade_sunshine_params *p,
                                          cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                          cl_event *event)
{
    sunshine_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = sunshine_job_for(lib, p, &j);
    if (st != OCLSHADE_OK) return st;
    const size_t W = (size_t)p->cols, n = (size_t)p->rows * W;
    if ((st = ocls_use_field(lib, &uses, "heights", &p->heights, p->rows, 4 * W, OCLS_IN)) != OCLSHADE_OK ||
        (!j.horizons && (st = ocls_use_field(lib, &uses, "mask", &p->mask, p->rows, W, OCLS_IN)) != OCLSHADE_OK) ||
        (j.horizons && (st = ocls_use_field(lib, &uses, "low", &p->low, p->rows, 4 * W, OCLS_IN)) != OCLSHADE_OK) ||
        (j.horizons && (st = ocls_use_field(lib, &uses, "high", &p->high, p->rows, 4 * W, OCLS_IN)) != OCLSHADE_OK) ||
        (p->sun && (st = ocls_use_buffer(lib, &uses, "sun", p->sun, 4 * n, OCLS_INOUT)) != OCLSHADE_OK) ||
        (p->cast && (st = ocls_use_buffer(lib, &uses, "cast", p->cast, 4 * n, OCLS_INOUT)) != OCLSHADE_OK) ||
        (p->beam && (st = ocls_use_buffer(lib, &uses, "beam", p->beam, 8 * n, OCLS_INOUT)) != OCLSHADE_OK))
        return st;
    return ocls_enqueue(lib, queue, p->scratch, &uses, sunshine_body, &j, num_events_in_wait_list, event_wait_list, event);
}

/* ------------------------------------------------------------------ zeroing */

typedef struct zero_job { cl_mem buffer; size_t bytes; } zero_job;

static oclshade_status zero_body(ocls_pass *ps, const void *params)
{
    const zero_job *z = (const zero_job *)params;
    return ocls_zero(ps, z->buffer, z->bytes, "buffer");
}

oclshade_status oclshade_enqueue_zero(oclshade *lib, cl_command_queue queue, cl_mem buffer, size_t bytes,
                                      cl_uint num_events_in_wait_list, const cl_event *event_wait_list, cl_event *event)
{
    ocls_uses uses = {0};
    zero_job z = {buffer, bytes};
    oclshade_status st = ocls_enter(lib);
    if (st != OCLSHADE_OK) return st;
    if (bytes == 0) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must be >= 1 (the bytes to zero), got 0");
    if ((st = ocls_use_buffer(lib, &uses, "buffer", buffer, bytes, OCLS_OUT)) != OCLSHADE_OK) return st;
    return ocls_enqueue(lib, queue, NULL, &uses, zero_body, &z, num_events_in_wait_list, event_wait_list, event);
}
