/* quadrics.c — quadrics on the terrain (kernels/quadric.cl quadric_cast, gbuffer_merge,
 * object_normals, quadric_shadow, and a point light's terrain_point_shadow and
 * quadric_point_shadow; oclshade/quadrics/caster.py QuadricCaster, terrain_point_shadow), and
 * the host tables of their shapes (QuadricCaster.tables, screen_rect). */
#include "internal.h"

#include <math.h>
#include <string.h>

void oclshade_quadric_params_init(oclshade_quadric_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
}

/* ------------------------------------------------------------------ host tables */

static double norm3(const double v[3]) { return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

/* oclshade/quadrics/objects.py frame_from_axis: columns local x, y, z (f[row][col]). */
static int frame_from_axis(const double axis[3], double f[3][3])
{
    const double n = norm3(axis);
    if (!(n > 0.0) || !isfinite(n)) return 0;
    const double z[3] = {axis[0] / n, axis[1] / n, axis[2] / n};
    double x[3] = {0.0, 0.0, 0.0};
    for (int r = 0; r < 2; ++r) {                     /* east, else north */
        const double ref[3] = {r == 0 ? 1.0 : 0.0, r == 1 ? 1.0 : 0.0, 0.0};
        const double d = ref[0] * z[0] + ref[1] * z[1] + ref[2] * z[2];
        for (int i = 0; i < 3; ++i) x[i] = ref[i] - d * z[i];
        if (norm3(x) > 1e-6) break;
    }
    const double xn = norm3(x);
    for (int i = 0; i < 3; ++i) x[i] /= xn;
    const double y[3] = {z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]};
    for (int i = 0; i < 3; ++i) {
        f[i][0] = x[i];
        f[i][1] = y[i];
        f[i][2] = z[i];
    }
    return 1;
}

/* view[:3, :3] @ p + view[:3, 3] */
static void to_view(const double *V, const double p[3], double out[3])
{
    for (int r = 0; r < 3; ++r) out[r] = (V[4 * r] * p[0] + V[4 * r + 1] * p[1] + V[4 * r + 2] * p[2]) + V[4 * r + 3];
}

static int clip_int(double v, int hi) { return v < 0.0 ? 0 : v > hi ? hi : (int)v; }

/* caster.py screen_rect: the pixels that may see a view-space sphere. */
void ocls_screen_rect(const oclshade_camera *cam, const double c[3], double radius, cl_int out[4])
{
    const int w = cam->width, h = cam->height;
    double cmin = INFINITY, cmax = -INFINITY, rmin = INFINITY, rmax = -INFINITY, dmin = INFINITY;
    for (int k = 0; k < 8; ++k) {
        const double p[3] = {c[0] + radius * ((k & 4) ? 1.0 : -1.0), c[1] + radius * ((k & 2) ? 1.0 : -1.0),
                             c[2] + radius * ((k & 1) ? 1.0 : -1.0)};
        double nx, ny;
        if (cam->projection == OCLSHADE_PERSPECTIVE) {
            const double depth = -p[2];
            dmin = depth < dmin ? depth : dmin;
            nx = p[0] / (depth * cam->sx);
            ny = p[1] / (depth * cam->sy);
        } else {
            nx = p[0] / cam->sx;
            ny = p[1] / cam->sy;
        }
        const double col = ((nx + 1.0) * w - 1.0) / 2.0, row = ((1.0 - ny) * h - 1.0) / 2.0;
        cmin = col < cmin ? col : cmin;
        cmax = col > cmax ? col : cmax;
        rmin = row < rmin ? row : rmin;
        rmax = row > rmax ? row : rmax;
    }
    if (cam->projection == OCLSHADE_PERSPECTIVE && dmin <= cam->near_depth) {
        out[0] = 0; out[1] = 0; out[2] = w; out[3] = h;
        return;
    }
    out[0] = clip_int(floor(cmin) - 1.0, w);
    out[1] = clip_int(floor(rmin) - 1.0, h);
    out[2] = clip_int(ceil(cmax) + 2.0, w);
    out[3] = clip_int(ceil(rmax) + 2.0, h);
}

static const int KIND_CODE[4] = {0, 0, 1, 2};   /* objects.py KIND_CODE: ellipsoid, cylinder, paraboloid */

