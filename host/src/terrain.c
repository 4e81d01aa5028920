/* terrain.c — the terrain G-buffer (kernels/terrain.cl terrain_dilate, terrain_cast;
 * oclshade/terrain.py TerrainRenderer). */
#include "internal.h"

#include <math.h>
#include <string.h>

#define MAX_IT 65536   /* oclshade/terrain.py MAX_ITERATIONS */

/* TerrainFeatures(method, orthographic, sphere, colour, descend=, leaf=, own_builtins=).defines() */
static void terrain_defines(oclshade_caster method, int ortho, int sphere, int colour, int descend, int leaf, int own,
                            ocls_defines *d)
{
    memset(d, 0, sizeof *d);
    ocls_def_int(d, "OCLS_METHOD", (int)method);
    ocls_def_flag(d, "OCLS_ORTHO", ortho);
    ocls_def_flag(d, "OCLS_SPHERE", sphere);
    ocls_def_flag(d, "OCLS_COLOUR", colour);
    ocls_def_text(d, "OCLS_MARCH_STEP", "0.5f");
    ocls_def_int(d, "OCLS_MAX_IT", MAX_IT);
    ocls_def_int(d, "OCLS_DESCEND", descend);
    ocls_def_int(d, "OCLS_LEAF", leaf);
    ocls_def_flag(d, "OCLS_OWN_BUILTINS", own);
}

/* ------------------------------------------------------------------ dilated levels */

oclshade_status oclshade_dilated_layout_for(oclshade *lib, int rows, int cols, oclshade_dilated_layout *out)
{
    oclshade_status st = ocls_enter(lib);
    if (st != OCLSHADE_OK) return st;
    if (out == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "out must not be NULL");
    if ((st = ocls_check_size(lib, "rows", rows, "cols", cols)) != OCLSHADE_OK) return st;
    oclshade_pyramid_layout pyr;
    oclshade_pyramid_layout_for(rows, cols, &pyr);
    ocls_mutex_lock(&lib->lock);
    const int leaf = ocls_knob(lib, K_TERRAIN_LEAF);
    ocls_mutex_unlock(&lib->lock);
    memset(out, 0, sizeof *out);
    /* TerrainRenderer.dilated: shapes = [patch shape] + the pyramid's, from lmin = min(leaf, L) */
    out->levels = pyr.levels;
    out->first = leaf < pyr.levels - 1 ? leaf : pyr.levels - 1;
    out->level_rows[0] = rows > 1 ? rows - 1 : 1;
    out->level_cols[0] = cols > 1 ? cols - 1 : 1;
    for (int l = 1; l < pyr.levels; ++l) {
        out->level_rows[l] = pyr.level_rows[l];
        out->level_cols[l] = pyr.level_cols[l];
    }
    size_t total = 0;
    for (int l = out->first; l < pyr.levels; ++l) {
        out->offsets[l] = (int)total;
        total += (size_t)out->level_rows[l] * (size_t)out->level_cols[l];
    }
    out->bytes = 4u * total;
    out->table_bytes = 8u * (size_t)pyr.levels;
    return OCLSHADE_OK;
}

typedef struct dilate_job {
    const oclshade_field *heights;
    int rows, cols;
    cl_mem pyramid, offsets, dilated, table;
    oclshade_dilated_layout lay;
} dilate_job;

