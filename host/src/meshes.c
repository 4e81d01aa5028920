/* meshes.c — triangle meshes on the terrain (kernels/mesh.cl mesh_cast, mesh_terrain_shadow,
 * mesh_shadow_rays, mesh_shadow_apply; oclshade/meshes/caster.py MeshCaster): the tables file
 * of oclshade/meshes/tables.py, the per-camera and light tables, the passes.  The depth merge
 * and object normals are quadrics.c's (the same kernels for every kind of object). */
#include "internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define BVH_MAX_DEPTH 64
#define INVALID OCLSHADE_INVALID_ARGUMENT   /* oclshade/meshes/bvh.py MAX_DEPTH, mesh.cl's OCLS_STACK */

/* ------------------------------------------------------------------ tables file */

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

void oclshade_mesh_tables_free(oclshade_mesh_tables *t)
{
    if (t == NULL) return;
    free(t->mi); free(t->origin); free(t->reach); free(t->surface); free(t->box); free(t->info);
    free(t->tri); free(t->tvtx); free(t->tangent); free(t->vnrm); free(t->vuv); free(t->texel);
    memset(t, 0, sizeof *t);
}

/* Little-endian file bytes into host values (the host's own order). */
static void from_le(void *data, size_t count, size_t width)
{
    const unsigned one = 1;
    if (*(const unsigned char *)&one == 1) return;
    unsigned char *b = (unsigned char *)data;
    for (size_t i = 0; i < count; ++i, b += width)
        for (size_t k = 0; k < width / 2; ++k) {
            const unsigned char c = b[k];
            b[k] = b[width - 1 - k];
            b[width - 1 - k] = c;
        }
}

/* The structure of the tables: what the kernels index stays inside them, the BVH a preorder
 * tree no deeper than the traversal stack.  OK, or INVALID_ARGUMENT with a message in error. */
static oclshade_status check_tables(const oclshade_mesh_tables *t, char *error, size_t size)
{
    for (int k = 0; k < t->meshes; ++k) {
        const cl_int *m = t->mi[3 * k].s;
        if (m[0] < 0 || m[0] >= t->nodes || m[1] < 0 || m[1] > 7)
            return file_fail(error, size, INVALID, "mesh %d: root %d must be a node (0..%d) and flags %d in 0..7",
                             k, m[0], t->nodes - 1, m[1]);
        for (int img = 1; img <= 2; ++img) {
            const cl_int *r = t->mi[3 * k + img].s;
            if ((m[1] & img) && (r[0] < 0 || r[1] < 1 || r[2] < 1 || (double)r[0] + (double)r[1] * r[2] > t->texels))
                return file_fail(error, size, INVALID, "mesh %d: %s (first %d, %d x %d) must lie within the %d "
                                 "texels", k, img == 1 ? "texture" : "normal map", r[0], r[1], r[2], t->texels);
        }
    }
    unsigned char *depth = (unsigned char *)calloc((size_t)t->nodes, 1);
    if (depth == NULL) return file_fail(error, size, OCLSHADE_OUT_OF_MEMORY, "out of memory");
    oclshade_status bad = OCLSHADE_OK;
    for (int i = 0; i < t->nodes && !bad; ++i) {
        const cl_int a = t->info[i].s[0], count = t->info[i].s[1];
        if (depth[i] == 0) depth[i] = 1;   /* a root */
        if (depth[i] > BVH_MAX_DEPTH) {
            bad = file_fail(error, size, INVALID, "BVH node %d: depth %d exceeds the traversal stack %d", i, depth[i],
                            BVH_MAX_DEPTH);
        } else if (count < 0 || (count > 0 && (a < 0 || (double)a + count > t->slots))) {
            bad = file_fail(error, size, INVALID, "BVH node %d: leaf slots %d + %d must lie within the %d slots", i,
                            a, count, t->slots);
        } else if (count == 0 && (i + 1 >= t->nodes || a <= i + 1 || a >= t->nodes)) {
            bad = file_fail(error, size, INVALID, "BVH node %d: children %d and %d must be later nodes (< %d)", i,
                            i + 1, a, t->nodes);
        } else if (count == 0) {
            depth[i + 1] = depth[a] = (unsigned char)(depth[i] + 1);
        }
    }
    free(depth);
    if (bad != OCLSHADE_OK) return bad;
    for (int s = 0; s < t->slots; ++s)
        for (int c = 0; c < 3; ++c)
            if (t->tvtx[s].s[c] < 0 || t->tvtx[s].s[c] >= t->vertices)
                return file_fail(error, size, INVALID, "slot %d: vertex index %d must be in 0..%d", s, t->tvtx[s].s[c],
                                 t->vertices - 1);
    return OCLSHADE_OK;
}

