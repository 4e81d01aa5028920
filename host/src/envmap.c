/* envmap.c — cube maps on the device (kernels/envmap.cl cube_border, latlong_to_cube,
 * cube_to_latlong, cube_face_store; oclshade/envmap/cube.py DeviceCubeMap, latlong_to_cube;
 * oclshade/scene/generate.py generate_cube). */
#include "internal.h"

#include <string.h>

#define MAX_FACE 8192   /* oclshade/envmap/cube.py MAX_FACE */

void oclshade_envmap_params_init(oclshade_envmap_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
}

enum { CUBE_BORDER, LATLONG_TO_CUBE, CUBE_TO_LATLONG, CUBE_FACE_STORE };

typedef struct envmap_job {
    const oclshade_envmap_params *p;
    int op;
} envmap_job;

static oclshade_status envmap_job_for(oclshade *lib, const oclshade_envmap_params *p, int op, envmap_job *j)
{
    j->p = p;
    j->op = op;
    if (p == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params must point to oclshade_envmap_params, got NULL");
    if (p->face < 1 || p->face > MAX_FACE)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "face must be the cube face size in 1..%d, got %d", MAX_FACE, p->face);
    if (op == CUBE_BORDER) return OCLSHADE_OK;
    if (op == CUBE_FACE_STORE)
        return p->face_index >= 0 && p->face_index < 6 ? OCLSHADE_OK
               : ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "face_index must be in 0..5 (+X, -X, +Y, -Y, +Z, -Z), got %d",
                           p->face_index);
    const int min_width = op == LATLONG_TO_CUBE ? 2 : 1;
    if (p->height < 1 || p->height > 4 * MAX_FACE || p->width < min_width || p->width > 4 * MAX_FACE)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "height and width of the lat-long map must be in 1..%d and "
                         "%d..%d, got %d, %d", 4 * MAX_FACE, min_width, 4 * MAX_FACE, p->height, p->width);
    return OCLSHADE_OK;
}

static oclshade_status envmap_body(ocls_pass *ps, const void *params)
{
    const envmap_job *j = (const envmap_job *)params;
    const oclshade_envmap_params *p = j->p;
    const size_t row = 16 * (size_t)p->width;
    cl_mem ll = NULL;
    oclshade_status st = OCLSHADE_OK;
    if (j->op == LATLONG_TO_CUBE) st = ocls_bind_in(ps, &p->latlong, p->height, row, "latlong", &ll);
    if (j->op == CUBE_TO_LATLONG) st = ocls_bind_out(ps, &p->latlong, p->height, row, "latlong", &ll);
    if (j->op == CUBE_FACE_STORE) st = ocls_bind_in(ps, &p->frame, p->face, 16 * (size_t)p->face, "frame", &ll);
    if (st != OCLSHADE_OK || !ps->run) return st;
    const ocls_defines none = {0};   /* no -D options */
    kernel_entry *k;
    const cl_int n = p->face, H = p->height, W = p->width, f = p->face_index;
    if (j->op == CUBE_FACE_STORE) {
        const ocls_arg a[4] = {OCLS_ARG(ll), OCLS_ARG(n), OCLS_ARG(f), OCLS_ARG(p->cube)};
        if ((st = ocls_kernel(ps, "envmap.cl", &none, "cube_face_store", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 4)) != OCLSHADE_OK)
            return st;
        return ocls_launch(ps, k, n, n, 64, 16);   /* Runtime.grid_2d(k, N, N) */
    }
    if (j->op == CUBE_TO_LATLONG) {
        const ocls_arg a[5] = {OCLS_ARG(p->cube), OCLS_ARG(n), OCLS_ARG(ll), OCLS_ARG(H), OCLS_ARG(W)};
        if ((st = ocls_kernel(ps, "envmap.cl", &none, "cube_to_latlong", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 5)) != OCLSHADE_OK)
            return st;
        return ocls_launch(ps, k, W, H, 64, 16);   /* Runtime.grid_2d(k, W, H) */
    }
    if (j->op == LATLONG_TO_CUBE) {   /* the face interiors, then their border */
        const ocls_arg a[5] = {OCLS_ARG(ll), OCLS_ARG(H), OCLS_ARG(W), OCLS_ARG(p->cube), OCLS_ARG(n)};
        if ((st = ocls_kernel(ps, "envmap.cl", &none, "latlong_to_cube", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 5)) != OCLSHADE_OK || (st = ocls_launch_3d(ps, k, n, n, 6, 64, 16)) != OCLSHADE_OK)
            return st;
    }
    const ocls_arg b[2] = {OCLS_ARG(p->cube), OCLS_ARG(n)};
    if ((st = ocls_kernel(ps, "envmap.cl", &none, "cube_border", &k)) != OCLSHADE_OK ||
        (st = ocls_set_args(ps, k, b, 2)) != OCLSHADE_OK)
        return st;
    return ocls_launch_3d(ps, k, n + 2, 4, 6, 0, 0);   /* (N + 2, 4, 6), the driver's local size */
}

