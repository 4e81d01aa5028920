/* reflect.c — environment reflections around compose (kernels/reflect.cl reflect_weights,
 * reflect_apply, reflect_finish; oclshade/envmap/reflect.py Reflections).  reflect.cl is
 * written in paper 002's @IF meta-language: each material group's program is its source
 * specialised for the group's condition vector (specialize.c) and then built, as the Python
 * host's reflect_program does, so both hosts compile the same text. */
#include "internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define MAX_FACE 8192   /* oclshade/envmap/cube.py MAX_FACE */
#define MAX_CONE 45.0   /* oclshade/envmap/materials.py: roughness 1 is a cone of this half-angle */
#define DEG (3.14159265358979323846 / 180.0)   /* math.radians */

static const char BACKGROUND[] = "BACKGROUND";

void oclshade_reflect_params_init(oclshade_reflect_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
    p->ssaa = 1;
    p->intensity = 1.0;
    p->background = 1;
}

/* ------------------------------------------------------------------ host tables */

/* Material.conditions as reflect_program names it: the sorted names joined by blanks. */
static void vector_of(const oclshade_material *m, char out[32])
{
    out[0] = '\0';
    if (m->kind == OCLSHADE_DIFFUSE) return;
    snprintf(out, 32, "%sREFLECT%s", m->kind == OCLSHADE_GLOSSY ? "FRESNEL " : "", m->roughness > 0.0 ? " ROUGH" : "");
}

oclshade_status oclshade_reflect_tables(const oclshade_material *materials, int count, oclshade_reflect_groups *groups,
                                        cl_float4 *table)
{
    if (materials == NULL || groups == NULL || table == NULL || count < 1) return OCLSHADE_INVALID_ARGUMENT;
    memset(groups, 0, sizeof *groups);
    for (int k = 0; k < count; ++k) {
        const oclshade_material *m = &materials[k];
        int ok = (int)m->kind >= 0 && (int)m->kind <= 2 && m->roughness >= 0.0 && m->roughness <= 1.0 &&
                 m->fresnel >= 0.0 && m->fresnel <= 1.0 && m->cube >= 0 &&
                 !(m->kind == OCLSHADE_DIFFUSE && m->roughness > 0.0);
        for (int i = 0; i < 3; ++i) ok = ok && m->colour[i] >= 0.0 && m->colour[i] <= 1.0;
        if (!ok) return OCLSHADE_INVALID_ARGUMENT;
        char v[32];
        vector_of(m, v);
        int g = 0;
        while (v[0] && g < groups->count && strcmp(groups->vector[g], v) != 0) ++g;
        if (v[0] && g == groups->count) {   /* a new vector, kept sorted (Python: sorted(vectors, key=sorted)) */
            int at = 0;
            while (at < groups->count && strcmp(groups->vector[at], v) < 0) ++at;
            memmove(groups->vector[at + 1], groups->vector[at], (size_t)(groups->count - at) * sizeof groups->vector[0]);
            strcpy(groups->vector[at], v);
            ++groups->count;
        }
    }
    for (int k = 0; k < count; ++k) {
        const oclshade_material *m = &materials[k];
        char v[32];
        vector_of(m, v);
        int group = -1;
        for (int g = 0; v[0] && g < groups->count; ++g)
            if (strcmp(groups->vector[g], v) == 0) group = g;
        const double f0 = m->kind == OCLSHADE_GLOSSY ? m->fresnel : 1.0;   /* a mirror is F = 1 (uber builds) */
        cl_float4 *row = table + 3 * k;
        for (int i = 0; i < 3; ++i) {
            row[0].s[i] = (cl_float)m->colour[i];
            row[2].s[i] = m->kind == OCLSHADE_MIRROR ? (cl_float)m->colour[i] : 1.0f;
        }
        row[0].s[3] = (cl_float)f0;
        row[1].s[0] = (cl_float)tan((MAX_CONE * m->roughness) * DEG);   /* Material.cone */
        row[1].s[1] = (cl_float)group;
        row[1].s[2] = row[1].s[3] = 0.0f;
        row[2].s[3] = (cl_float)m->cube;
    }
    return OCLSHADE_OK;
}

/* ------------------------------------------------------------------ passes */

enum { WEIGHTS, APPLY, FINISH };