oclshade_status oclshade_mesh_tables_read(const char *path, oclshade_mesh_tables *out, char *error, size_t error_size)
{
    if (error != NULL && error_size > 0) error[0] = '\0';
    if (out == NULL) return file_fail(error, error_size, OCLSHADE_INVALID_ARGUMENT, "out must not be NULL");
    memset(out, 0, sizeof *out);
    if (path == NULL) return file_fail(error, error_size, OCLSHADE_INVALID_ARGUMENT, "path must not be NULL");
    FILE *f = fopen(path, "rb");
    if (f == NULL) return file_fail(error, error_size, OCLSHADE_INVALID_ARGUMENT, "%s: cannot be opened", path);
    char magic[8];
    cl_int n[6];
    if (fread(magic, 1, 8, f) != 8 || memcmp(magic, "OCLSMSH1", 8) != 0 || fread(n, 4, 6, f) != 6) {
        fclose(f);
        return file_fail(error, error_size, OCLSHADE_INVALID_ARGUMENT, "%s: not a mesh tables file (magic "
                         "OCLSMSH1 and six counts expected; oclshade.meshes.tables.write_mesh_tables)", path);
    }
    from_le(n, 6, 4);
    if (n[0] < 1 || n[0] > OCLSHADE_MAX_MESHES || n[1] < 1 || n[2] < 1 || n[3] < 1 || n[4] < 1 || n[5] != 0) {
        fclose(f);
        return file_fail(error, error_size, OCLSHADE_INVALID_ARGUMENT, "%s: counts (meshes %d, nodes %d, slots %d, "
                         "vertices %d, texels %d, reserved %d) must be >= 1 (meshes <= %d, reserved 0)", path, n[0],
                         n[1], n[2], n[3], n[4], n[5], OCLSHADE_MAX_MESHES);
    }
    out->meshes = n[0]; out->nodes = n[1]; out->slots = n[2]; out->vertices = n[3]; out->texels = n[4];
    const size_t m = (size_t)n[0], nd = (size_t)n[1], sl = (size_t)n[2], vx = (size_t)n[3], tx = (size_t)n[4];
    struct { void **p; size_t count, width; } arr[12] = {
        {(void **)&out->mi, 12 * m, 4}, {(void **)&out->origin, 3 * m, 8}, {(void **)&out->reach, m, 8},
        {(void **)&out->surface, 4 * m, 4}, {(void **)&out->box, 8 * nd, 4}, {(void **)&out->info, 2 * nd, 4},
        {(void **)&out->tri, 12 * sl, 4}, {(void **)&out->tvtx, 4 * sl, 4}, {(void **)&out->tangent, 4 * sl, 4},
        {(void **)&out->vnrm, 4 * vx, 4}, {(void **)&out->vuv, 2 * vx, 4}, {(void **)&out->texel, 4 * tx, 4}};
    oclshade_status st = OCLSHADE_OK;
    for (int i = 0; i < 12 && st == OCLSHADE_OK; ++i) {
        *arr[i].p = malloc(arr[i].count * arr[i].width);
        if (*arr[i].p == NULL)
            st = file_fail(error, error_size, OCLSHADE_OUT_OF_MEMORY, "%s: out of memory", path);
        else if (fread(*arr[i].p, arr[i].width, arr[i].count, f) != arr[i].count)
            st = file_fail(error, error_size, OCLSHADE_INVALID_ARGUMENT, "%s: shorter than its counts say", path);
        else
            from_le(*arr[i].p, arr[i].count, arr[i].width);
    }
    if (st == OCLSHADE_OK && fgetc(f) != EOF)
        st = file_fail(error, error_size, OCLSHADE_INVALID_ARGUMENT, "%s: longer than its counts say", path);
    fclose(f);
    if (st == OCLSHADE_OK) {
        char why[256];
        if ((st = check_tables(out, why, sizeof why)) != OCLSHADE_OK)
            file_fail(error, error_size, st, "%s: %s", path, why);
    }
    if (st != OCLSHADE_OK) oclshade_mesh_tables_free(out);
    return st;
}

