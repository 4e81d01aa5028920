/* shadow_volumes.c — mesh shadows by shadow volumes (kernels/shadow_volume.cl sv_bin,
 * sv_prepare, sv_count, sv_apply; oclshade/meshes/shadow_volumes.py MeshShadows): the frame
 * tables file of write_frame_tables, the tiles' prefix sums, the passes.  The volumes, the
 * silhouette and the eye's start count stay in the Python host (float64). */
#include "internal.h"

#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define INVALID OCLSHADE_INVALID_ARGUMENT

/* ------------------------------------------------------------------ frame tables file */

static oclshade_status file_fail(char *error, size_t size, oclshade_status st, const char *fmt, ...)
{
    if (error != NULL && size > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(error, size, fmt, ap);
        va_end(ap);
    }
    return st;
}

/* Little-endian file words into host values (4-byte words only). */
static void from_le32(void *data, size_t count)
{
    const unsigned one = 1;
    if (*(const unsigned char *)&one == 1) return;
    unsigned char *b = (unsigned char *)data;
    for (size_t i = 0; i < count; ++i, b += 4) {
        unsigned char c = b[0]; b[0] = b[3]; b[3] = c;
        c = b[1]; b[1] = b[2]; b[2] = c;
    }
}

void oclshade_shadow_volume_frame_free(oclshade_shadow_volume_frame *frame)
{
    if (frame == NULL) return;
    free(frame->verts);
    free(frame->tris);
    memset(frame, 0, sizeof *frame);
}

static oclshade_status read_frame(FILE *f, const char *path, oclshade_shadow_volume_frame *out, char *error,
                                  size_t size)
{
    char magic[8];
    cl_int n[4];
    cl_float z[2];
    if (fread(magic, 1, 8, f) != 8 || memcmp(magic, "OCLSSVF1", 8) != 0 || fread(n, 4, 4, f) != 4 ||
        fread(z, 4, 2, f) != 2)
        return file_fail(error, size, INVALID, "%s: not a shadow volume frame file (magic OCLSSVF1, four counts "
                         "and two floats expected; oclshade.meshes.shadow_volumes.write_frame_tables)", path);
    from_le32(n, 4);
    from_le32(z, 2);
    if (n[0] < 1 || n[1] < 1 || n[3] != 0 || !isfinite(z[0]) || !(z[1] >= 0.0f) || !isfinite(z[1]))
        return file_fail(error, size, INVALID, "%s: counts (vertices %d, faces %d, reserved %d) must be >= 1 "
                         "(reserved 0) and start height %g, max depth %g finite (max depth >= 0)", path, n[0], n[1],
                         n[3], z[0], z[1]);
    out->vertices = n[0]; out->faces = n[1]; out->start_count = n[2];
    out->start_height = z[0]; out->max_depth = z[1];
    out->verts = (cl_float4 *)malloc(16 * (size_t)n[0]);
    out->tris = (cl_int4 *)malloc(16 * (size_t)n[1]);
    if (out->verts == NULL || out->tris == NULL) return file_fail(error, size, OCLSHADE_OUT_OF_MEMORY, "%s: out of memory", path);
    if (fread(out->verts, 16, (size_t)n[0], f) != (size_t)n[0] || fread(out->tris, 16, (size_t)n[1], f) != (size_t)n[1])
        return file_fail(error, size, INVALID, "%s: shorter than its counts say", path);
    if (fgetc(f) != EOF) return file_fail(error, size, INVALID, "%s: longer than its counts say", path);
    from_le32(out->verts, 4 * (size_t)n[0]);
    from_le32(out->tris, 4 * (size_t)n[1]);
    int empty = n[1] == 1;   /* the placeholder row of a frame without volumes: all zero */
    for (int k = 0; k < n[1]; ++k) {
        const cl_int *t = out->tris[k].s;
        empty = empty && t[0] == 0 && t[1] == 0 && t[2] == 0 && t[3] == 0;
        for (int c = 0; c < 3; ++c)
            if (t[c] < 0 || t[c] >= n[0])
                return file_fail(error, size, INVALID, "%s: face %d: vertex index %d must be in 0..%d", path, k, t[c],
                                 n[0] - 1);
        if (t[3] != 0 && t[3] != 1)
            return file_fail(error, size, INVALID, "%s: face %d: kind %d must be 0 (side) or 1 (cap)", path, k, t[3]);
    }
    out->ntri = empty ? 0 : n[1];
    return OCLSHADE_OK;
}