oclshade_status oclshade_quadric_tables(const oclshade_quadric *quadrics, int count, const oclshade_camera *camera,
                                        cl_float4 *qf, cl_int4 *qi)
{
    if (quadrics == NULL || camera == NULL || qf == NULL || qi == NULL || count < 1 || count > OCLSHADE_MAX_QUADRICS)
        return OCLSHADE_INVALID_ARGUMENT;
    const double *V = camera->view;
    for (int k = 0; k < count; ++k) {
        const oclshade_quadric *q = &quadrics[k];
        const double *r = q->radii;
        double f[3][3];
        if ((int)q->kind < 0 || (int)q->kind > 3 || !(r[0] > 0.0 && r[1] > 0.0 && r[2] > 0.0) ||
            !isfinite(r[0] + r[1] + r[2]) || !frame_from_axis(q->axis, f) ||
            (q->kind == OCLSHADE_SPHERE && !(r[0] == r[1] && r[1] == r[2])))
            return OCLSHADE_INVALID_ARGUMENT;
        /* m = diag(1 / radii) @ (rotation @ frame)^T: row i = (R f)[:, i] / radii[i] */
        double m[3][3], c[3];
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                const double rf = V[4 * j] * f[0][i] + V[4 * j + 1] * f[1][i] + V[4 * j + 2] * f[2][i];
                m[i][j] = (1.0 / r[i]) * rf;
            }
        to_view(V, q->centre, c);
        cl_float4 *row = qf + 5 * k;
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) row[i].s[j] = (cl_float)m[i][j];
            row[i].s[3] = (cl_float)(-(m[i][0] * c[0] + m[i][1] * c[1] + m[i][2] * c[2]));
        }
        for (int i = 0; i < 3; ++i) row[3].s[i] = (cl_float)q->colour[i];
        row[3].s[3] = 1.0f;
        /* Quadric.bound */
        const double ab = r[0] > r[1] ? r[0] : r[1];
        double centre[3] = {q->centre[0], q->centre[1], q->centre[2]}, radius;
        if (q->kind == OCLSHADE_SPHERE || q->kind == OCLSHADE_ELLIPSOID) {
            radius = ab > r[2] ? ab : r[2];
        } else if (q->kind == OCLSHADE_CYLINDER) {
            radius = hypot(ab, r[2]);
        } else {
            for (int i = 0; i < 3; ++i) centre[i] = q->centre[i] + (0.5 * r[2]) * f[i][2];
            radius = hypot(ab, 0.5 * r[2]);
        }
        double bc[3];
        to_view(V, centre, bc);
        for (int i = 0; i < 3; ++i) row[4].s[i] = (cl_float)bc[i];
        row[4].s[3] = (cl_float)radius;
        qi[2 * k].s[0] = KIND_CODE[q->kind];
        qi[2 * k].s[1] = qi[2 * k].s[2] = qi[2 * k].s[3] = 0;
        ocls_screen_rect(camera, bc, radius, qi[2 * k + 1].s);
    }
    return OCLSHADE_OK;
}

/* ------------------------------------------------------------------ the sun on object pixels */