typedef struct reflect_job {
    const oclshade_reflect_params *p;
    int op;
    cl_float4 cam, v2w[3], w2c[3];
} reflect_job;

/* Reflections._cam, the rows of camera.rotation.T and of cube_frame(rotation) */
static void reflect_args(const oclshade_reflect_params *p, reflect_job *j)
{
    const double *V = p->camera.view;
    j->cam.s[0] = (cl_float)p->camera.sx;
    j->cam.s[1] = (cl_float)p->camera.sy;
    j->cam.s[2] = p->camera.projection == OCLSHADE_ORTHOGRAPHIC ? 1.0f : 0.0f;
    j->cam.s[3] = 0.0f;
    const double a = p->rotation * DEG, c = cos(a), s = sin(a);
    const double turn[3][3] = {{c, s, 0.0}, {-s, c, 0.0}, {0.0, 0.0, 1.0}};
    const double to_f[3][3] = {{1.0, 0.0, 0.0}, {0.0, 0.0, 1.0}, {0.0, -1.0, 0.0}};
    for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) {
            j->v2w[r].s[k] = (cl_float)V[4 * k + r];
            j->w2c[r].s[k] = (cl_float)(to_f[r][0] * turn[0][k] + to_f[r][1] * turn[1][k] + to_f[r][2] * turn[2][k]);
        }
        j->v2w[r].s[3] = j->w2c[r].s[3] = 0.0f;
    }
}

static oclshade_status reflect_job_for(oclshade *lib, const oclshade_reflect_params *p, int op, reflect_job *j)
{
    j->p = p;
    j->op = op;
    if (p == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params must point to oclshade_reflect_params, got NULL");
    if (p->width < 1 || p->height < 1 || p->width > 32768 || p->height > 32768)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "width and height must be in 1..32768, got %d, %d", p->width,
                         p->height);
    if (op == FINISH) return OCLSHADE_OK;
    if (p->ssaa < 1 || p->ssaa > 8) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "ssaa must be in 1..8, got %d", p->ssaa);
    if (p->camera.width != p->width * p->ssaa || p->camera.height != p->height * p->ssaa)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "camera must be the G-buffer's, %d x %d samples (width, "
                         "height times ssaa), got %d x %d", p->width * p->ssaa, p->height * p->ssaa, p->camera.width,
                         p->camera.height);
    if (!(p->camera.sx > 0.0) || !(p->camera.sy > 0.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "camera must come from oclshade_camera_look_at or "
                         "oclshade_camera_from_matrices (sx, sy > 0)");
    if (p->objects < 1) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "objects must be the material table's rows, >= 1, got %d", p->objects);
    if (p->groups.count < 0 || p->groups.count > OCLSHADE_MAX_GROUPS)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "groups.count must be in 0..%d, got %d", OCLSHADE_MAX_GROUPS,
                         p->groups.count);
    for (int g = 0; g < p->groups.count; ++g) {
        char message[256];
        size_t n;
        if (memchr(p->groups.vector[g], '\0', sizeof p->groups.vector[g]) == NULL ||
            !ocls_specialize("", p->groups.vector[g], NULL, 0, &n, message, sizeof message))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "groups.vector[%d] must be a condition vector of names "
                             "(oclshade_reflect_tables): %s", g, message);
    }
    if (op == APPLY) {
        if (p->face < 1 || p->face > MAX_FACE || p->cubes < 1)
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "face must be in 1..%d and cubes >= 1, got %d, %d", MAX_FACE,
                             p->face, p->cubes);
        if (!isfinite(p->rotation)) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "rotation must be a finite number of degrees, got %g", p->rotation);
        if (!(p->intensity >= 0.0) || !isfinite(p->intensity))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "intensity must be a finite number >= 0, got %g", p->intensity);
    }
    reflect_args(p, j);
    return OCLSHADE_OK;
}