oclshade_status oclshade_shadow_volume_frame_read(const char *path, oclshade_shadow_volume_frame *out, char *error,
                                                  size_t error_size)
{
    if (error != NULL && error_size > 0) error[0] = '\0';
    if (out == NULL) return file_fail(error, error_size, INVALID, "out must not be NULL");
    memset(out, 0, sizeof *out);
    if (path == NULL) return file_fail(error, error_size, INVALID, "path must not be NULL");
    FILE *f = fopen(path, "rb");
    if (f == NULL) return file_fail(error, error_size, INVALID, "%s: cannot be opened", path);
    const oclshade_status st = read_frame(f, path, out, error, error_size);
    fclose(f);
    if (st != OCLSHADE_OK) oclshade_shadow_volume_frame_free(out);
    return st;
}

oclshade_status oclshade_shadow_volume_offsets(const cl_int *counts, int tiles, cl_int *offsets)
{
    if (counts == NULL || offsets == NULL || tiles < 1) return INVALID;
    long long total = 0;
    for (int t = 0; t < tiles; ++t) {
        if (counts[t] < 0 || total + counts[t] > INT_MAX) return INVALID;
        offsets[t] = (cl_int)total;
        total += counts[t];
    }
    offsets[tiles] = (cl_int)total;
    return OCLSHADE_OK;
}

/* ------------------------------------------------------------------ passes */

void oclshade_shadow_volume_params_init(oclshade_shadow_volume_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
    p->tile = 16;
}

enum { BIN, MASK, APPLY };

static int tiles_of(const oclshade_shadow_volume_params *p, int *tw, int *th)
{
    *tw = (p->camera.width + p->tile - 1) / p->tile;
    *th = (p->camera.height + p->tile - 1) / p->tile;
    return *tw * *th;
}

typedef struct sv_job {
    const oclshade_shadow_volume_params *p;
    int op;
} sv_job;

static oclshade_status sv_job_for(oclshade *lib, const oclshade_shadow_volume_params *p, int op, sv_job *j)
{
    j->p = p;
    j->op = op;
    if (p == NULL)
        return ocls_fail(lib, INVALID, 0, "params must point to oclshade_shadow_volume_params, got NULL");
    oclshade_status st = ocls_check_size(lib, "camera.height", p->camera.height, "camera.width", p->camera.width);
    if (st != OCLSHADE_OK) return st;
    if (p->camera.width > 32768 || p->camera.height > 32768)
        return ocls_fail(lib, INVALID, 0, "camera width and height must be in 1..32768, got %d, %d", p->camera.width,
                         p->camera.height);
    if (op == APPLY) return ocls_check_sun(lib, 0.0, p->elevation, p->k_dark, p->k_bright);
    if (!(p->camera.sx > 0.0) || !(p->camera.sy > 0.0) || !(p->camera.near_depth > 0.0))
        return ocls_fail(lib, INVALID, 0, "camera must come from oclshade_camera_look_at or "
                         "oclshade_camera_from_matrices (sx, sy, near > 0)");
    if (p->tile < 1 || p->tile > 32768)
        return ocls_fail(lib, INVALID, 0, "tile must be a tile side in pixels, 1..32768, got %d", p->tile);
    if (p->ntri < 0 || p->vertices < 1)
        return ocls_fail(lib, INVALID, 0, "ntri must be >= 0 and vertices >= 1 (the frame's sizes), got %d, %d",
                         p->ntri, p->vertices);
    if (op == BIN && (!(p->max_depth >= 0.0) || !isfinite(p->max_depth)))
        return ocls_fail(lib, INVALID, 0, "max_depth must be finite and >= 0, got %g", p->max_depth);
    if (op == MASK && p->entries < 0)
        return ocls_fail(lib, INVALID, 0, "entries must be offsets[TW * TH] (>= 0), got %d", p->entries);
    if (op == MASK && !isfinite(p->start_height))
        return ocls_fail(lib, INVALID, 0, "start_height must be finite, got %g", (double)p->start_height);
    return OCLSHADE_OK;
}