/* ------------------------------------------------------------------ host tables */

static int tables_ok(const oclshade_mesh_tables *t)
{
    return t != NULL && t->meshes >= 1 && t->meshes <= OCLSHADE_MAX_MESHES && t->origin != NULL && t->reach != NULL &&
           t->surface != NULL;
}

oclshade_status oclshade_mesh_camera_table(const oclshade_mesh_tables *tables, const oclshade_camera *camera,
                                           const double position[3], cl_float4 *mf)
{
    if (!tables_ok(tables) || camera == NULL || position == NULL || mf == NULL) return OCLSHADE_INVALID_ARGUMENT;
    const double *V = camera->view;
    double miss = 0.0, size = 1.0;
    for (int r = 0; r < 3; ++r) {   /* the view maps the position to the view-space origin */
        const double e =
            (V[4 * r] * position[0] + V[4 * r + 1] * position[1] + V[4 * r + 2] * position[2]) + V[4 * r + 3];
        miss += e * e;
        size += fabs(position[r]);
    }
    if (!isfinite(size) || !(sqrt(miss) <= 1e-6 * size)) return OCLSHADE_INVALID_ARGUMENT;
    for (int k = 0; k < tables->meshes; ++k) {
        const double *o = tables->origin + 3 * k;
        cl_float4 *row = mf + 3 * k;
        double rel[3], c[3];
        for (int i = 0; i < 3; ++i) {
            row[0].s[i] = (cl_float)(position[i] - o[i]);     /* float64 difference, rounded once */
            rel[i] = o[i] - position[i];
        }
        row[0].s[3] = 0.0f;
        row[1] = tables->surface[k];
        for (int r = 0; r < 3; ++r) c[r] = V[4 * r] * rel[0] + V[4 * r + 1] * rel[1] + V[4 * r + 2] * rel[2];
        cl_int rect[4];
        ocls_screen_rect(camera, c, tables->reach[k], rect);
        for (int i = 0; i < 4; ++i) row[2].s[i] = (cl_float)rect[i];
    }
    return OCLSHADE_OK;
}

oclshade_status oclshade_mesh_light_table(const oclshade_mesh_tables *tables, const oclshade_mesh_light *light,
                                          cl_float4 *table)
{
    if (!tables_ok(tables) || light == NULL || table == NULL || (light->point != 0 && light->point != 1))
        return OCLSHADE_INVALID_ARGUMENT;
    double s[3];
    if (light->point) {
        if (!isfinite(light->position[0] + light->position[1] + light->position[2])) return OCLSHADE_INVALID_ARGUMENT;
    } else if (!isfinite(light->azimuth) || !(light->elevation >= -90.0 && light->elevation <= 90.0) ||
               oclshade_sun_vector(light->azimuth, light->elevation, s) != OCLSHADE_OK) {
        return OCLSHADE_INVALID_ARGUMENT;
    }
    for (int k = 0; k < tables->meshes; ++k) {
        for (int i = 0; i < 3; ++i)
            table[k].s[i] = (cl_float)(light->point ? light->position[i] - tables->origin[3 * k + i] : s[i]);
        table[k].s[3] = light->point ? 1.0f : 0.0f;
    }
    return OCLSHADE_OK;
}