oclshade_status oclshade_envmap_scratch_size(oclshade *lib, const oclshade_envmap_params *params, size_t *bytes)
{
    envmap_job j;
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    /* the lat-long map's pitch when one is set, else the face frame's (cube_face_store) */
    const int op = params != NULL && params->latlong.buffer == NULL && params->frame.buffer != NULL ? CUBE_FACE_STORE
                                                                                                    : CUBE_TO_LATLONG;
    if (st == OCLSHADE_OK) st = envmap_job_for(lib, params, op, &j);
    return st != OCLSHADE_OK ? st : ocls_plan(lib, envmap_body, &j, bytes);
}

static oclshade_status envmap_enqueue(oclshade *lib, cl_command_queue queue, const oclshade_envmap_params *p, int op,
                                      cl_uint nwait, const cl_event *wait, cl_event *event)
{
    envmap_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = envmap_job_for(lib, p, op, &j);
    if (st != OCLSHADE_OK) return st;
    const size_t m = (size_t)p->face + 2;
    const int cube_use = op == CUBE_TO_LATLONG ? OCLS_IN : OCLS_INOUT;
    if ((st = ocls_use_buffer(lib, &uses, "cube", p->cube, 16 * 6 * m * m, cube_use)) != OCLSHADE_OK ||
        (op == CUBE_FACE_STORE &&
         (st = ocls_use_field(lib, &uses, "frame", &p->frame, p->face, 16 * (size_t)p->face, OCLS_IN)) != OCLSHADE_OK) ||
        ((op == LATLONG_TO_CUBE || op == CUBE_TO_LATLONG) &&
         (st = ocls_use_field(lib, &uses, "latlong", &p->latlong, p->height, 16 * (size_t)p->width,
                              op == LATLONG_TO_CUBE ? OCLS_IN : OCLS_OUT)) != OCLSHADE_OK))
        return st;
    return ocls_enqueue(lib, queue, p->scratch, &uses, envmap_body, &j, nwait, wait, event);
}

oclshade_status oclshade_enqueue_cube_border(oclshade *lib, cl_command_queue queue, const oclshade_envmap_params *params,
                                             cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                             cl_event *event)
{
    return envmap_enqueue(lib, queue, params, CUBE_BORDER, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_latlong_to_cube(oclshade *lib, cl_command_queue queue,
                                                 const oclshade_envmap_params *params, cl_uint num_events_in_wait_list,
                                                 const cl_event *event_wait_list, cl_event *event)
{
    return envmap_enqueue(lib, queue, params, LATLONG_TO_CUBE, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_cube_to_latlong(oclshade *lib, cl_command_queue queue,
                                                 const oclshade_envmap_params *params, cl_uint num_events_in_wait_list,
                                                 const cl_event *event_wait_list, cl_event *event)
{
    return envmap_enqueue(lib, queue, params, CUBE_TO_LATLONG, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_cube_face_store(oclshade *lib, cl_command_queue queue,
                                                 const oclshade_envmap_params *params, cl_uint num_events_in_wait_list,
                                                 const cl_event *event_wait_list, cl_event *event)
{
    return envmap_enqueue(lib, queue, params, CUBE_FACE_STORE, num_events_in_wait_list, event_wait_list, event);
}
