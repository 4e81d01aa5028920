/* camera.c — cameras (oclshade/camera.py Camera), host maths only. */
#include "internal.h"

#include <math.h>
#include <string.h>

static const double PI = 3.141592653589793;

static double norm3(const double v[3]) { return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static int finite3(const double v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

/* Camera.__post_init__'s checks of everything but the vectors. */
static int camera_ok(int width, int height, oclshade_projection projection, double sx, double sy, double near_depth,
                     double far_depth)
{
    if (width < 1 || width > 32768 || height < 1 || height > 32768) return 0;
    if (projection != OCLSHADE_PERSPECTIVE && projection != OCLSHADE_ORTHOGRAPHIC) return 0;
    if (!(isfinite(sx) && sx > 0.0 && isfinite(sy) && sy > 0.0)) return 0;
    if (projection == OCLSHADE_PERSPECTIVE ? !(isfinite(near_depth) && near_depth > 0.0)
                                           : !(isfinite(near_depth) && near_depth >= 0.0))
        return 0;
    return isfinite(far_depth) && far_depth > near_depth;
}

/* Camera.projection_matrix */
static void projection_matrix(oclshade_camera *c)
{
    const double n = c->near_depth, f = c->far_depth;
    double *m = c->projection_matrix;
    memset(m, 0, 16 * sizeof *m);
    m[0] = 1.0 / c->sx;
    m[5] = 1.0 / c->sy;
    if (c->projection == OCLSHADE_PERSPECTIVE) {
        m[10] = -(f + n) / (f - n);
        m[11] = -2.0 * f * n / (f - n);
        m[14] = -1.0;
    } else {
        m[10] = -2.0 / (f - n);
        m[11] = -(f + n) / (f - n);
        m[15] = 1.0;
    }
}

oclshade_status oclshade_camera_look_at(const double position[3], const double look_at[3], const double up[3],
                                        int width, int height, oclshade_projection projection, double fov,
                                        double ortho_height, double near_depth, double far_depth, oclshade_camera *out)
{
    static const double z_up[3] = {0.0, 0.0, 1.0}, north[3] = {0.0, 1.0, 0.0}, east[3] = {1.0, 0.0, 0.0};
    if (up == NULL) up = z_up;
    if (out == NULL || position == NULL || look_at == NULL || !finite3(position) || !finite3(look_at) || !finite3(up) ||
        norm3(up) == 0.0 || !(projection == OCLSHADE_ORTHOGRAPHIC || (fov > 0.0 && fov < 180.0)) ||
        !(projection == OCLSHADE_PERSPECTIVE || (isfinite(ortho_height) && ortho_height > 0.0)))
        return OCLSHADE_INVALID_ARGUMENT;
    double fwd[3] = {look_at[0] - position[0], look_at[1] - position[1], look_at[2] - position[2]};
    const double len = norm3(fwd);
    if (len == 0.0) return OCLSHADE_INVALID_ARGUMENT;
    /* Camera.scale */
    const double aspect = (double)width / (double)height;
    const double sy = projection == OCLSHADE_PERSPECTIVE ? tan(fov * (PI / 180.0) / 2.0) : ortho_height / 2.0;
    const double sx = sy * aspect;
    if (!camera_ok(width, height, projection, sx, sy, near_depth, far_depth)) return OCLSHADE_INVALID_ARGUMENT;
    /* Camera.rotation: rows right, up, back; up parallel to the view: north, then east */
    for (int i = 0; i < 3; ++i) fwd[i] = fwd[i] / len;
    const double *const ups[3] = {up, north, east};
    double right[3], true_up[3];
    for (int k = 0; k < 3; ++k) {
        const double n = norm3(ups[k]);
        const double u[3] = {ups[k][0] / n, ups[k][1] / n, ups[k][2] / n};
        cross3(fwd, u, right);
        if (norm3(right) > 1e-9) break;
    }
    const double rn = norm3(right);
    for (int i = 0; i < 3; ++i) right[i] = right[i] / rn;
    cross3(right, fwd, true_up);
    memset(out, 0, sizeof *out);
    out->width = width;
    out->height = height;
    out->projection = projection;
    /* Camera.view: [rot | -rot @ position] */
    for (int i = 0; i < 3; ++i) {
        out->view[i] = right[i];
        out->view[4 + i] = true_up[i];
        out->view[8 + i] = -fwd[i];
    }
    for (int r = 0; r < 3; ++r)
        out->view[4 * r + 3] = (-out->view[4 * r]) * position[0] + (-out->view[4 * r + 1]) * position[1] +
                               (-out->view[4 * r + 2]) * position[2];
    out->view[15] = 1.0;
    out->sx = sx;
    out->sy = sy;
    out->near_depth = near_depth;
    out->far_depth = far_depth;
    projection_matrix(out);
    return OCLSHADE_OK;
}

oclshade_status oclshade_camera_from_matrices(const double view[16], const double projection[16], int width,
                                              int height, oclshade_camera *out)
{
    if (out == NULL || view == NULL || projection == NULL) return OCLSHADE_INVALID_ARGUMENT;
    for (int i = 0; i < 16; ++i)
        if (!isfinite(view[i]) || !isfinite(projection[i])) return OCLSHADE_INVALID_ARGUMENT;
    /* rigid: rows of the rotation orthonormal, right-handed, last row 0 0 0 1 */
    if (view[12] != 0.0 || view[13] != 0.0 || view[14] != 0.0 || view[15] != 1.0) return OCLSHADE_INVALID_ARGUMENT;
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            const double dot = view[4 * a] * view[4 * b] + view[4 * a + 1] * view[4 * b + 1] + view[4 * a + 2] * view[4 * b + 2];
            if (fabs(dot - (a == b ? 1.0 : 0.0)) > 1e-9) return OCLSHADE_INVALID_ARGUMENT;
        }
    double x_cross_y[3];
    cross3(&view[0], &view[4], x_cross_y);
    if (x_cross_y[0] * view[8] + x_cross_y[1] * view[9] + x_cross_y[2] * view[10] <= 0.0) return OCLSHADE_INVALID_ARGUMENT;
    const double *P = projection;
    /* symmetric: no off-axis or shear terms */
    if (P[1] != 0.0 || P[2] != 0.0 || P[3] != 0.0 || P[4] != 0.0 || P[6] != 0.0 || P[7] != 0.0 || P[8] != 0.0 ||
        P[9] != 0.0 || P[12] != 0.0 || P[13] != 0.0 || !(P[0] > 0.0) || !(P[5] > 0.0))
        return OCLSHADE_INVALID_ARGUMENT;
    oclshade_projection kind;
    double n, f;
    if (P[14] == -1.0 && P[15] == 0.0) {          /* m22 = -(f+n)/(f-n), m23 = -2fn/(f-n) */
        kind = OCLSHADE_PERSPECTIVE;
        n = P[11] / (P[10] - 1.0);
        f = P[11] / (P[10] + 1.0);
    } else if (P[14] == 0.0 && P[15] == 1.0) {    /* m22 = -2/(f-n), m23 = -(f+n)/(f-n) */
        kind = OCLSHADE_ORTHOGRAPHIC;
        const double span = -2.0 / P[10], sum = -P[11] * span;
        n = (sum - span) / 2.0;
        f = (sum + span) / 2.0;
    } else {
        return OCLSHADE_INVALID_ARGUMENT;
    }
    const double sx = 1.0 / P[0], sy = 1.0 / P[5];
    if (!camera_ok(width, height, kind, sx, sy, n, f)) return OCLSHADE_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    out->width = width;
    out->height = height;
    out->projection = kind;
    memcpy(out->view, view, sizeof out->view);
    memcpy(out->projection_matrix, projection, sizeof out->projection_matrix);
    out->sx = sx;
    out->sy = sy;
    out->near_depth = n;
    out->far_depth = f;
    return OCLSHADE_OK;
}