/* ------------------------------------------------------------------ passes */

void oclshade_mesh_params_init(oclshade_mesh_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
    p->own_builtins = 1;
}

enum { CAST, TERRAIN, RAYS, APPLY };

/* The cast's output fields: bytes per pixel and names, in the kernel's order. */
static const size_t GB[7] = {16, 16, 8, 16, 4, 16, 4};
static const char *const NAMES[7] = {"objects.position", "objects.normal", "objects.uv", "objects.uv_grad",
                                     "objects.depth", "objects.albedo", "objects.object"};
#define OBJECT_FIELDS(p) {&(p)->objects.position, &(p)->objects.normal, &(p)->objects.uv, &(p)->objects.uv_grad, \
                          &(p)->objects.depth, &(p)->objects.albedo, &(p)->objects.object}

typedef struct mesh_job {
    const oclshade_mesh_params *p;
    int op;
    cl_float4 hm[3];
} mesh_job;

static oclshade_status mesh_job_for(oclshade *lib, const oclshade_mesh_params *p, int op, mesh_job *j)
{
    j->p = p;
    j->op = op;
    if (p == NULL)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params must point to oclshade_mesh_params, got NULL");
    oclshade_status st = ocls_check_size(lib, "camera.height", p->camera.height, "camera.width", p->camera.width);
    if (st != OCLSHADE_OK) return st;
    if (p->camera.width > 32768 || p->camera.height > 32768)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "camera width and height must be in 1..32768, got %d, %d",
                         p->camera.width, p->camera.height);
    if (op == CAST || op == RAYS) {
        if (p->count < 1 || p->count > OCLSHADE_MAX_MESHES)
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "count must be the number of meshes, 1..%d, got %d",
                             OCLSHADE_MAX_MESHES, p->count);
        if (p->nodes < 1 || p->slots < 1 || p->vertices < 1 || p->texels < 1)
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "nodes, slots, vertices, texels must be the tables' "
                             "sizes (>= 1), got %d, %d, %d, %d", p->nodes, p->slots, p->vertices, p->texels);
        if (!(p->camera.sx > 0.0) || !(p->camera.sy > 0.0) || !(p->camera.far_depth > p->camera.near_depth))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "camera must come from oclshade_camera_look_at or "
                             "oclshade_camera_from_matrices (sx, sy > 0, far > near)");
    }
    if (op == TERRAIN && p->heights.buffer != NULL) {
        if ((st = ocls_check_size(lib, "rows", p->rows, "cols", p->cols)) != OCLSHADE_OK) return st;
        if (!(p->dx > 0.0) || !(p->dy > 0.0) || !isfinite(p->dx) || !isfinite(p->dy) || !isfinite(p->offset))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "dx, dy must be positive finite cell sizes and "
                             "offset finite, got %g, %g, %g", p->dx, p->dy, p->offset);
        if (!isfinite(p->hmax))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "hmax must be finite, got %g", p->hmax);
    }
    if ((op == TERRAIN || op == APPLY) &&
        (st = ocls_check_sun(lib, p->azimuth, p->elevation, p->k_dark, p->k_bright)) != OCLSHADE_OK)
        return st;
    ocls_heightmap_rows(p->camera.view, op == TERRAIN && p->heights.buffer != NULL, p->dx, p->dy, p->offset, j->hm);
    return OCLSHADE_OK;
}