static oclshade_status sv_body(ocls_pass *ps, const void *params)
{
    const sv_job *j = (const sv_job *)params;
    const oclshade_shadow_volume_params *p = j->p;
    const int W = p->camera.width, H = p->camera.height;
    const cl_int n = W * H;
    cl_mem position = NULL, mask = NULL, coef = NULL;
    oclshade_status st = OCLSHADE_OK;
    if (j->op == MASK) {
        st = ocls_bind_in(ps, &p->position, H, 16 * (size_t)W, "position", &position);
        if (st == OCLSHADE_OK) st = ocls_bind_out(ps, &p->mask, H, (size_t)W, "mask", &mask);
    }
    if (j->op == APPLY) {
        st = ocls_bind_in(ps, &p->mask, H, (size_t)W, "mask", &mask);
        if (st == OCLSHADE_OK) st = ocls_bind_inout(ps, &p->coefficient, H, 4 * (size_t)W, "coefficient", &coef);
    }
    if (st != OCLSHADE_OK || !ps->run) return st;

    ocls_defines d = {0};
    kernel_entry *k;
    if (j->op == APPLY) {
        const cl_float kshadow = ocls_kshadow(p->elevation, p->k_dark, p->k_bright);
        const ocls_arg a[4] = {OCLS_ARG(n), OCLS_ARG(mask), OCLS_ARG(kshadow), OCLS_ARG(coef)};
        if ((st = ocls_kernel(ps, "shadow_volume.cl", &d, "sv_apply", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 4)) != OCLSHADE_OK)
            return st;
        return ocls_launch(ps, k, n, 0, 64, 0);
    }
    const int ortho = p->camera.projection == OCLSHADE_ORTHOGRAPHIC;
    ocls_def_flag(&d, "OCLS_ORTHO", ortho);
    int tw, th;
    const int tiles = tiles_of(p, &tw, &th);
    const cl_float4 cam = {{(cl_float)p->camera.sx, (cl_float)p->camera.sy, (cl_float)p->camera.near_depth,
                            (cl_float)p->max_depth}};
    const cl_int ntri = p->ntri, T = p->tile;
    if ((st = ocls_zero(ps, p->counts, 4 * (size_t)tiles, "counts")) != OCLSHADE_OK) return st;
    const cl_int fill = j->op == MASK;
    if (ntri > 0 && (j->op == BIN || p->entries > 0)) {
        const cl_mem list = j->op == MASK ? p->list : p->counts;   /* not written by the first pass */
        const cl_mem offsets = j->op == MASK ? p->offsets : p->counts;
        const ocls_arg a[13] = {OCLS_ARG(ntri), OCLS_ARG(p->tris), OCLS_ARG(p->verts), OCLS_ARG(cam), OCLS_ARG(W),
                                OCLS_ARG(H), OCLS_ARG(T), OCLS_ARG(tw), OCLS_ARG(th), OCLS_ARG(fill),
                                OCLS_ARG(p->counts), OCLS_ARG(offsets), OCLS_ARG(list)};
        if ((st = ocls_kernel(ps, "shadow_volume.cl", &d, "sv_bin", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 13)) != OCLSHADE_OK || (st = ocls_launch(ps, k, ntri, 0, 64, 0)) != OCLSHADE_OK)
            return st;
    }
    if (j->op == BIN) return OCLSHADE_OK;
    cl_mem planes = p->verts;   /* orthographic or no face: not read */
    if (!ortho && ntri > 0) {
        planes = p->planes;
        const ocls_arg a[4] = {OCLS_ARG(ntri), OCLS_ARG(p->tris), OCLS_ARG(p->verts), OCLS_ARG(planes)};
        if ((st = ocls_kernel(ps, "shadow_volume.cl", &d, "sv_prepare", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 4)) != OCLSHADE_OK || (st = ocls_launch(ps, k, ntri, 0, 64, 0)) != OCLSHADE_OK)
            return st;
    }
    const cl_mem list = p->entries > 0 ? p->list : p->counts;   /* no entry: not read */
    const cl_float zs = p->start_height;
    const cl_int w0 = p->start_count;
    const ocls_arg a[14] = {OCLS_ARG(p->verts), OCLS_ARG(p->tris), OCLS_ARG(planes), OCLS_ARG(p->offsets),
                            OCLS_ARG(list), OCLS_ARG(position), OCLS_ARG(cam), OCLS_ARG(zs), OCLS_ARG(w0), OCLS_ARG(W),
                            OCLS_ARG(H), OCLS_ARG(T), OCLS_ARG(tw), OCLS_ARG(mask)};
    if ((st = ocls_kernel(ps, "shadow_volume.cl", &d, "sv_count", &k)) != OCLSHADE_OK ||
        (st = ocls_set_args(ps, k, a, 14)) != OCLSHADE_OK)
        return st;
    return ocls_launch(ps, k, W, H, 64, 16);   /* Runtime.grid_2d */
}

