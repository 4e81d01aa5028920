/* compose.c — the final frame (kernels/compose.cl; oclshade/compose.py compose). */
#include "internal.h"

#include <math.h>
#include <string.h>

void oclshade_compose_params_init(oclshade_compose_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
    p->rotation[0] = p->rotation[4] = p->rotation[8] = 1.0;
    p->azimuth = 315.0;   /* Lighting() */
    p->elevation = 45.0;
    p->ssaa = 1;
    p->sun_intensity = 2.0;
    p->sky[0] = 0.21; p->sky[1] = 0.24; p->sky[2] = 0.30;
    p->background[0] = 0.45; p->background[1] = 0.62; p->background[2] = 0.85;
}

void oclshade_compose_set_camera(oclshade_compose_params *p, const oclshade_camera *camera)
{
    if (p == NULL || camera == NULL) return;
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) p->rotation[3 * r + c] = camera->view[4 * r + c];
        p->translation[r] = camera->view[4 * r + 3];
    }
}

#define MAX_SSAA 8   /* oclshade/compose.py MAX_SSAA */

typedef struct compose_job {
    const oclshade_compose_params *p;
    int sample_rows, sample_cols;   /* the inputs: height * ssaa x width * ssaa */
    cl_float4 sun, sky, up, background;
    cl_float falloff;               /* point light: r0^2 (0: none) */
} compose_job;

static oclshade_status compose_job_for(oclshade *lib, const oclshade_compose_params *p, compose_job *j)
{
    oclshade_status st;
    memset(j, 0, sizeof *j);
    if (p == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params must point to oclshade_compose_params, got NULL");
    if ((st = ocls_check_size(lib, "height", p->height, "width", p->width)) != OCLSHADE_OK) return st;
    if (p->linear != 0 && p->linear != 1)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "linear must be 0 (8-bit sRGB) or 1 (float4 linear), got %d",
                         p->linear);
    if (p->ssaa < 1 || p->ssaa > MAX_SSAA)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "ssaa must be an integer in 1..%d (samples per pixel along "
                         "each axis), got %d", MAX_SSAA, p->ssaa);
    if ((st = ocls_check_size(lib, "height * ssaa", p->height * p->ssaa, "width * ssaa", p->width * p->ssaa)) != OCLSHADE_OK)
        return st;
    j->sample_rows = p->height * p->ssaa;
    j->sample_cols = p->width * p->ssaa;
    if (p->point_light != 0 && p->point_light != 1)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "point_light must be 0 (the sun: azimuth, elevation) or 1 "
                         "(a point light at light_position), got %d", p->point_light);
    double s[3];
    if (!p->point_light && oclshade_sun_vector(p->azimuth, p->elevation, s) != OCLSHADE_OK)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "azimuth must be finite and elevation in [-90, 90] degrees, "
                         "got %g, %g", p->azimuth, p->elevation);
    if (p->point_light) {
        for (int i = 0; i < 3; ++i)
            if (!isfinite(p->light_position[i]) || !isfinite(p->translation[i]))
                return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "light_position and translation must be finite "
                                 "(world metres; the view's translation), got light_position[%d] %g, translation[%d] %g",
                                 i, p->light_position[i], i, p->translation[i]);
        if (!(isfinite(p->light_distance) && p->light_distance >= 0.0))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "light_distance must be the falloff's reference "
                             "distance, > 0 metres, or 0 for no falloff, got %g", p->light_distance);
    }
    if (!(isfinite(p->sun_intensity) && p->sun_intensity >= 0.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "sun_intensity must be >= 0, got %g", p->sun_intensity);
    for (int i = 0; i < 3; ++i)
        if (!(isfinite(p->sky[i]) && p->sky[i] >= 0.0 && isfinite(p->background[i]) && p->background[i] >= 0.0))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "sky and background must be 3 non-negative linear RGB "
                             "values each, got sky[%d] %g, background[%d] %g", i, p->sky[i], i, p->background[i]);
    for (int i = 0; i < 9; ++i)
        if (!isfinite(p->rotation[i]))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "rotation must be finite, element %d is %g", i, p->rotation[i]);
    /* Lighting.light_view: camera.rotation @ sun.vector(), or a point light's
     * view[:3, :3] @ position + view[:3, 3]; Lighting.up_view: rotation[:, 2] */
    const double *R = p->rotation, *L = p->light_position;
    for (int r = 0; r < 3; ++r) {
        j->sun.s[r] = p->point_light
                          ? (cl_float)((R[3 * r] * L[0] + R[3 * r + 1] * L[1] + R[3 * r + 2] * L[2]) + p->translation[r])
                          : (cl_float)(R[3 * r] * s[0] + R[3 * r + 1] * s[1] + R[3 * r + 2] * s[2]);
        j->up.s[r] = (cl_float)R[3 * r + 2];
    }
    j->falloff = (cl_float)(p->light_distance * p->light_distance);   /* Lighting.falloff: d * d, then float32 */
    j->sun.s[3] = (cl_float)p->sun_intensity;
    for (int i = 0; i < 3; ++i) {
        j->sky.s[i] = (cl_float)p->sky[i];
        j->background.s[i] = (cl_float)p->background[i];
    }
    j->p = p;
    return OCLSHADE_OK;
}