static oclshade_status mesh_body(ocls_pass *ps, const void *params)
{
    const mesh_job *j = (const mesh_job *)params;
    const oclshade_mesh_params *p = j->p;
    const int W = p->camera.width, H = p->camera.height;
    const cl_int n = W * H;
    const oclshade_field *obj[7] = OBJECT_FIELDS(p);
    cl_mem out[7] = {NULL}, position = NULL, object = NULL, coef = NULL, hidden = NULL, heights = NULL;
    oclshade_status st = OCLSHADE_OK;
    if (j->op == CAST)
        for (int i = 0; i < 7 && st == OCLSHADE_OK; ++i)
            st = ocls_bind_out(ps, obj[i], H, GB[i] * (size_t)W, NAMES[i], &out[i]);
    if (st == OCLSHADE_OK && (j->op == TERRAIN || j->op == RAYS))
        st = ocls_bind_in(ps, &p->gbuffer.position, H, 16 * (size_t)W, "gbuffer.position", &position);
    if (st == OCLSHADE_OK && j->op == TERRAIN) {
        st = ocls_bind_in(ps, &p->gbuffer.object, H, 4 * (size_t)W, "gbuffer.object", &object);
        if (st == OCLSHADE_OK && p->heights.buffer != NULL)
            st = ocls_bind_in(ps, &p->heights, p->rows, 4 * (size_t)p->cols, "heights", &heights);
    }
    if (st == OCLSHADE_OK && (j->op == TERRAIN || j->op == APPLY))
        st = ocls_bind_inout(ps, &p->coefficient, H, 4 * (size_t)W, "coefficient", &coef);
    if (st == OCLSHADE_OK && j->op == RAYS) st = ocls_bind_out(ps, &p->hidden, H, 4 * (size_t)W, "hidden", &hidden);
    if (st == OCLSHADE_OK && j->op == APPLY) st = ocls_bind_in(ps, &p->hidden, H, 4 * (size_t)W, "hidden", &hidden);
    if (st != OCLSHADE_OK || !ps->run) return st;

    ocls_defines d = {0};
    ocls_def_flag(&d, "OCLS_OWN_BUILTINS", p->own_builtins != 0);
    kernel_entry *k;
    /* the view -> world rotation's rows (rot.T) and its inverse's (rot), float32 (caster.py _rows) */
    const double *V = p->camera.view;
    cl_float4 vw[3], wv[3];
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
            vw[r].s[c] = (cl_float)V[4 * c + r];
            wv[r].s[c] = (cl_float)V[4 * r + c];
        }
        vw[r].s[3] = wv[r].s[3] = 0.0f;
    }
    if (j->op == CAST) {
        ocls_def_flag(&d, "OCLS_ORTHO", p->camera.projection == OCLSHADE_ORTHOGRAPHIC);
        const cl_float4 cam = {{(cl_float)p->camera.sx, (cl_float)p->camera.sy, (cl_float)p->camera.near_depth,
                                (cl_float)p->camera.far_depth}};
        const ocls_arg a[27] = {OCLS_ARG(p->count), OCLS_ARG(p->mf), OCLS_ARG(p->mi), OCLS_ARG(p->box),
                                OCLS_ARG(p->info), OCLS_ARG(p->tri), OCLS_ARG(p->tvtx), OCLS_ARG(p->tangent), OCLS_ARG(p->vnrm),
                                OCLS_ARG(p->vuv), OCLS_ARG(p->texel), OCLS_ARG(cam), OCLS_ARG(W), OCLS_ARG(H),
                                OCLS_ARG(vw[0]), OCLS_ARG(vw[1]), OCLS_ARG(vw[2]), OCLS_ARG(wv[0]), OCLS_ARG(wv[1]),
                                OCLS_ARG(wv[2]), OCLS_ARG(out[0]), OCLS_ARG(out[1]), OCLS_ARG(out[2]),
                                OCLS_ARG(out[3]), OCLS_ARG(out[4]), OCLS_ARG(out[5]), OCLS_ARG(out[6])};
        if ((st = ocls_kernel(ps, "mesh.cl", &d, "mesh_cast", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 27)) != OCLSHADE_OK)
            return st;
        return ocls_launch(ps, k, W, H, 64, 16);   /* Runtime.grid_2d */
    }
    if (j->op == TERRAIN) {
        ocls_sun_args sa;
        if ((st = ocls_sun_args_for(ps->lib, &p->camera, p->heights.buffer != NULL, p->dx, p->dy, p->azimuth,
                                    p->elevation, p->k_dark, p->k_bright, &sa)) != OCLSHADE_OK)
            return st;
        const cl_int rows = heights ? p->rows : 0, cols = heights ? p->cols : 0;
        const cl_float zmax = heights ? p->hmax : 0.0f;
        const cl_mem h = heights ? heights : position;   /* not read without a terrain (rows, cols 0) */
        const ocls_arg a[14] = {OCLS_ARG(n), OCLS_ARG(position), OCLS_ARG(object), OCLS_ARG(sa.sun), OCLS_ARG(h),
                                OCLS_ARG(rows), OCLS_ARG(cols), OCLS_ARG(zmax), OCLS_ARG(j->hm[0]), OCLS_ARG(j->hm[1]),
                                OCLS_ARG(j->hm[2]), OCLS_ARG(sa.ray), OCLS_ARG(sa.kshadow), OCLS_ARG(coef)};
        if ((st = ocls_kernel(ps, "mesh.cl", &d, "mesh_terrain_shadow", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 14)) != OCLSHADE_OK)
            return st;
        return ocls_launch(ps, k, n, 0, 64, 0);    /* caster.py launch_1d */
    }
    if (j->op == RAYS) {
        const ocls_arg a[16] = {OCLS_ARG(n), OCLS_ARG(p->count), OCLS_ARG(p->mf), OCLS_ARG(p->mi), OCLS_ARG(p->box),
                                OCLS_ARG(p->info), OCLS_ARG(p->tri), OCLS_ARG(p->tvtx), OCLS_ARG(p->vuv),
                                OCLS_ARG(p->texel), OCLS_ARG(position), OCLS_ARG(vw[0]), OCLS_ARG(vw[1]),
                                OCLS_ARG(vw[2]), OCLS_ARG(p->light), OCLS_ARG(hidden)};
        if ((st = ocls_kernel(ps, "mesh.cl", &d, "mesh_shadow_rays", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 16)) != OCLSHADE_OK)
            return st;
        return ocls_launch(ps, k, n, 0, 64, 0);
    }
    const cl_float kshadow = ocls_kshadow(p->elevation, p->k_dark, p->k_bright);
    const ocls_arg a[4] = {OCLS_ARG(n), OCLS_ARG(hidden), OCLS_ARG(kshadow), OCLS_ARG(coef)};
    if ((st = ocls_kernel(ps, "mesh.cl", &d, "mesh_shadow_apply", &k)) != OCLSHADE_OK ||
        (st = ocls_set_args(ps, k, a, 4)) != OCLSHADE_OK)
        return st;
    return ocls_launch(ps, k, n, 0, 64, 0);
}