static oclshade_status dilate_body(ocls_pass *ps, const void *params)
{
    const dilate_job *j = (const dilate_job *)params;
    const oclshade_dilated_layout *lay = &j->lay;
    cl_mem heights;
    oclshade_status st = ocls_bind_in(ps, j->heights, j->rows, 4u * (size_t)j->cols, "heights", &heights);
    if (st != OCLSHADE_OK || !ps->run) return st;
    cl_int table[2 * OCLSHADE_MAX_LEVELS];
    for (int l = 0; l < lay->levels; ++l) {
        table[2 * l] = l < lay->first ? 0 : lay->offsets[l];
        table[2 * l + 1] = lay->level_cols[l];
    }
    st = ocls_upload(ps, j->table, 0, table, lay->table_bytes, "dilated table");
    ocls_defines d;
    terrain_defines(OCLSHADE_CAST_BISECT, 0, 0, 0, 3, 2, 0, &d);   /* TerrainFeatures().defines() */
    kernel_entry *k = NULL;
    if (st == OCLSHADE_OK) st = ocls_kernel(ps, "terrain.cl", &d, "terrain_dilate", &k);
    const cl_int H = j->rows, W = j->cols;
    for (int l = lay->first; st == OCLSHADE_OK && l < lay->levels; ++l) {
        const cl_int lev = l, r = lay->level_rows[l], c = lay->level_cols[l], off = lay->offsets[l];
        const ocls_arg a[] = {OCLS_ARG(heights), OCLS_ARG(H), OCLS_ARG(W), OCLS_ARG(j->pyramid), OCLS_ARG(j->offsets),
                              OCLS_ARG(lev), OCLS_ARG(r), OCLS_ARG(c), OCLS_ARG(j->dilated), OCLS_ARG(off)};
        st = ocls_set_args(ps, k, a, 10);
        if (st == OCLSHADE_OK) st = ocls_launch(ps, k, c, r, 64, 16);
    }
    return st;
}

static oclshade_status dilate_job_for(oclshade *lib, const oclshade_field *heights, int rows, int cols, dilate_job *j)
{
    memset(j, 0, sizeof *j);
    if (heights == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "heights must point to an oclshade_field, got NULL");
    j->heights = heights;
    j->rows = rows;
    j->cols = cols;
    return oclshade_dilated_layout_for(lib, rows, cols, &j->lay);
}

oclshade_status oclshade_dilated_levels_scratch_size(oclshade *lib, const oclshade_field *heights, int rows, int cols,
                                                     size_t *bytes)
{
    dilate_job j;
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st == OCLSHADE_OK) st = dilate_job_for(lib, heights, rows, cols, &j);
    return st != OCLSHADE_OK ? st : ocls_plan(lib, dilate_body, &j, bytes);
}

oclshade_status oclshade_enqueue_dilated_levels(oclshade *lib, cl_command_queue queue, const oclshade_field *heights,
                                                int rows, int cols, cl_mem pyramid, cl_mem offsets, cl_mem dilated,
                                                cl_mem table, cl_mem scratch, cl_uint num_events_in_wait_list,
                                                const cl_event *event_wait_list, cl_event *event)
{
    dilate_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = dilate_job_for(lib, heights, rows, cols, &j);
    if (st != OCLSHADE_OK) return st;
    oclshade_pyramid_layout pyr;
    oclshade_pyramid_layout_for(rows, cols, &pyr);
    j.pyramid = pyramid;
    j.offsets = offsets;
    j.dilated = dilated;
    j.table = table;
    if ((st = ocls_use_field(lib, &uses, "heights", heights, rows, 4u * (size_t)cols, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "pyramid", pyramid, pyr.pyramid_bytes, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "offsets", offsets, pyr.offsets_bytes, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "dilated", dilated, j.lay.bytes, OCLS_OUT)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "table", table, j.lay.table_bytes, OCLS_OUT)) != OCLSHADE_OK)
        return st;
    return ocls_enqueue(lib, queue, scratch, &uses, dilate_body, &j, num_events_in_wait_list, event_wait_list, event);
}

/* ------------------------------------------------------------------ terrain G-buffer */

void oclshade_terrain_params_init(oclshade_terrain_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
    p->dx = p->dy = 1.0;
    p->method = OCLSHADE_CAST_BISECT;
    static const double origin[3] = {0.0, 0.0, 0.0}, below[3] = {0.0, 0.0, -1.0};
    oclshade_camera_look_at(origin, below, NULL, 1, 1, OCLSHADE_PERSPECTIVE, 45.0, 1.0, 1.0, 1e6, &p->camera);
}