oclshade_status ocls_check_sun(oclshade *lib, double azimuth, double elevation, double k_dark, double k_bright)
{
    if (!isfinite(azimuth) || !(elevation >= -90.0 && elevation <= 90.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "azimuth must be finite and elevation in [-90, 90], "
                         "got %g, %g", azimuth, elevation);
    if (!(k_dark >= 0.0 && k_dark <= 1.0) || !(k_bright >= 0.0 && k_bright <= 1.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "k_dark and k_bright must be in [0, 1], got %g, %g",
                         k_dark, k_bright);
    return OCLSHADE_OK;
}

float ocls_kshadow(double elevation, double k_dark, double k_bright)
{
    const double e = sin(elevation * (3.14159265358979323846 / 180.0));
    return (cl_float)(k_dark + (k_bright - k_dark) * (e > 0.0 ? e : 0.0));
}

/* caster.py terrain_shadow_args: the view-space sun (w = 1 at or below the horizon), the
 * terrain ray and eq. (1)'s coefficient. */
oclshade_status ocls_sun_args_for(oclshade *lib, const oclshade_camera *camera, int terrain, double dx, double dy,
                                  double azimuth, double elevation, double k_dark, double k_bright, ocls_sun_args *out)
{
    double s[3];
    oclshade_sun sun;
    oclshade_status st;
    if ((st = oclshade_sun_vector(azimuth, elevation, s)) != OCLSHADE_OK ||
        (st = oclshade_sun_for(azimuth, elevation, dx > 0.0 ? dx : 1.0, dy > 0.0 ? dy : 1.0, &sun)) != OCLSHADE_OK)
        return ocls_fail(lib, st, 0, "the sun (%g, %g) could not be set up", azimuth, elevation);
    const int below = elevation <= 0.0;
    const double *V = camera->view;
    memset(out, 0, sizeof *out);
    for (int r = 0; r < 3; ++r) out->sun.s[r] = (cl_float)(V[4 * r] * s[0] + V[4 * r + 1] * s[1] + V[4 * r + 2] * s[2]);
    out->sun.s[3] = below ? 1.0f : 0.0f;
    if (terrain && !below) {   /* Sun.ray(dx, dy): w is inf at the zenith */
        cl_float uxy[2];
        ocls_horizontal_ray(azimuth, dx, dy, uxy);
        out->ray.s[0] = uxy[0];
        out->ray.s[1] = uxy[1];
        out->ray.s[2] = sun.mode == 0 ? sun.ray[2] : INFINITY;
    }
    out->kshadow = ocls_kshadow(elevation, k_dark, k_bright);
    return OCLSHADE_OK;
}

/* ------------------------------------------------------------------ passes */

enum { CAST, MERGE, NORMALS, SHADOW, TPOINT, QPOINT };

typedef struct quadric_job {
    const oclshade_quadric_params *p;
    int op;
    cl_float4 hm[3];   /* rows of view -> (u, v, z - offset) (zeros without a terrain) */
    cl_float4 light;   /* TPOINT: the light in (u, v, z - offset); QPOINT: in view space (w 0) */
} quadric_job;

/* caster.py heightmap_rows: heightmap_from_world(hm) @ inv(view), the view rigid: inv = [R^T | -R^T t]
 * (numpy inverts by LU: equal up to rounding, as terrain.c); zeros without a terrain. */
void ocls_heightmap_rows(const double *V, int terrain, double dx, double dy, double offset, cl_float4 hm[3])
{
    memset(hm, 0, 3 * sizeof *hm);
    if (!terrain) return;
    double inv[4][4] = {{0}};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) inv[r][c] = V[4 * c + r];
        inv[r][3] = -(V[r] * V[3] + V[4 + r] * V[7] + V[8 + r] * V[11]);
    }
    inv[3][3] = 1.0;
    const double h[3][4] = {{1.0 / dx, 0.0, 0.0, 0.0}, {0.0, -1.0 / dy, 0.0, 0.0}, {0.0, 0.0, 1.0, -offset}};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) {
            double sum = 0.0;
            for (int k = 0; k < 4; ++k) sum += h[r][k] * inv[k][c];
            hm[r].s[c] = (cl_float)sum;
        }
}

/* caster.py terrain_point_shadow: heightmap_from_world(hm) @ (light, 1), summed in index order
 * (one or two non-zero terms a row: the same bits in any order); zeros without a terrain. */
static void light_in_heightmap(const oclshade_quadric_params *p, cl_float4 *out)
{
    memset(out, 0, sizeof *out);
    if (p->heights.buffer == NULL) return;
    const double m[3][4] = {{1.0 / p->dx, 0.0, 0.0, -0.0}, {0.0, -1.0 / p->dy, 0.0, -0.0}, {0.0, 0.0, 1.0, -p->offset}};
    const double v[4] = {p->light_position[0], p->light_position[1], p->light_position[2], 1.0};
    for (int r = 0; r < 3; ++r) {
        double sum = 0.0;
        for (int k = 0; k < 4; ++k) sum += m[r][k] * v[k];
        out->s[r] = (cl_float)sum;
    }
}