oclshade_status oclshade_mesh_scratch_size(oclshade *lib, const oclshade_mesh_params *params, size_t *bytes)
{
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st != OCLSHADE_OK) return st;
    *bytes = 0;
    for (int op = CAST; op <= APPLY; ++op) {
        mesh_job j;
        size_t b = 0;
        /* the cast and the rays are planned only when their tables are set */
        if ((op == CAST || op == RAYS) && params != NULL && (params->count < 1 || params->mf == NULL)) continue;
        if ((st = mesh_job_for(lib, params, op, &j)) != OCLSHADE_OK ||
            (st = ocls_plan(lib, mesh_body, &j, &b)) != OCLSHADE_OK)
            return st;
        if (b > *bytes) *bytes = b;
    }
    return OCLSHADE_OK;
}

/* The tables the cast (all of them) or the rays (no tangents, normals) read. */
static oclshade_status table_uses(oclshade *lib, ocls_uses *uses, const oclshade_mesh_params *p, int op)
{
    const size_t m = (size_t)p->count, nd = (size_t)p->nodes, sl = (size_t)p->slots, vx = (size_t)p->vertices;
    const struct { const char *name; cl_mem mem; size_t bytes; int cast_only; } t[10] = {
        {"mf", p->mf, 48 * m, 0},        {"mi", p->mi, 48 * m, 0},         {"box", p->box, 32 * nd, 0},
        {"info", p->info, 8 * nd, 0},    {"tri", p->tri, 48 * sl, 0},      {"tvtx", p->tvtx, 16 * sl, 0},
        {"tangent", p->tangent, 16 * sl, 1}, {"vnrm", p->vnrm, 16 * vx, 1}, {"vuv", p->vuv, 8 * vx, 0},
        {"texel", p->texel, 16 * (size_t)p->texels, 0}};
    oclshade_status st = OCLSHADE_OK;
    for (int i = 0; i < 10 && st == OCLSHADE_OK; ++i)
        if (op == CAST || !t[i].cast_only) st = ocls_use_buffer(lib, uses, t[i].name, t[i].mem, t[i].bytes, OCLS_IN);
    if (st == OCLSHADE_OK && op == RAYS) st = ocls_use_buffer(lib, uses, "light", p->light, 16 * m, OCLS_IN);
    return st;
}