typedef struct terrain_job {
    const oclshade_terrain_params *p;
    oclshade_pyramid_layout pyr;
    cl_float4 g[3], r[3], cam, geo, hrange;
    cl_int cu, cv;
} terrain_job;

/* TerrainRenderer.kernel_args: g = heightmap_from_world(hm, centre) @ inv(view), the view being
 * rigid: inv(view) = [R^T | -R^T t] (numpy inverts it by LU: equal up to rounding). */
static void terrain_args(const oclshade_terrain_params *p, terrain_job *j)
{
    const double *V = p->camera.view;
    double inv[4][4] = {{0}};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) inv[r][c] = V[4 * c + r];
        inv[r][3] = -(V[r] * V[3] + V[4 + r] * V[7] + V[8 + r] * V[11]);
    }
    inv[3][3] = 1.0;
    const int rows = p->rows, cols = p->cols;
    j->cv = (rows - 1) / 2;   /* Heightfield.centre: ((rows - 1) // 2, (cols - 1) // 2) */
    j->cu = (cols - 1) / 2;
    /* heightmap_from_world: rows (1/dx, 0, 0, -cu), (0, -1/dy, 0, -cv), (0, 0, 1, -offset) */
    const double h[3][4] = {{1.0 / p->dx, 0.0, 0.0, -(double)j->cu},
                            {0.0, -1.0 / p->dy, 0.0, -(double)j->cv},
                            {0.0, 0.0, 1.0, -p->offset}};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) {
            double sum = 0.0;
            for (int k = 0; k < 4; ++k) sum += h[r][k] * inv[k][c];
            j->g[r].s[c] = (cl_float)sum;
        }
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) j->r[r].s[c] = (cl_float)V[4 * r + c];
        j->r[r].s[3] = 0.0f;
    }
    j->cam.s[0] = (cl_float)p->camera.sx;
    j->cam.s[1] = (cl_float)p->camera.sy;
    j->cam.s[2] = (cl_float)p->camera.near_depth;
    j->cam.s[3] = (cl_float)p->camera.far_depth;
    const double k = p->radius > 0.0 ? 0.5 / p->radius : 0.0;   /* Heightfield.curvature */
    j->geo.s[0] = (cl_float)p->dx;
    j->geo.s[1] = (cl_float)p->dy;
    j->geo.s[2] = (cl_float)(k * (p->dx * p->dx));
    j->geo.s[3] = (cl_float)(k * (p->dy * p->dy));
    j->hrange.s[0] = p->hmin;
    j->hrange.s[1] = p->hmax;
    j->hrange.s[2] = j->hrange.s[3] = 0.0f;
}