static oclshade_status reflect_body(ocls_pass *ps, const void *params)
{
    const reflect_job *j = (const reflect_job *)params;
    const oclshade_reflect_params *p = j->p;
    const int ss = p->ssaa > 0 ? p->ssaa : 1;
    const int sw = p->width * ss, sh = p->height * ss;
    const cl_int ns = sw * sh, n = p->width * p->height;
    cl_mem pos = NULL, nrm = NULL, alb = NULL, obj = NULL, out = NULL, frame = NULL;
    oclshade_status st = OCLSHADE_OK;
    if (j->op == WEIGHTS || j->op == APPLY) {
        st = ocls_bind_in(ps, &p->position, sh, 16 * (size_t)sw, "position", &pos);
        if (st == OCLSHADE_OK) st = ocls_bind_in(ps, &p->normal, sh, 16 * (size_t)sw, "normal", &nrm);
        if (st == OCLSHADE_OK) st = ocls_bind_in(ps, &p->object, sh, 4 * (size_t)sw, "object", &obj);
    }
    if (st == OCLSHADE_OK && j->op == WEIGHTS) {
        st = ocls_bind_in(ps, &p->albedo, sh, 16 * (size_t)sw, "albedo", &alb);
        if (st == OCLSHADE_OK) st = ocls_bind_out(ps, &p->weighted, sh, 16 * (size_t)sw, "weighted", &out);
    }
    if (st == OCLSHADE_OK && j->op == FINISH) {
        st = ocls_bind_in(ps, &p->frame, p->height, 4 * (size_t)p->width, "frame", &frame);
        if (st == OCLSHADE_OK) st = ocls_bind_out(ps, &p->image, p->height, 4 * (size_t)p->width, "image", &out);
    }
    if (st != OCLSHADE_OK || !ps->run) return st;
    const ocls_defines none = {0};   /* no -D options: the variants are specialised sources */
    kernel_entry *k;
    if (j->op == FINISH) {   /* the kernel is the same in every variant: the BACKGROUND program's, as Python */
        const ocls_arg a[4] = {OCLS_ARG(n), OCLS_ARG(frame), OCLS_ARG(p->acc), OCLS_ARG(out)};
        if ((st = ocls_kernel_variant(ps, "reflect.cl", &none, BACKGROUND, "reflect_finish", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 4)) != OCLSHADE_OK)
            return st;
        return ocls_launch(ps, k, n, 0, 64, 0);
    }
    if (j->op == WEIGHTS) {
        if ((st = ocls_copy(ps, alb, out, 16 * (size_t)ns, "weighted")) != OCLSHADE_OK) return st;
        for (cl_int g = 0; g < p->groups.count; ++g) {
            const ocls_arg a[9] = {OCLS_ARG(ns), OCLS_ARG(pos), OCLS_ARG(nrm), OCLS_ARG(alb), OCLS_ARG(obj),
                                   OCLS_ARG(p->materials), OCLS_ARG(g), OCLS_ARG(j->cam), OCLS_ARG(out)};
            if ((st = ocls_kernel_variant(ps, "reflect.cl", &none, p->groups.vector[g], "reflect_weights", &k)) !=
                    OCLSHADE_OK ||
                (st = ocls_set_args(ps, k, a, 9)) != OCLSHADE_OK || (st = ocls_launch(ps, k, ns, 0, 64, 0)) != OCLSHADE_OK)
                return st;
        }
        return OCLSHADE_OK;
    }
    /* APPLY: Reflections.accumulate */
    if ((st = ocls_zero(ps, p->acc, 16 * (size_t)n, "acc")) != OCLSHADE_OK) return st;
    const cl_int face = p->face;
    const cl_float intensity = (cl_float)p->intensity;
    for (cl_int g = 0; g < p->groups.count + (p->background ? 1 : 0); ++g) {
        const int bg = g == p->groups.count;
        const cl_int group = bg ? -1 : g, width = p->width, height = p->height, ssaa = ss;
        const ocls_arg a[20] = {OCLS_ARG(width), OCLS_ARG(height), OCLS_ARG(ssaa), OCLS_ARG(pos), OCLS_ARG(nrm),
                                OCLS_ARG(obj), OCLS_ARG(p->materials), OCLS_ARG(group), OCLS_ARG(j->cam),
                                OCLS_ARG(j->v2w[0]), OCLS_ARG(j->v2w[1]), OCLS_ARG(j->v2w[2]), OCLS_ARG(j->w2c[0]),
                                OCLS_ARG(j->w2c[1]), OCLS_ARG(j->w2c[2]), OCLS_ARG(p->cube), OCLS_ARG(face),
                                OCLS_ARG(intensity), OCLS_ARG(p->acc)};
        if ((st = ocls_kernel_variant(ps, "reflect.cl", &none, bg ? BACKGROUND : p->groups.vector[g], "reflect_apply",
                                      &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 19)) != OCLSHADE_OK || (st = ocls_launch(ps, k, n, 0, 64, 0)) != OCLSHADE_OK)
            return st;
    }
    return OCLSHADE_OK;
}

