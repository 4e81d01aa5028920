/* sun_disc.c — soft shadows: the visible share of the sun's disc from the clamped horizons of its
 * strips (oclshade/horizon/disc.py; HorizonCaster.sun_disc, _strip_angles). */
#include "internal.h"

#include <math.h>
#include <string.h>

#define SUN_RADIUS 0.2666       /* disc.py SUN_RADIUS */
#define DEFAULT_COLUMNS 16      /* disc.py DEFAULT_COLUMNS */
#define MAX_COLUMNS 1024        /* disc.py check_disc */
#define STRIP_MARGIN 1e-3       /* caster.py STRIP_MARGIN: degrees either side of a strip's chord */
#define DEG (3.14159265358979323846 / 180.0)

oclshade_status oclshade_sun_disc_strips(double azimuth, double elevation, double radius, int columns,
                                         double *azimuths, double *half_chords, double (*bounds)[2])
{
    if (!(isfinite(radius) && radius > 0.0 && radius <= 5.0) || columns < 1 || columns > MAX_COLUMNS ||
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

typedef struct sun_disc_job {
    double radius;
    int columns;
    double azimuths[MAX_COLUMNS], half_chords[MAX_COLUMNS], bounds[MAX_COLUMNS][2];
    oclshade_horizon_params h;   /* strip 0's clamped horizon call; the others change the azimuth and bounds */
} sun_disc_job;

static oclshade_status sun_disc_job_for(oclshade *lib, const oclshade_sun_disc_params *p, sun_disc_job *j)
{
    if (p == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params must point to oclshade_sun_disc_params, got NULL");
    j->radius = p->radius == 0.0 ? SUN_RADIUS : p->radius;
    j->columns = p->columns == 0 ? DEFAULT_COLUMNS : p->columns;
    if (!(isfinite(j->radius) && j->radius > 0.0 && j->radius <= 5.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "radius (the sun disc's angular radius) must be in (0, 5] "
                         "degrees (0: %g), got %g", SUN_RADIUS, p->radius);
    if (j->columns < 1 || j->columns > MAX_COLUMNS)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "columns (strips across the sun's disc) must be in "
                         "1..%d (0: %d), got %d", MAX_COLUMNS, DEFAULT_COLUMNS, p->columns);
    if (!isfinite(p->azimuth))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "azimuth must be finite degrees, got %g", p->azimuth);
    if (!(fabs(p->elevation) < 90.0 - j->radius))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "elevation must leave the whole disc between the nadir "
                         "and the zenith (|elevation| < %g degrees), got %g", 90.0 - j->radius, p->elevation);
    oclshade_sun_disc_strips(p->azimuth, p->elevation, j->radius, j->columns, j->azimuths, j->half_chords, j->bounds);
    oclshade_horizon_params *h = &j->h;
    oclshade_horizon_params_init(h);
    h->heights = p->heights;
    h->rows = p->rows; h->cols = p->cols; h->dx = p->dx; h->dy = p->dy;
    h->pyramid = p->pyramid; h->offsets = p->offsets;
    h->curvature = p->curvature; h->max_distance = p->max_distance;
    h->angle = p->angle;
    h->scratch = p->scratch;
    h->clamped = 1;
    h->azimuth = j->azimuths[0];
    h->clamp_bounds[0] = j->bounds[0][0];
    h->clamp_bounds[1] = j->bounds[0][1];
    return OCLSHADE_OK;
}

oclshade_status oclshade_sun_disc_scratch_size(oclshade *lib, const oclshade_sun_disc_params *p, size_t *bytes)
{
    sun_disc_job j;             /* (32 KiB on the stack: the strips' tables) */
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = sun_disc_job_for(lib, p, &j);
    return st == OCLSHADE_OK ? oclshade_horizon_scratch_size(lib, &j.h, bytes) : st;
}

oclshade_status oclshade_sun_disc(oclshade *lib, cl_command_queue queue, const oclshade_sun_disc_params *p,
                                  float *fraction)
{
    sun_disc_job j;
    oclshade_status st = ocls_enter(lib);
    if (st != OCLSHADE_OK || (st = sun_disc_job_for(lib, p, &j)) != OCLSHADE_OK) return st;
    if (fraction == NULL || p->work == NULL)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "fraction and work must point to rows x cols floats and "
                         "doubles of host memory, got %s", fraction == NULL ? "fraction NULL" : "work NULL");
    const size_t n = (size_t)p->rows * (size_t)p->cols, row = 4 * (size_t)p->cols;
    const size_t origin[3] = {p->angle.offset, 0, 0}, region[3] = {row, (size_t)p->rows, 1};
    const size_t pitch = p->angle.row_pitch ? p->angle.row_pitch : row;
    double whole = 0.0;
    for (int k = 0; k < j.columns; ++k) {
        j.h.azimuth = j.azimuths[k];
        j.h.clamp_bounds[0] = j.bounds[k][0];
        j.h.clamp_bounds[1] = j.bounds[k][1];
        if ((st = oclshade_enqueue_horizon(lib, queue, &j.h, 0, NULL, NULL)) != OCLSHADE_OK) return st;
        const cl_int err = clEnqueueReadBufferRect(queue, p->angle.buffer, CL_TRUE, origin, (const size_t[3]){0, 0, 0},
                                                   region, pitch, 0, row, 0, fraction, 0, NULL, NULL);
        if (err != CL_SUCCESS) return ocls_fail_cl(lib, err, "clEnqueueReadBufferRect (a strip's horizon angles)");
        const double c = j.half_chords[k], top = p->elevation + c;
        for (size_t i = 0; i < n; ++i) {     /* disc.py visible_fraction: clip(e + c - h, 0, 2c), summed */
            double v = top - (double)fraction[i];
            if (!isnan(v)) v = v < 0.0 ? 0.0 : (v > 2.0 * c ? 2.0 * c : v);
            p->work[i] = k == 0 ? v : p->work[i] + v;
        }
        whole += 2.0 * c;
    }
    for (size_t i = 0; i < n; ++i) fraction[i] = (float)(p->work[i] / whole);
    return OCLSHADE_OK;
}