static oclshade_status mesh_enqueue(oclshade *lib, cl_command_queue queue, const oclshade_mesh_params *p, int op,
                                    cl_uint nwait, const cl_event *wait, cl_event *event)
{
    mesh_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = mesh_job_for(lib, p, op, &j);
    if (st != OCLSHADE_OK) return st;
    const int W = p->camera.width, H = p->camera.height;
    if (op == CAST || op == RAYS) st = table_uses(lib, &uses, p, op);
    if (st == OCLSHADE_OK && op == CAST) {
        const oclshade_field *obj[7] = OBJECT_FIELDS(p);
        for (int i = 0; i < 7 && st == OCLSHADE_OK; ++i)
            st = ocls_use_field(lib, &uses, NAMES[i], obj[i], H, GB[i] * (size_t)W, OCLS_OUT);
    }
    if (st == OCLSHADE_OK && (op == TERRAIN || op == RAYS))
        st = ocls_use_field(lib, &uses, "gbuffer.position", &p->gbuffer.position, H, 16 * (size_t)W, OCLS_IN);
    if (st == OCLSHADE_OK && op == TERRAIN) {
        st = ocls_use_field(lib, &uses, "gbuffer.object", &p->gbuffer.object, H, 4 * (size_t)W, OCLS_IN);
        if (st == OCLSHADE_OK && p->heights.buffer != NULL)
            st = ocls_use_field(lib, &uses, "heights", &p->heights, p->rows, 4 * (size_t)p->cols, OCLS_IN);
    }
    if (st == OCLSHADE_OK && (op == TERRAIN || op == APPLY))
        st = ocls_use_field(lib, &uses, "coefficient", &p->coefficient, H, 4 * (size_t)W, OCLS_INOUT);
    if (st == OCLSHADE_OK && (op == RAYS || op == APPLY))
        st = ocls_use_field(lib, &uses, "hidden", &p->hidden, H, 4 * (size_t)W, op == RAYS ? OCLS_OUT : OCLS_IN);
    if (st != OCLSHADE_OK) return st;
    return ocls_enqueue(lib, queue, p->scratch, &uses, mesh_body, &j, nwait, wait, event);
}

oclshade_status oclshade_enqueue_mesh_cast(oclshade *lib, cl_command_queue queue, const oclshade_mesh_params *params,
                                           cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                           cl_event *event)
{
    return mesh_enqueue(lib, queue, params, CAST, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_mesh_terrain_shadow(oclshade *lib, cl_command_queue queue,
                                                     const oclshade_mesh_params *params,
                                                     cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                     cl_event *event)
{
    return mesh_enqueue(lib, queue, params, TERRAIN, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_mesh_shadow_rays(oclshade *lib, cl_command_queue queue,
                                                  const oclshade_mesh_params *params,
                                                  cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                  cl_event *event)
{
    return mesh_enqueue(lib, queue, params, RAYS, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_mesh_shadow_apply(oclshade *lib, cl_command_queue queue,
                                                   const oclshade_mesh_params *params,
                                                   cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                   cl_event *event)
{
    return mesh_enqueue(lib, queue, params, APPLY, num_events_in_wait_list, event_wait_list, event);
}