static oclshade_status terrain_job_for(oclshade *lib, const oclshade_terrain_params *p, terrain_job *j)
{
    oclshade_status st;
    memset(j, 0, sizeof *j);
    if (p == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params must point to oclshade_terrain_params, got NULL");
    if ((st = ocls_check_size(lib, "rows", p->rows, "cols", p->cols)) != OCLSHADE_OK) return st;
    if (!(isfinite(p->dx) && p->dx > 0.0 && isfinite(p->dy) && p->dy > 0.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "dx and dy must be positive finite cell sizes, got dx %g, dy %g",
                         p->dx, p->dy);
    if (!isfinite(p->offset)) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "offset must be finite, got %g", p->offset);
    if (!(isfinite(p->hmin) && isfinite(p->hmax) && p->hmin <= p->hmax))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "hmin and hmax must be finite with hmin <= hmax "
                         "(oclshade_height_range), got %g, %g", (double)p->hmin, (double)p->hmax);
    if (!(isfinite(p->radius) && p->radius >= 0.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "radius must be 0 (plane) or a positive finite radius, got %g",
                         p->radius);
    if (p->method < OCLSHADE_CAST_BISECT || p->method > OCLSHADE_CAST_DDA)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "method must be OCLSHADE_CAST_BISECT, _MARCH or _DDA (1..3), got %d",
                         (int)p->method);
    const oclshade_camera *c = &p->camera;
    if (c->width < 1 || c->width > 32768 || c->height < 1 || c->height > 32768 ||
        (c->projection != OCLSHADE_PERSPECTIVE && c->projection != OCLSHADE_ORTHOGRAPHIC) ||
        !(c->sx > 0.0 && c->sy > 0.0 && isfinite(c->near_depth) && c->far_depth > c->near_depth && isfinite(c->far_depth)))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "camera must come from oclshade_camera_look_at or "
                         "oclshade_camera_from_matrices (got %d x %d pixels, sx %g, sy %g, near %g, far %g)",
                         c->width, c->height, c->sx, c->sy, c->near_depth, c->far_depth);
    if ((p->texture == NULL) != (p->texture_levels == NULL) || (p->texture != NULL && p->texture_count < 1))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "texture and texture_levels go together, with texture_count "
                         ">= 1 levels (got texture %s, texture_levels %s, texture_count %d)", p->texture ? "set" : "NULL",
                         p->texture_levels ? "set" : "NULL", p->texture_count);
    j->p = p;
    oclshade_pyramid_layout_for(p->rows, p->cols, &j->pyr);
    terrain_args(p, j);
    return OCLSHADE_OK;
}

/* TerrainRenderer.features(camera, method).defines() with the handle's knobs (lock held). */
static void cast_defines(oclshade *lib, const oclshade_terrain_params *p, ocls_defines *d)
{
    const int bisect = p->method == OCLSHADE_CAST_BISECT;
    terrain_defines(p->method, p->camera.projection == OCLSHADE_ORTHOGRAPHIC, p->radius > 0.0, p->texture != NULL,
                    bisect ? ocls_knob(lib, K_TERRAIN_DESCEND) : 3, bisect ? ocls_knob(lib, K_TERRAIN_LEAF) : 2,
                    ocls_knob(lib, K_TERRAIN_OWN_BUILTINS), d);
}

static const char *const GBUFFER_NAMES[6] = {"position", "normal", "uv", "uv_grad", "depth", "albedo"};
static const size_t GBUFFER_BYTES[6] = {16, 16, 8, 16, 4, 16};

static const oclshade_field *gbuffer_field(const oclshade_gbuffer *g, int i)
{
    const oclshade_field *const f[6] = {&g->position, &g->normal, &g->uv, &g->uv_grad, &g->depth, &g->albedo};
    return f[i];
}