oclshade_status oclshade_shadow_volume_scratch_size(oclshade *lib, const oclshade_shadow_volume_params *params,
                                                    size_t *bytes)
{
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, INVALID, 0, "bytes must not be NULL");
    if (st != OCLSHADE_OK) return st;
    *bytes = 0;
    for (int op = BIN; op <= APPLY; ++op) {
        sv_job j;
        size_t b = 0;
        if ((st = sv_job_for(lib, params, op, &j)) != OCLSHADE_OK || (st = ocls_plan(lib, sv_body, &j, &b)) != OCLSHADE_OK)
            return st;
        if (b > *bytes) *bytes = b;
    }
    return OCLSHADE_OK;
}

static oclshade_status sv_enqueue(oclshade *lib, cl_command_queue queue, const oclshade_shadow_volume_params *p,
                                  int op, cl_uint nwait, const cl_event *wait, cl_event *event)
{
    sv_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = sv_job_for(lib, p, op, &j);
    if (st != OCLSHADE_OK) return st;
    const int W = p->camera.width, H = p->camera.height;
    if (op != APPLY) {
        int tw, th;
        const size_t tiles = (size_t)tiles_of(p, &tw, &th), faces = (size_t)(p->ntri > 0 ? p->ntri : 1);
        const int ortho = p->camera.projection == OCLSHADE_ORTHOGRAPHIC;
        st = ocls_use_buffer(lib, &uses, "verts", p->verts, 16 * (size_t)p->vertices, OCLS_IN);
        if (st == OCLSHADE_OK) st = ocls_use_buffer(lib, &uses, "tris", p->tris, 16 * faces, OCLS_IN);
        if (st == OCLSHADE_OK) st = ocls_use_buffer(lib, &uses, "counts", p->counts, 4 * tiles, OCLS_OUT);
        if (st == OCLSHADE_OK && op == MASK) {
            st = ocls_use_buffer(lib, &uses, "offsets", p->offsets, 4 * (tiles + 1), OCLS_IN);
            if (st == OCLSHADE_OK && p->entries > 0)
                st = ocls_use_buffer(lib, &uses, "list", p->list, 4 * (size_t)p->entries, OCLS_OUT);
            if (st == OCLSHADE_OK && !ortho && p->ntri > 0)
                st = ocls_use_buffer(lib, &uses, "planes", p->planes, 64 * faces, OCLS_OUT);
            if (st == OCLSHADE_OK)
                st = ocls_use_field(lib, &uses, "position", &p->position, H, 16 * (size_t)W, OCLS_IN);
            if (st == OCLSHADE_OK) st = ocls_use_field(lib, &uses, "mask", &p->mask, H, (size_t)W, OCLS_OUT);
        }
    } else {
        st = ocls_use_field(lib, &uses, "mask", &p->mask, H, (size_t)W, OCLS_IN);
        if (st == OCLSHADE_OK)
            st = ocls_use_field(lib, &uses, "coefficient", &p->coefficient, H, 4 * (size_t)W, OCLS_INOUT);
    }
    if (st != OCLSHADE_OK) return st;
    return ocls_enqueue(lib, queue, p->scratch, &uses, sv_body, &j, nwait, wait, event);
}

oclshade_status oclshade_enqueue_shadow_volume_bin(oclshade *lib, cl_command_queue queue,
                                                   const oclshade_shadow_volume_params *params,
                                                   cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                   cl_event *event)
{
    return sv_enqueue(lib, queue, params, BIN, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_shadow_volume_mask(oclshade *lib, cl_command_queue queue,
                                                    const oclshade_shadow_volume_params *params,
                                                    cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                    cl_event *event)
{
    return sv_enqueue(lib, queue, params, MASK, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_shadow_volume_apply(oclshade *lib, cl_command_queue queue,
                                                     const oclshade_shadow_volume_params *params,
                                                     cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                     cl_event *event)
{
    return sv_enqueue(lib, queue, params, APPLY, num_events_in_wait_list, event_wait_list, event);
}