static oclshade_status quadric_job_for(oclshade *lib, const oclshade_quadric_params *p, int op, quadric_job *j)
{
    memset(j, 0, sizeof *j);
    j->p = p;
    j->op = op;
    if (p == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params must point to oclshade_quadric_params, got NULL");
    oclshade_status st = ocls_check_size(lib, "camera.height", p->camera.height, "camera.width", p->camera.width);
    if (st != OCLSHADE_OK) return st;
    if (p->camera.width > 32768 || p->camera.height > 32768)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "camera width and height must be in 1..32768, got %d, %d",
                         p->camera.width, p->camera.height);
    if (op == CAST || op == SHADOW || op == TPOINT || op == QPOINT) {
        if (op != TPOINT && (p->count < 1 || p->count > OCLSHADE_MAX_QUADRICS))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "count must be the number of quadrics, 1..%d, got %d",
                             OCLSHADE_MAX_QUADRICS, p->count);
        if (!(p->camera.sx > 0.0) || !(p->camera.sy > 0.0) || !(p->camera.far_depth > p->camera.near_depth))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "camera must come from oclshade_camera_look_at or "
                             "oclshade_camera_from_matrices (sx, sy > 0, far > near)");
        if (p->heights.buffer != NULL) {
            if ((st = ocls_check_size(lib, "rows", p->rows, "cols", p->cols)) != OCLSHADE_OK) return st;
            if (!(p->dx > 0.0) || !(p->dy > 0.0) || !isfinite(p->dx) || !isfinite(p->dy) || !isfinite(p->offset))
                return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "dx, dy must be positive finite cell sizes and "
                                 "offset finite, got %g, %g, %g", p->dx, p->dy, p->offset);
        }
    }
    if (op == SHADOW) {
        if ((st = ocls_check_sun(lib, p->azimuth, p->elevation, p->k_dark, p->k_bright)) != OCLSHADE_OK) return st;
        if (!isfinite(p->hmax)) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "hmax must be finite, got %g", p->hmax);
    }
    if (op == TPOINT || op == QPOINT) {
        for (int i = 0; i < 3; ++i)
            if (!isfinite(p->light_position[i]))
                return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "light_position must be the point light's finite "
                                 "world position (metres), got light_position[%d] = %g", i, p->light_position[i]);
        if (!(p->k_dark >= 0.0 && p->k_dark <= 1.0))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "k_dark must be in [0, 1] (a shadowed pixel's "
                             "coefficient), got %g", p->k_dark);
        if (op == TPOINT && !isfinite(p->hmax))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "hmax must be finite, got %g", p->hmax);
    }
    ocls_heightmap_rows(p->camera.view, p->heights.buffer != NULL, p->dx, p->dy, p->offset, j->hm);
    if (op == TPOINT) light_in_heightmap(p, &j->light);
    if (op == QPOINT) {   /* caster.py light_view: view[:3, :3] @ position + view[:3, 3], rounded once */
        double v[3];
        to_view(p->camera.view, p->light_position, v);
        for (int i = 0; i < 3; ++i) j->light.s[i] = (cl_float)v[i];
    }
    return OCLSHADE_OK;
}

/* Bytes per pixel of the G-buffer's fields, in the kernels' order. */
static const size_t GB_BYTES[7] = {16, 16, 8, 16, 4, 16, 4};
static const char *const GB_NAMES[2][7] = {
    {"objects.position", "objects.normal", "objects.uv", "objects.uv_grad", "objects.depth", "objects.albedo",
     "objects.object"},
    {"gbuffer.position", "gbuffer.normal", "gbuffer.uv", "gbuffer.uv_grad", "gbuffer.depth", "gbuffer.albedo",
     "gbuffer.object"}};

static const oclshade_field *gb_field(const oclshade_object_gbuffer *g, int i)
{
    const oclshade_field *f[7] = {&g->position, &g->normal, &g->uv, &g->uv_grad, &g->depth, &g->albedo, &g->object};
    return f[i];
}

/* An input and output field: read from its own buffer or a staged copy, copied back at the end. */
oclshade_status ocls_bind_inout(ocls_pass *ps, const oclshade_field *f, int rows, size_t row_bytes,
                                  const char *name, cl_mem *out)
{
    oclshade_status st = ocls_bind_in(ps, f, rows, row_bytes, name, out);
    if (st != OCLSHADE_OK || !ps->run || *out == f->buffer) return st;
    const int i = ps->nstaged++;
    ps->staged[i].field = f;
    ps->staged[i].view = *out;
    ps->staged[i].rows = rows;
    ps->staged[i].row_bytes = row_bytes;
    ps->staged[i].name = name;
    return OCLSHADE_OK;
}

