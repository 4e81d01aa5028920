/* pixels.c — per-pixel shadows over a G-buffer (kernels/shadow.cl shadow_pixels;
 * oclshade/screen_shadows.py ScreenShadowCaster). */
#include "internal.h"

#include <math.h>
#include <string.h>

#define CERT_TILE 16   /* PixelShadowFeatures builds with ShadowFeatures' defaults: CERT_TILE, CERT_K */
#define CERT_K 6

void oclshade_pixel_shadow_params_init(oclshade_pixel_shadow_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
    p->dx = p->dy = 1.0;
    p->azimuth = 315.0;
    p->elevation = 45.0;
    p->method = OCLSHADE_EXACT;
    p->force_q = 0;    /* exact; -1: Algo 1 (automatic q, a speed setting) */
    p->n_a_max = 16;   /* LodOptions() */
    p->k_dark = OCLSHADE_DEFAULT_K_DARK;
    p->k_bright = OCLSHADE_DEFAULT_K_BRIGHT;
}

typedef struct pixel_job {
    const oclshade_pixel_shadow_params *p;
    oclshade_pyramid_layout pyr;
    oclshade_coarse_layout coarse;
    oclshade_sun sun;
} pixel_job;

static oclshade_status pixel_job_for(oclshade *lib, const oclshade_pixel_shadow_params *p, pixel_job *j)
{
    oclshade_status st;
    memset(j, 0, sizeof *j);
    if (p == NULL)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params must point to oclshade_pixel_shadow_params, got NULL");
    if ((st = ocls_check_size(lib, "rows", p->rows, "cols", p->cols)) != OCLSHADE_OK ||
        (st = ocls_check_size(lib, "height", p->height, "width", p->width)) != OCLSHADE_OK)
        return st;
    if (!(isfinite(p->dx) && p->dx > 0.0 && isfinite(p->dy) && p->dy > 0.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "dx and dy must be positive finite cell sizes, got dx %g, dy %g",
                         p->dx, p->dy);
    if (!isfinite(p->azimuth))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "azimuth must be a finite number of degrees, got %g", p->azimuth);
    if (!(isfinite(p->elevation) && p->elevation >= -90.0 && p->elevation <= 90.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "elevation must be in [-90, 90] degrees, got %g", p->elevation);
    if (p->method < OCLSHADE_EXACT || p->method > OCLSHADE_DDA)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "method must be OCLSHADE_EXACT, OCLSHADE_PAPER, "
                         "OCLSHADE_MAXMIP or OCLSHADE_DDA (1..4), got %d", (int)p->method);
    if (!(p->k_dark >= 0.0 && p->k_dark <= 1.0 && p->k_bright >= 0.0 && p->k_bright <= 1.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "k_dark and k_bright must be in [0, 1] (paper 000 eq. 1), "
                         "got k_dark %g, k_bright %g", p->k_dark, p->k_bright);
    if (p->n_a_max < 1 || p->n_a_max > 256)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "n_a_max must be an integer in [1, 256], got %d", p->n_a_max);
    if (p->bias < -64 || p->bias > 64)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bias must be an integer in [-64, 64], got %d", p->bias);
    oclshade_pyramid_layout_for(p->rows, p->cols, &j->pyr);
    if (p->force_q < -1 || p->force_q > j->pyr.levels - 1)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "force_q must be -1 (Algo 1) or a level in [0, %d] for this "
                         "heightmap (%d levels), got %d", j->pyr.levels - 1, j->pyr.levels, p->force_q);
    if (p->flag.buffer == NULL && p->coefficient.buffer == NULL && p->lod.buffer == NULL)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "at least one of flag, coefficient, lod must have a buffer");
    oclshade_coarse_layout_for(p->rows, p->cols, &j->coarse);
    oclshade_sun_for(p->azimuth, p->elevation, p->dx, p->dy, &j->sun);
    j->p = p;
    return OCLSHADE_OK;
}