oclshade_status oclshade_reflect_scratch_size(oclshade *lib, const oclshade_reflect_params *params, size_t *bytes)
{
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st != OCLSHADE_OK) return st;
    *bytes = 0;
    for (int op = WEIGHTS; op <= FINISH; ++op) {
        reflect_job j;
        size_t b = 0;
        if (op == APPLY && params != NULL && params->face < 1) continue;   /* the members of apply are not set */
        if ((st = reflect_job_for(lib, params, op, &j)) != OCLSHADE_OK || (st = ocls_plan(lib, reflect_body, &j, &b)) != OCLSHADE_OK)
            return st;
        if (b > *bytes) *bytes = b;
    }
    return OCLSHADE_OK;
}

static oclshade_status reflect_enqueue(oclshade *lib, cl_command_queue queue, const oclshade_reflect_params *p, int op,
                                       cl_uint nwait, const cl_event *wait, cl_event *event)
{
    reflect_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = reflect_job_for(lib, p, op, &j);
    if (st != OCLSHADE_OK) return st;
    const int sw = p->width * p->ssaa, sh = p->height * p->ssaa;
    const size_t acc_bytes = 16 * (size_t)p->width * (size_t)p->height, m = (size_t)p->face + 2;
    if (op == FINISH) {
        if ((st = ocls_use_field(lib, &uses, "frame", &p->frame, p->height, 4 * (size_t)p->width, OCLS_IN)) != OCLSHADE_OK ||
            (st = ocls_use_buffer(lib, &uses, "acc", p->acc, acc_bytes, OCLS_IN)) != OCLSHADE_OK ||
            (st = ocls_use_field(lib, &uses, "image", &p->image, p->height, 4 * (size_t)p->width, OCLS_OUT)) != OCLSHADE_OK)
            return st;
    } else {
        if ((st = ocls_use_field(lib, &uses, "position", &p->position, sh, 16 * (size_t)sw, OCLS_IN)) != OCLSHADE_OK ||
            (st = ocls_use_field(lib, &uses, "normal", &p->normal, sh, 16 * (size_t)sw, OCLS_IN)) != OCLSHADE_OK ||
            (st = ocls_use_field(lib, &uses, "object", &p->object, sh, 4 * (size_t)sw, OCLS_IN)) != OCLSHADE_OK ||
            (st = ocls_use_buffer(lib, &uses, "materials", p->materials, 48 * (size_t)p->objects, OCLS_IN)) != OCLSHADE_OK)
            return st;
        if (op == WEIGHTS &&
            ((st = ocls_use_field(lib, &uses, "albedo", &p->albedo, sh, 16 * (size_t)sw, OCLS_IN)) != OCLSHADE_OK ||
             (st = ocls_use_field(lib, &uses, "weighted", &p->weighted, sh, 16 * (size_t)sw, OCLS_OUT)) != OCLSHADE_OK))
            return st;
        if (op == APPLY &&
            ((st = ocls_use_buffer(lib, &uses, "cube", p->cube, 96 * m * m * (size_t)p->cubes, OCLS_IN)) != OCLSHADE_OK ||
             (st = ocls_use_buffer(lib, &uses, "acc", p->acc, acc_bytes, OCLS_OUT)) != OCLSHADE_OK))
            return st;
    }
    return ocls_enqueue(lib, queue, p->scratch, &uses, reflect_body, &j, nwait, wait, event);
}

oclshade_status oclshade_enqueue_reflect_weights(oclshade *lib, cl_command_queue queue, const oclshade_reflect_params *params,
                                                 cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                 cl_event *event)
{
    return reflect_enqueue(lib, queue, params, WEIGHTS, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_reflect_apply(oclshade *lib, cl_command_queue queue, const oclshade_reflect_params *params,
                                               cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                               cl_event *event)
{
    return reflect_enqueue(lib, queue, params, APPLY, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_reflect_finish(oclshade *lib, cl_command_queue queue, const oclshade_reflect_params *params,
                                                cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                cl_event *event)
{
    return reflect_enqueue(lib, queue, params, FINISH, num_events_in_wait_list, event_wait_list, event);
}