static oclshade_status quadric_body(ocls_pass *ps, const void *params)
{
    const quadric_job *j = (const quadric_job *)params;
    const oclshade_quadric_params *p = j->p;
    const int W = p->camera.width, H = p->camera.height;
    const cl_int n = W * H;
    cl_mem src[7] = {NULL}, dst[7] = {NULL}, heights = NULL, extra = NULL;
    oclshade_status st = OCLSHADE_OK;
    for (int i = 0; i < 7 && st == OCLSHADE_OK; ++i) {
        const size_t row = GB_BYTES[i] * (size_t)W;
        if (j->op == CAST) st = ocls_bind_out(ps, gb_field(&p->objects, i), H, row, GB_NAMES[0][i], &src[i]);
        if (j->op == MERGE) {
            st = ocls_bind_in(ps, gb_field(&p->objects, i), H, row, GB_NAMES[0][i], &src[i]);
            if (st == OCLSHADE_OK) st = ocls_bind_inout(ps, gb_field(&p->gbuffer, i), H, row, GB_NAMES[1][i], &dst[i]);
        }
        if ((j->op == NORMALS && (i == 1 || i == 6)) || (j->op >= SHADOW && (i == 0 || i == 6)))
            st = ocls_bind_in(ps, gb_field(&p->gbuffer, i), H, row, GB_NAMES[1][i], &dst[i]);
    }
    if (st == OCLSHADE_OK && j->op == NORMALS) st = ocls_bind_inout(ps, &p->shading, H, 16 * (size_t)W, "shading", &extra);
    if (st == OCLSHADE_OK && (j->op == SHADOW || j->op == QPOINT))
        st = ocls_bind_inout(ps, &p->coefficient, H, 4 * (size_t)W, "coefficient", &extra);
    if (st == OCLSHADE_OK && j->op == TPOINT)   /* every pixel written */
        st = ocls_bind_out(ps, &p->coefficient, H, 4 * (size_t)W, "coefficient", &extra);
    if (st == OCLSHADE_OK && (j->op == SHADOW || j->op == TPOINT) && p->heights.buffer != NULL)
        st = ocls_bind_in(ps, &p->heights, p->rows, 4 * (size_t)p->cols, "heights", &heights);
    if (st != OCLSHADE_OK || !ps->run) return st;
    ocls_defines d = {0};
    kernel_entry *k;
    if (j->op == CAST) {
        ocls_def_flag(&d, "OCLS_ORTHO", p->camera.projection == OCLSHADE_ORTHOGRAPHIC);
        const cl_float4 cam = {{(cl_float)p->camera.sx, (cl_float)p->camera.sy, (cl_float)p->camera.near_depth,
                                (cl_float)p->camera.far_depth}};
        const ocls_arg a[15] = {OCLS_ARG(p->count), OCLS_ARG(p->qf), OCLS_ARG(p->qi), OCLS_ARG(cam), OCLS_ARG(W),
                                OCLS_ARG(H), OCLS_ARG(j->hm[0]), OCLS_ARG(j->hm[1]), OCLS_ARG(src[0]),
                                OCLS_ARG(src[1]), OCLS_ARG(src[2]), OCLS_ARG(src[3]), OCLS_ARG(src[4]),
                                OCLS_ARG(src[5]), OCLS_ARG(src[6])};
        if ((st = ocls_kernel(ps, "quadric.cl", &d, "quadric_cast", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 15)) != OCLSHADE_OK)
            return st;
        return ocls_launch(ps, k, W, H, 64, 16);   /* Runtime.grid_2d */
    }
    if (j->op == MERGE) {
        ocls_arg a[15] = {OCLS_ARG(n)};
        for (int i = 0; i < 7; ++i) {
            a[1 + i].size = a[8 + i].size = sizeof(cl_mem);
            a[1 + i].value = &src[i];
            a[8 + i].value = &dst[i];
        }
        if ((st = ocls_kernel(ps, "quadric.cl", &d, "gbuffer_merge", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 15)) != OCLSHADE_OK)
            return st;
        return ocls_launch(ps, k, n, 0, 64, 0);    /* QuadricCaster._launch: 1-D, local_size(k, 64) */
    }
    if (j->op == NORMALS) {
        const ocls_arg a[4] = {OCLS_ARG(n), OCLS_ARG(dst[6]), OCLS_ARG(dst[1]), OCLS_ARG(extra)};
        if ((st = ocls_kernel(ps, "quadric.cl", &d, "object_normals", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 4)) != OCLSHADE_OK)
            return st;
        return ocls_launch(ps, k, n, 0, 64, 0);
    }
    if (j->op == TPOINT) {   /* caster.py terrain_point_shadow's arguments */
        const cl_int rows = p->heights.buffer ? p->rows : 0, cols = p->heights.buffer ? p->cols : 0;
        const cl_float zmax = p->heights.buffer ? p->hmax : 0.0f, kshadow = (cl_float)p->k_dark;
        const cl_mem h = heights ? heights : dst[0];   /* not read without a terrain (rows, cols 0) */
        const ocls_arg a[13] = {OCLS_ARG(n), OCLS_ARG(dst[0]), OCLS_ARG(dst[6]), OCLS_ARG(j->light), OCLS_ARG(h),
                                OCLS_ARG(rows), OCLS_ARG(cols), OCLS_ARG(zmax), OCLS_ARG(j->hm[0]), OCLS_ARG(j->hm[1]),
                                OCLS_ARG(j->hm[2]), OCLS_ARG(kshadow), OCLS_ARG(extra)};
        if ((st = ocls_kernel(ps, "quadric.cl", &d, "terrain_point_shadow", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 13)) != OCLSHADE_OK)
            return st;
        return ocls_launch(ps, k, n, 0, 64, 0);
    }
    if (j->op == QPOINT) {   /* QuadricCaster.point_shadow's arguments */
        const cl_float kshadow = (cl_float)p->k_dark;
        const ocls_arg a[9] = {OCLS_ARG(n), OCLS_ARG(p->count), OCLS_ARG(p->qf), OCLS_ARG(p->qi), OCLS_ARG(dst[0]),
                               OCLS_ARG(dst[6]), OCLS_ARG(j->light), OCLS_ARG(kshadow), OCLS_ARG(extra)};
        if ((st = ocls_kernel(ps, "quadric.cl", &d, "quadric_point_shadow", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, a, 9)) != OCLSHADE_OK)
            return st;
        return ocls_launch(ps, k, n, 0, 64, 0);
    }
    /* SHADOW: QuadricCaster.shadow's arguments */
    ocls_sun_args sa;
    if ((st = ocls_sun_args_for(ps->lib, &p->camera, p->heights.buffer != NULL, p->dx, p->dy, p->azimuth, p->elevation,
                                p->k_dark, p->k_bright, &sa)) != OCLSHADE_OK)
        return st;
    const cl_int rows = p->heights.buffer ? p->rows : 0, cols = p->heights.buffer ? p->cols : 0;
    const cl_float zmax = p->heights.buffer ? p->hmax : 0.0f;
    const cl_mem h = heights ? heights : p->qf;   /* not read without a terrain (rows, cols 0) */
    const ocls_arg a[17] = {OCLS_ARG(n), OCLS_ARG(p->count), OCLS_ARG(p->qf), OCLS_ARG(p->qi), OCLS_ARG(dst[0]),
                            OCLS_ARG(dst[6]), OCLS_ARG(sa.sun), OCLS_ARG(h), OCLS_ARG(rows), OCLS_ARG(cols),
                            OCLS_ARG(zmax), OCLS_ARG(j->hm[0]), OCLS_ARG(j->hm[1]), OCLS_ARG(j->hm[2]),
                            OCLS_ARG(sa.ray), OCLS_ARG(sa.kshadow), OCLS_ARG(extra)};
    if ((st = ocls_kernel(ps, "quadric.cl", &d, "quadric_shadow", &k)) != OCLSHADE_OK ||
        (st = ocls_set_args(ps, k, a, 17)) != OCLSHADE_OK)
        return st;
    return ocls_launch(ps, k, n, 0, 64, 0);
}