static oclshade_status compose_body(ocls_pass *ps, const void *params)
{
    const compose_job *j = (const compose_job *)params;
    const oclshade_compose_params *p = j->p;
    const size_t sw = (size_t)j->sample_cols;
    const int sh = j->sample_rows;
    cl_mem pos, nrm, alb, shadow, ao, image;
    oclshade_status st;
    if ((st = ocls_bind_in(ps, &p->position, sh, 16 * sw, "position", &pos)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->normal, sh, 16 * sw, "normal", &nrm)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->albedo, sh, 16 * sw, "albedo", &alb)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->shadow, sh, 4 * sw, "shadow", &shadow)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->ao, sh, 4 * sw, "ao", &ao)) != OCLSHADE_OK ||
        (st = ocls_bind_out(ps, &p->image, p->height, (p->linear ? 16u : 4u) * (size_t)p->width, "image", &image)) !=
            OCLSHADE_OK ||
        !ps->run)
        return st;
    ocls_defines d = {0};   /* ComposeFeatures.defines */
    ocls_def_flag(&d, "OCLS_SHADOW", shadow != NULL);
    ocls_def_flag(&d, "OCLS_AO", ao != NULL);
    ocls_def_flag(&d, "OCLS_LINEAR", p->linear);
    ocls_def_flag(&d, "OCLS_POINT_LIGHT", p->point_light);
    kernel_entry *k;
    if ((st = ocls_kernel(ps, "compose.cl", &d, "compose", &k)) != OCLSHADE_OK) return st;
    const cl_int width = p->width, height = p->height, ssaa = p->ssaa;
    ocls_arg a[14] = {OCLS_ARG(pos), OCLS_ARG(nrm), OCLS_ARG(alb), OCLS_ARG(width), OCLS_ARG(height), OCLS_ARG(ssaa),
                      OCLS_ARG(j->sun), OCLS_ARG(j->sky), OCLS_ARG(j->up), OCLS_ARG(j->background)};
    int na = 10;
    if (p->point_light) { a[na].size = sizeof j->falloff; a[na++].value = &j->falloff; }
    if (shadow) { a[na].size = sizeof shadow; a[na++].value = &shadow; }
    if (ao) { a[na].size = sizeof ao; a[na++].value = &ao; }
    a[na].size = sizeof image;
    a[na++].value = &image;
    if ((st = ocls_set_args(ps, k, a, na)) != OCLSHADE_OK) return st;
    return ocls_launch(ps, k, width * height, 0, 64, 0);   /* 1-D, Runtime.local_size(kernel, 64) */
}

oclshade_status oclshade_compose_scratch_size(oclshade *lib, const oclshade_compose_params *params, size_t *bytes)
{
    compose_job j;
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st == OCLSHADE_OK) st = compose_job_for(lib, params, &j);
    return st != OCLSHADE_OK ? st : ocls_plan(lib, compose_body, &j, bytes);
}

oclshade_status oclshade_enqueue_compose(oclshade *lib, cl_command_queue queue, const oclshade_compose_params *p,
                                         cl_uint num_events_in_wait_list, const cl_event *event_wait_list, cl_event *event)
{
    compose_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = compose_job_for(lib, p, &j);
    if (st != OCLSHADE_OK) return st;
    const size_t sw = (size_t)j.sample_cols;
    const int sh = j.sample_rows;
    if ((st = ocls_use_field(lib, &uses, "position", &p->position, sh, 16 * sw, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_field(lib, &uses, "normal", &p->normal, sh, 16 * sw, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_field(lib, &uses, "albedo", &p->albedo, sh, 16 * sw, OCLS_IN)) != OCLSHADE_OK ||
        (p->shadow.buffer && (st = ocls_use_field(lib, &uses, "shadow", &p->shadow, sh, 4 * sw, OCLS_IN)) != OCLSHADE_OK) ||
        (p->ao.buffer && (st = ocls_use_field(lib, &uses, "ao", &p->ao, sh, 4 * sw, OCLS_IN)) != OCLSHADE_OK) ||
        (st = ocls_use_field(lib, &uses, "image", &p->image, p->height, (p->linear ? 16u : 4u) * (size_t)p->width,
                             OCLS_OUT)) != OCLSHADE_OK)
        return st;
    return ocls_enqueue(lib, queue, p->scratch, &uses, compose_body, &j, num_events_in_wait_list, event_wait_list, event);
}