/* TerrainRenderer.render */
static oclshade_status terrain_body(ocls_pass *ps, const void *params)
{
    const terrain_job *j = (const terrain_job *)params;
    const oclshade_terrain_params *p = j->p;
    oclshade *lib = ps->lib;
    const int height = p->camera.height;
    const size_t width = (size_t)p->camera.width;
    cl_mem heights, out[6];
    oclshade_status st = ocls_bind_in(ps, &p->heights, p->rows, 4u * (size_t)p->cols, "heights", &heights);
    for (int i = 0; i < 6 && st == OCLSHADE_OK; ++i)
        st = ocls_bind_out(ps, gbuffer_field(&p->gbuffer, i), height, GBUFFER_BYTES[i] * width, GBUFFER_NAMES[i], &out[i]);
    if (st != OCLSHADE_OK || !ps->run) return st;
    ocls_defines d;
    cast_defines(lib, p, &d);
    kernel_entry *k;
    if ((st = ocls_kernel(ps, "terrain.cl", &d, "terrain_cast", &k)) != OCLSHADE_OK) return st;
    const cl_int H = p->rows, W = p->cols, levels = j->pyr.levels, IW = p->camera.width, IH = p->camera.height;
    const cl_int ntex = p->texture != NULL ? p->texture_count : 0;
    const ocls_arg a[] = {OCLS_ARG(heights), OCLS_ARG(H), OCLS_ARG(W), OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets),
                          OCLS_ARG(levels), OCLS_ARG(p->dilated), OCLS_ARG(p->dilated_table),
                          OCLS_ARG(j->g[0]), OCLS_ARG(j->g[1]), OCLS_ARG(j->g[2]),
                          OCLS_ARG(j->r[0]), OCLS_ARG(j->r[1]), OCLS_ARG(j->r[2]),
                          OCLS_ARG(j->cam), OCLS_ARG(IW), OCLS_ARG(IH), OCLS_ARG(j->cu), OCLS_ARG(j->cv),
                          OCLS_ARG(j->geo), OCLS_ARG(j->hrange),
                          OCLS_ARG(p->texture), OCLS_ARG(p->texture_levels), OCLS_ARG(ntex),
                          OCLS_ARG(out[0]), OCLS_ARG(out[1]), OCLS_ARG(out[2]), OCLS_ARG(out[3]),
                          OCLS_ARG(out[4]), OCLS_ARG(out[5])};
    if ((st = ocls_set_args(ps, k, a, (int)N_ITEMS(a))) != OCLSHADE_OK) return st;
    return ocls_launch(ps, k, IW, IH, (size_t)ocls_knob(lib, K_TERRAIN_GROUP), 16);
}

oclshade_status oclshade_terrain_scratch_size(oclshade *lib, const oclshade_terrain_params *params, size_t *bytes)
{
    terrain_job j;
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st == OCLSHADE_OK) st = terrain_job_for(lib, params, &j);
    return st != OCLSHADE_OK ? st : ocls_plan(lib, terrain_body, &j, bytes);
}

oclshade_status oclshade_enqueue_terrain(oclshade *lib, cl_command_queue queue, const oclshade_terrain_params *p,
                                         cl_uint num_events_in_wait_list, const cl_event *event_wait_list, cl_event *event)
{
    terrain_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = terrain_job_for(lib, p, &j);
    if (st != OCLSHADE_OK) return st;
    oclshade_dilated_layout dil;
    if ((st = oclshade_dilated_layout_for(lib, p->rows, p->cols, &dil)) != OCLSHADE_OK) return st;
    const int bisect = p->method == OCLSHADE_CAST_BISECT;
    if ((st = ocls_use_field(lib, &uses, "heights", &p->heights, p->rows, 4u * (size_t)p->cols, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "pyramid", p->pyramid, j.pyr.pyramid_bytes, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "offsets", p->offsets, j.pyr.offsets_bytes, OCLS_IN)) != OCLSHADE_OK ||
        ((bisect || p->dilated) && (st = ocls_use_buffer(lib, &uses, "dilated", p->dilated, dil.bytes, OCLS_IN)) != OCLSHADE_OK) ||
        ((bisect || p->dilated_table) &&
         (st = ocls_use_buffer(lib, &uses, "dilated_table", p->dilated_table, dil.table_bytes, OCLS_IN)) != OCLSHADE_OK) ||
        (p->texture && (st = ocls_use_buffer(lib, &uses, "texture", p->texture, 16, OCLS_IN)) != OCLSHADE_OK) ||
        (p->texture && (st = ocls_use_buffer(lib, &uses, "texture_levels", p->texture_levels,
                                             16u * (size_t)p->texture_count, OCLS_IN)) != OCLSHADE_OK))
        return st;
    for (int i = 0; i < 6 && st == OCLSHADE_OK; ++i)
        st = ocls_use_field(lib, &uses, GBUFFER_NAMES[i], gbuffer_field(&p->gbuffer, i), p->camera.height,
                            GBUFFER_BYTES[i] * (size_t)p->camera.width, OCLS_OUT);
    if (st != OCLSHADE_OK) return st;
    return ocls_enqueue(lib, queue, p->scratch, &uses, terrain_body, &j, num_events_in_wait_list, event_wait_list, event);
}