/* ScreenShadowCaster.shade_to_device and _args */
static oclshade_status pixel_body(ocls_pass *ps, const void *params)
{
    const pixel_job *j = (const pixel_job *)params;
    const oclshade_pixel_shadow_params *p = j->p;
    oclshade *lib = ps->lib;
    const size_t w = (size_t)p->width;
    cl_mem heights, pos, uv, grad, flag, coef, lod;
    oclshade_status st;
    if ((st = ocls_bind_in(ps, &p->heights, p->rows, 4u * (size_t)p->cols, "heights", &heights)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->position, p->height, 16 * w, "position", &pos)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->uv, p->height, 8 * w, "uv", &uv)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->uv_grad, p->height, 16 * w, "uv_grad", &grad)) != OCLSHADE_OK ||
        (st = ocls_bind_out(ps, &p->flag, p->height, w, "flag", &flag)) != OCLSHADE_OK ||
        (st = ocls_bind_out(ps, &p->coefficient, p->height, 4 * w, "coefficient", &coef)) != OCLSHADE_OK ||
        (st = ocls_bind_out(ps, &p->lod, p->height, w, "lod", &lod)) != OCLSHADE_OK || !ps->run)
        return st;
    /* PixelShadowFeatures.defines: the heightmap-space defines (flag -> mask), no self, lod */
    ocls_defines d = {0};
    const int certified = p->method == OCLSHADE_EXACT || p->method == OCLSHADE_MAXMIP;
    if (certified) {
        ocls_def_int(&d, "OCLS_CERT", CERT_TILE);
        ocls_def_int(&d, "OCLS_CERT_K", CERT_K);
    }
    ocls_def_int(&d, "OCLS_METHOD", (int)p->method);
    ocls_def_flag(&d, "OCLS_OUT_MASK", flag != NULL);
    ocls_def_flag(&d, "OCLS_OUT_COEF", coef != NULL);
    ocls_def_flag(&d, "OCLS_OUT_LOD", lod != NULL);
    ocls_def_flag(&d, "OCLS_OWN_BUILTINS", ocls_knob(lib, K_PIXELS_OWN_BUILTINS));
    kernel_entry *k;
    if ((st = ocls_kernel(ps, "shadow.cl", &d, "shadow_pixels", &k)) != OCLSHADE_OK) return st;
    const cl_int H = p->rows, W = p->cols, nlev = j->pyr.levels, width = p->width, height = p->height;
    const cl_int mode = j->sun.mode;
    cl_float4 ray, vec;
    cl_float2 kcoef;
    cl_int4 lodopt;
    for (int i = 0; i < 4; ++i) { ray.s[i] = j->sun.ray[i]; vec.s[i] = j->sun.vector[i]; }
    kcoef.s[0] = (cl_float)p->k_dark;
    kcoef.s[1] = (cl_float)p->k_bright;
    lodopt.s[0] = p->force_q;
    lodopt.s[1] = p->bias;
    lodopt.s[2] = p->n_a_max;
    lodopt.s[3] = 0;
    const ocls_arg a[] = {OCLS_ARG(heights), OCLS_ARG(p->coarse), OCLS_ARG(p->coarse_offsets), OCLS_ARG(H), OCLS_ARG(W),
                          OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets), OCLS_ARG(nlev), OCLS_ARG(pos), OCLS_ARG(uv),
                          OCLS_ARG(grad), OCLS_ARG(width), OCLS_ARG(height), OCLS_ARG(ray), OCLS_ARG(vec),
                          OCLS_ARG(kcoef), OCLS_ARG(mode), OCLS_ARG(lodopt), OCLS_ARG(flag), OCLS_ARG(coef),
                          OCLS_ARG(lod)};
    if ((st = ocls_set_args(ps, k, a, (int)N_ITEMS(a))) != OCLSHADE_OK) return st;
    return ocls_launch(ps, k, width, height, (size_t)ocls_knob(lib, K_PIXELS_GROUP), 16);
}

oclshade_status oclshade_pixel_shadows_scratch_size(oclshade *lib, const oclshade_pixel_shadow_params *params,
                                                    size_t *bytes)
{
    pixel_job j;
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st == OCLSHADE_OK) st = pixel_job_for(lib, params, &j);
    return st != OCLSHADE_OK ? st : ocls_plan(lib, pixel_body, &j, bytes);
}

oclshade_status oclshade_enqueue_pixel_shadows(oclshade *lib, cl_command_queue queue,
                                               const oclshade_pixel_shadow_params *p, cl_uint num_events_in_wait_list,
                                               const cl_event *event_wait_list, cl_event *event)
{
    pixel_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = pixel_job_for(lib, p, &j);
    if (st != OCLSHADE_OK) return st;
    const size_t w = (size_t)p->width;
    if ((st = ocls_use_field(lib, &uses, "heights", &p->heights, p->rows, 4u * (size_t)p->cols, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "pyramid", p->pyramid, j.pyr.pyramid_bytes, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "offsets", p->offsets, j.pyr.offsets_bytes, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "coarse", p->coarse, j.coarse.grids_bytes, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "coarse_offsets", p->coarse_offsets, j.coarse.offsets_bytes, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_field(lib, &uses, "position", &p->position, p->height, 16 * w, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_field(lib, &uses, "uv", &p->uv, p->height, 8 * w, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_field(lib, &uses, "uv_grad", &p->uv_grad, p->height, 16 * w, OCLS_IN)) != OCLSHADE_OK ||
        (p->flag.buffer && (st = ocls_use_field(lib, &uses, "flag", &p->flag, p->height, w, OCLS_OUT)) != OCLSHADE_OK) ||
        (p->coefficient.buffer &&
         (st = ocls_use_field(lib, &uses, "coefficient", &p->coefficient, p->height, 4 * w, OCLS_OUT)) != OCLSHADE_OK) ||
        (p->lod.buffer && (st = ocls_use_field(lib, &uses, "lod", &p->lod, p->height, w, OCLS_OUT)) != OCLSHADE_OK))
        return st;
    return ocls_enqueue(lib, queue, p->scratch, &uses, pixel_body, &j, num_events_in_wait_list, event_wait_list, event);
}
