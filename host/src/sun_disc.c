/* sun_disc.c — soft shadows: the visible share of the sun's disc from the clamped horizons of its
 * strips (oclshade/horizon/disc.py; HorizonCaster.sun_disc, _strip_angles). */
#include "internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define SUN_RADIUS 0.2666       /* disc.py SUN_RADIUS */
#define DEFAULT_COLUMNS 16      /* disc.py DEFAULT_COLUMNS */
#define STRIP_MARGIN 1e-3       /* caster.py STRIP_MARGIN: degrees either side of a strip's chord */
#define DEG (3.14159265358979323846 / 180.0)

oclshade_status oclshade_sun_disc_strips(double azimuth, double elevation, double radius, int columns,
                                         double *azimuths, double *half_chords, double (*bounds)[2])
{
    if (!(isfinite(radius) && radius > 0.0 && radius <= 5.0) || columns < 1 || columns > 1024 ||
        !isfinite(azimuth) || !(fabs(elevation) < 90.0 - radius))
        return OCLSHADE_INVALID_ARGUMENT;
    const double width = 2.0 * radius / columns, across = cos(elevation * DEG);
    for (int k = 0; k < columns; ++k) {
        const double x = -radius + ((double)k + 0.5) * width, c = sqrt(radius * radius - x * x);
        if (azimuths != NULL) {          /* numpy's %: the divisor's sign */
            const double a = fmod(azimuth + x / across, 360.0);
            azimuths[k] = a != 0.0 ? (a < 0.0 ? a + 360.0 : a) : 0.0;
        }
        if (half_chords != NULL) half_chords[k] = c;
        if (bounds != NULL) {
            bounds[k][0] = tan((elevation - (c + STRIP_MARGIN)) * DEG);
            bounds[k][1] = tan((elevation + (c + STRIP_MARGIN)) * DEG);
        }
    }
    return OCLSHADE_OK;
}

void oclshade_sun_disc_params_init(oclshade_sun_disc_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
    p->dx = p->dy = 1.0;
}

oclshade_status oclshade_sun_disc(oclshade *lib, cl_command_queue queue, const oclshade_sun_disc_params *p,
                                  float *fraction)
{
    oclshade_status st = ocls_enter(lib);
    if (st != OCLSHADE_OK) return st;
    if (p == NULL || fraction == NULL)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params and fraction must not be NULL");
    if ((st = ocls_check_size(lib, "rows", p->rows, "cols", p->cols)) != OCLSHADE_OK) return st;
    const double radius = p->radius == 0.0 ? SUN_RADIUS : p->radius;
    const int columns = p->columns == 0 ? DEFAULT_COLUMNS : p->columns;
    if (!(isfinite(radius) && radius > 0.0 && radius <= 5.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "radius (the sun disc's angular radius) must be in (0, 5] "
                         "degrees (0: %g), got %g", SUN_RADIUS, p->radius);
    if (columns < 1 || columns > 1024)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "columns (strips across the sun's disc) must be in "
                         "1..1024 (0: %d), got %d", DEFAULT_COLUMNS, p->columns);
    if (!isfinite(p->azimuth))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "azimuth must be finite degrees, got %g", p->azimuth);
    if (!(fabs(p->elevation) < 90.0 - radius))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "elevation must leave the whole disc between the nadir "
                         "and the zenith (|elevation| < %g degrees), got %g", 90.0 - radius, p->elevation);
    const size_t n = (size_t)p->rows * (size_t)p->cols;
    double *strips = (double *)malloc(sizeof *strips * 4 * (size_t)columns);
    double *seen = (double *)malloc(sizeof *seen * n);
    float *angles = (float *)malloc(sizeof *angles * n);
    cl_mem angle = NULL, scratch = NULL;
    cl_int err = CL_SUCCESS;
    if (strips == NULL || seen == NULL || angles == NULL) {
        st = ocls_fail(lib, OCLSHADE_OUT_OF_MEMORY, 0, "no host memory for a %dx%d map's soft shadows", p->cols, p->rows);
        goto done;
    }
    double *azimuths = strips, *half_chords = strips + columns, (*bounds)[2] = (double (*)[2])(strips + 2 * columns);
    oclshade_sun_disc_strips(p->azimuth, p->elevation, radius, columns, azimuths, half_chords, bounds);
    angle = clCreateBuffer(lib->context, CL_MEM_READ_WRITE, 4 * n, NULL, &err);
    if (err != CL_SUCCESS) {
        st = ocls_fail_cl(lib, err, "clCreateBuffer (the strips' horizon angles)");
        goto done;
    }
    oclshade_horizon_params h;
    oclshade_horizon_params_init(&h);
    h.heights = p->heights;
    h.rows = p->rows; h.cols = p->cols; h.dx = p->dx; h.dy = p->dy;
    h.pyramid = p->pyramid; h.offsets = p->offsets;
    h.curvature = p->curvature; h.max_distance = p->max_distance;
    h.angle = oclshade_field_of(angle);
    h.clamped = 1;
    h.azimuth = azimuths[0];
    h.clamp_bounds[0] = bounds[0][0];
    h.clamp_bounds[1] = bounds[0][1];
    size_t bytes = 0;
    if ((st = oclshade_horizon_scratch_size(lib, &h, &bytes)) != OCLSHADE_OK) goto done;
    if (bytes > 0) {
        scratch = clCreateBuffer(lib->context, CL_MEM_READ_WRITE, bytes, NULL, &err);
        if (err != CL_SUCCESS) {
            st = ocls_fail_cl(lib, err, "clCreateBuffer (the horizon pass's scratch)");
            goto done;
        }
        h.scratch = scratch;
    }
    double whole = 0.0;
    for (int k = 0; k < columns; ++k) {
        h.azimuth = azimuths[k];
        h.clamp_bounds[0] = bounds[k][0];
        h.clamp_bounds[1] = bounds[k][1];
        if ((st = oclshade_enqueue_horizon(lib, queue, &h, 0, NULL, NULL)) != OCLSHADE_OK) goto done;
        if ((err = clEnqueueReadBuffer(queue, angle, CL_TRUE, 0, 4 * n, angles, 0, NULL, NULL)) != CL_SUCCESS) {
            st = ocls_fail_cl(lib, err, "clEnqueueReadBuffer (a strip's horizon angles)");
            goto done;
        }
        const double c = half_chords[k], top = p->elevation + c;
        for (size_t i = 0; i < n; ++i) {     /* disc.py visible_fraction: clip(e + c - h, 0, 2c), summed */
            double v = top - (double)angles[i];
            if (!isnan(v)) v = v < 0.0 ? 0.0 : (v > 2.0 * c ? 2.0 * c : v);
            seen[i] = k == 0 ? v : seen[i] + v;
        }
        whole += 2.0 * c;
    }
    for (size_t i = 0; i < n; ++i) fraction[i] = (float)(seen[i] / whole);
done:
    if (scratch != NULL) clReleaseMemObject(scratch);
    if (angle != NULL) clReleaseMemObject(angle);
    free(angles);
    free(seen);
    free(strips);
    return st;
}