/* ------------------------------------------------------------------ shading normals */

typedef struct normals_job {
    terrain_job t;
    const oclshade_field *normals;
} normals_job;

/* TerrainRenderer.shading_normals */
static oclshade_status normals_body(ocls_pass *ps, const void *params)
{
    const normals_job *nj = (const normals_job *)params;
    const terrain_job *j = &nj->t;
    const oclshade_terrain_params *p = j->p;
    const int height = p->camera.height;
    const size_t width = (size_t)p->camera.width;
    cl_mem heights, uv, pos, out;
    oclshade_status st;
    if ((st = ocls_bind_in(ps, &p->heights, p->rows, 4u * (size_t)p->cols, "heights", &heights)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->gbuffer.uv, height, 8 * width, "uv", &uv)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->gbuffer.position, height, 16 * width, "position", &pos)) != OCLSHADE_OK ||
        (st = ocls_bind_out(ps, nj->normals, height, 16 * width, "normals", &out)) != OCLSHADE_OK || !ps->run)
        return st;
    ocls_defines d;
    cast_defines(ps->lib, p, &d);
    kernel_entry *k;
    if ((st = ocls_kernel(ps, "terrain.cl", &d, "terrain_normals", &k)) != OCLSHADE_OK) return st;
    const cl_int H = p->rows, W = p->cols, n = p->camera.width * p->camera.height;
    const ocls_arg a[] = {OCLS_ARG(heights), OCLS_ARG(H), OCLS_ARG(W), OCLS_ARG(uv), OCLS_ARG(pos),
                          OCLS_ARG(j->r[0]), OCLS_ARG(j->r[1]), OCLS_ARG(j->r[2]), OCLS_ARG(j->geo),
                          OCLS_ARG(j->cu), OCLS_ARG(j->cv), OCLS_ARG(n), OCLS_ARG(out)};
    if ((st = ocls_set_args(ps, k, a, (int)N_ITEMS(a))) != OCLSHADE_OK) return st;
    return ocls_launch(ps, k, n, 0, 64, 0);   /* 1-D, Runtime.local_size(kernel, 64) */
}

static oclshade_status normals_job_for(oclshade *lib, const oclshade_terrain_params *p, const oclshade_field *normals,
                                       normals_job *j)
{
    oclshade_status st = terrain_job_for(lib, p, &j->t);
    if (st == OCLSHADE_OK && normals == NULL)
        st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "normals must point to an oclshade_field, got NULL");
    j->normals = normals;
    return st;
}

oclshade_status oclshade_terrain_normals_scratch_size(oclshade *lib, const oclshade_terrain_params *params,
                                                      const oclshade_field *normals, size_t *bytes)
{
    normals_job j;
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st == OCLSHADE_OK) st = normals_job_for(lib, params, normals, &j);
    return st != OCLSHADE_OK ? st : ocls_plan(lib, normals_body, &j, bytes);
}

oclshade_status oclshade_enqueue_terrain_normals(oclshade *lib, cl_command_queue queue,
                                                 const oclshade_terrain_params *p, const oclshade_field *normals,
                                                 cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                 cl_event *event)
{
    normals_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = normals_job_for(lib, p, normals, &j);
    if (st != OCLSHADE_OK) return st;
    const int height = p->camera.height;
    const size_t width = (size_t)p->camera.width;
    if ((st = ocls_use_field(lib, &uses, "heights", &p->heights, p->rows, 4u * (size_t)p->cols, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_field(lib, &uses, "uv", &p->gbuffer.uv, height, 8 * width, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_field(lib, &uses, "position", &p->gbuffer.position, height, 16 * width, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_field(lib, &uses, "normals", normals, height, 16 * width, OCLS_OUT)) != OCLSHADE_OK)
        return st;
    return ocls_enqueue(lib, queue, p->scratch, &uses, normals_body, &j, num_events_in_wait_list, event_wait_list, event);
}