oclshade_status oclshade_quadric_scratch_size(oclshade *lib, const oclshade_quadric_params *params, size_t *bytes)
{
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st != OCLSHADE_OK) return st;
    *bytes = 0;
    for (int op = CAST; op <= QPOINT; ++op) {
        quadric_job j;
        size_t b = 0;
        if (op == CAST || op == SHADOW || op == QPOINT) {   /* checked only for the calls whose members are set */
            if (params != NULL && (params->count < 1 || params->qf == NULL)) continue;
        }
        if ((st = quadric_job_for(lib, params, op, &j)) != OCLSHADE_OK || (st = ocls_plan(lib, quadric_body, &j, &b)) != OCLSHADE_OK)
            return st;
        if (b > *bytes) *bytes = b;
    }
    return OCLSHADE_OK;
}

static oclshade_status gb_uses(oclshade *lib, ocls_uses *uses, const oclshade_object_gbuffer *g, int which, int H, int W,
                               int access, unsigned mask)
{
    oclshade_status st = OCLSHADE_OK;
    for (int i = 0; i < 7 && st == OCLSHADE_OK; ++i)
        if (mask & (1u << i)) st = ocls_use_field(lib, uses, GB_NAMES[which][i], gb_field(g, i), H, GB_BYTES[i] * (size_t)W, access);
    return st;
}

static oclshade_status quadric_enqueue(oclshade *lib, cl_command_queue queue, const oclshade_quadric_params *p, int op,
                                       cl_uint nwait, const cl_event *wait, cl_event *event)
{
    quadric_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = quadric_job_for(lib, p, op, &j);
    if (st != OCLSHADE_OK) return st;
    const int W = p->camera.width, H = p->camera.height;
    if (op == CAST || op == SHADOW || op == QPOINT) {
        if ((st = ocls_use_buffer(lib, &uses, "qf", p->qf, 80 * (size_t)p->count, OCLS_IN)) != OCLSHADE_OK ||
            (st = ocls_use_buffer(lib, &uses, "qi", p->qi, 32 * (size_t)p->count, OCLS_IN)) != OCLSHADE_OK)
            return st;
    }
    if (op == CAST) st = gb_uses(lib, &uses, &p->objects, 0, H, W, OCLS_OUT, 0x7f);
    if (op == MERGE && (st = gb_uses(lib, &uses, &p->objects, 0, H, W, OCLS_IN, 0x7f)) == OCLSHADE_OK)
        st = gb_uses(lib, &uses, &p->gbuffer, 1, H, W, OCLS_INOUT, 0x7f);
    if (op == NORMALS && (st = gb_uses(lib, &uses, &p->gbuffer, 1, H, W, OCLS_IN, 0x42)) == OCLSHADE_OK)
        st = ocls_use_field(lib, &uses, "shading", &p->shading, H, 16 * (size_t)W, OCLS_INOUT);
    if (op >= SHADOW && (st = gb_uses(lib, &uses, &p->gbuffer, 1, H, W, OCLS_IN, 0x41)) == OCLSHADE_OK) {
        st = ocls_use_field(lib, &uses, "coefficient", &p->coefficient, H, 4 * (size_t)W,
                            op == TPOINT ? OCLS_OUT : OCLS_INOUT);
        if (st == OCLSHADE_OK && op != QPOINT && p->heights.buffer != NULL)
            st = ocls_use_field(lib, &uses, "heights", &p->heights, p->rows, 4 * (size_t)p->cols, OCLS_IN);
    }
    if (st != OCLSHADE_OK) return st;
    return ocls_enqueue(lib, queue, p->scratch, &uses, quadric_body, &j, nwait, wait, event);
}

oclshade_status oclshade_enqueue_quadric_cast(oclshade *lib, cl_command_queue queue, const oclshade_quadric_params *params,
                                              cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                              cl_event *event)
{
    return quadric_enqueue(lib, queue, params, CAST, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_gbuffer_merge(oclshade *lib, cl_command_queue queue, const oclshade_quadric_params *params,
                                               cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                               cl_event *event)
{
    return quadric_enqueue(lib, queue, params, MERGE, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_object_normals(oclshade *lib, cl_command_queue queue,
                                                const oclshade_quadric_params *params,
                                                cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                cl_event *event)
{
    return quadric_enqueue(lib, queue, params, NORMALS, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_quadric_shadow(oclshade *lib, cl_command_queue queue,
                                                const oclshade_quadric_params *params,
                                                cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                cl_event *event)
{
    return quadric_enqueue(lib, queue, params, SHADOW, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_terrain_point_shadow(oclshade *lib, cl_command_queue queue,
                                                      const oclshade_quadric_params *params,
                                                      cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                      cl_event *event)
{
    return quadric_enqueue(lib, queue, params, TPOINT, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_enqueue_quadric_point_shadow(oclshade *lib, cl_command_queue queue,
                                                      const oclshade_quadric_params *params,
                                                      cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                      cl_event *event)
{
    return quadric_enqueue(lib, queue, params, QPOINT, num_events_in_wait_list, event_wait_list, event);
}
