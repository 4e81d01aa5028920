/* shadows.c — the sun as the kernels read it and heightmap-space shadows (kernels/shadow.cl
 * shadow_cells / shadow_cells_packet / shadow_certify; oclshade/sun.py, oclshade/shadows.py). */
#include "internal.h"

#include <float.h>
#include <math.h>
#include <string.h>

/* far-field tile certificates (kernels/shadow.cl -D OCLS_CERT): oclshade/shadows.py CERT_K */
#define CERT_K 6
#define CERTIFIED(method) ((method) == OCLSHADE_EXACT || (method) == OCLSHADE_MAXMIP)
/* the largest window origin plus extent (oclshade/shadows.py MAX_COORDINATE) */
#define OCLS_MAX_COORDINATE (1 << 30)

/* ------------------------------------------------------------------ sun */

/* oclshade/sun.py sincos_degrees: exact at multiples of 90 degrees, |sin| ==
 * |cos| at odd multiples of 45; libm sin/cos of a * (pi / 180) (CPython's
 * math.radians) elsewhere. */
static void sincos_degrees(double angle, double *s, double *c)
{
    double a = fmod(angle, 360.0);
    if (a < 0.0) {
        a += 360.0;
        if (a == 360.0) a = 0.0;   /* a tiny negative angle rounds up to 360: it is 0 */
    }
    if (a == 0.0) { *s = 0.0; *c = 1.0; return; }
    if (a == 90.0) { *s = 1.0; *c = 0.0; return; }
    if (a == 180.0) { *s = 0.0; *c = -1.0; return; }
    if (a == 270.0) { *s = -1.0; *c = 0.0; return; }
    if (fmod(a, 45.0) == 0.0) {
        const double r = sqrt(0.5);
        *s = a < 180.0 ? r : -r;
        *c = (a == 45.0 || a == 315.0) ? r : -r;
        return;
    }
    const double rad = a * (3.14159265358979323846 / 180.0);
    *s = sin(rad);
    *c = cos(rad);
}

/* oclshade/sun.py _float32: nearest float32, subnormals flushed to 0. */
static float float32_flushed(double v)
{
    const float f = (float)v;
    return fabsf(f) < FLT_MIN ? 0.0f : f;
}

static int sun_ok(double azimuth, double elevation)
{
    return isfinite(azimuth) && isfinite(elevation) && elevation >= -90.0 && elevation <= 90.0;
}

oclshade_status oclshade_sun_vector(double azimuth, double elevation, double out[3])
{
    if (out == NULL || !sun_ok(azimuth, elevation)) return OCLSHADE_INVALID_ARGUMENT;
    double sa, ca, se, ce;
    sincos_degrees(azimuth, &sa, &ca);
    sincos_degrees(elevation, &se, &ce);
    out[0] = sa * ce;
    out[1] = ca * ce;
    out[2] = se;
    return OCLSHADE_OK;
}

double ocls_direction_factor(double p, double q, double azimuth)
{
    double s, c;
    if (p == 0.0 && q == 0.0) return 1.0;
    sincos_degrees(2.0 * azimuth, &s, &c);
    return sqrt(1.0 + p * c + q * s);
}

void ocls_horizontal_ray(double azimuth, double dx, double dy, cl_float out[2])
{
    double sa, ca;
    sincos_degrees(azimuth, &sa, &ca);
    out[0] = float32_flushed(sa / dx);
    out[1] = float32_flushed(-ca / dy);
}

oclshade_status oclshade_sun_for(double azimuth, double elevation, double dx, double dy, oclshade_sun *out)
{
    if (out == NULL || !sun_ok(azimuth, elevation) || !isfinite(dx) || dx <= 0.0 || !isfinite(dy) || dy <= 0.0)
        return OCLSHADE_INVALID_ARGUMENT;
    double sa, ca, se, ce, v[3];
    sincos_degrees(azimuth, &sa, &ca);
    sincos_degrees(elevation, &se, &ce);
    oclshade_sun_vector(azimuth, elevation, v);
    const double w = elevation == 45.0 ? 1.0 : (ce > 0.0 ? se / ce : INFINITY);
    out->mode = elevation <= 0.0 ? 2 : (elevation >= 90.0 ? 1 : 0);
    out->ray[0] = out->mode ? 0.0f : float32_flushed(sa / dx);
    out->ray[1] = out->mode ? 0.0f : float32_flushed(-ca / dy);
    out->ray[2] = out->mode ? 0.0f : float32_flushed(w);
    out->ray[3] = 0.0f;
    for (int i = 0; i < 3; ++i) out->vector[i] = (float)v[i];   /* Sun.vector, rounded by numpy (no flush) */
    out->vector[3] = 0.0f;
    return OCLSHADE_OK;
}

/* ------------------------------------------------------------------ build options */

/* oclshade/shadows.py ShadowFeatures.defines for (method, outputs) with these knobs
 * (lanes 0: shadow_cells; packets only for EXACT and MAXMIP). */
static void shadow_defines(oclshade_method method, unsigned outputs, int lanes, int run, int cert_tile, int own,
                           int gather, ocls_defines *d)
{
    const int packets = lanes > 0 && CERTIFIED(method);
    memset(d, 0, sizeof *d);
    if (packets) {
        ocls_def_int(d, "OCLS_PACKET", run);
        ocls_def_int(d, "OCLS_LANES", lanes);
    }
    if (CERTIFIED(method)) {
        ocls_def_int(d, "OCLS_CERT", cert_tile);
        ocls_def_int(d, "OCLS_CERT_K", CERT_K);
    }
    ocls_def_int(d, "OCLS_METHOD", (int)method);
    ocls_def_flag(d, "OCLS_OUT_MASK", (outputs & OCLSHADE_OUT_MASK) != 0);
    ocls_def_flag(d, "OCLS_OUT_SELF", (outputs & OCLSHADE_OUT_SELF) != 0);
    ocls_def_flag(d, "OCLS_OUT_COEF", (outputs & OCLSHADE_OUT_COEFFICIENT) != 0);
    ocls_def_flag(d, "OCLS_OWN_BUILTINS", own);
    ocls_def_flag(d, "OCLS_HW_GATHER", gather && packets);
}

static int gcd_int(int a, int b)
{
    while (b != 0) {
        const int t = a % b;
        a = b;
        b = t;
    }
    return a;
}

static int method_ok(oclshade_method method) { return method >= OCLSHADE_EXACT && method <= OCLSHADE_DDA; }

size_t oclshade_shadow_build_options(oclshade_method method, unsigned outputs, char *buf, size_t size)
{
    if (!method_ok(method) || outputs == 0 || outputs > 7u) return 0;
    ocls_defines d;
    shadow_defines(method, outputs, 0, 1024, 16, 0, 0, &d);
    return ocls_options(&d, buf, size);
}

/* The handle's knobs (lock held). */
static void handle_defines(oclshade *lib, oclshade_method method, unsigned outputs, ocls_defines *d)
{
    shadow_defines(method, outputs, ocls_knob(lib, K_SHADOW_LANES), ocls_knob(lib, K_SHADOW_RUN),
                   ocls_knob(lib, K_SHADOW_CERT_TILE), ocls_knob(lib, K_SHADOW_OWN_BUILTINS),
                   ocls_knob(lib, K_SHADOW_GATHER), d);
}

size_t oclshade_shadow_build_options_for(const oclshade *clib, oclshade_method method, unsigned outputs, char *buf,
                                         size_t size)
{
    oclshade *lib = (oclshade *)clib;   /* the lock guards the knobs */
    if (lib == NULL || lib->failed != OCLSHADE_OK || !method_ok(method) || outputs == 0 || outputs > 7u) return 0;
    ocls_defines d;
    ocls_mutex_lock(&lib->lock);
    handle_defines(lib, method, outputs, &d);
    ocls_mutex_unlock(&lib->lock);
    return ocls_options(&d, buf, size);
}

/* ------------------------------------------------------------------ shadows */

void oclshade_shadow_params_init(oclshade_shadow_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
    p->dx = p->dy = 1.0;
    p->azimuth = 315.0;
    p->elevation = 45.0;
    p->method = OCLSHADE_EXACT;
    p->k_dark = OCLSHADE_DEFAULT_K_DARK;
    p->k_bright = OCLSHADE_DEFAULT_K_BRIGHT;
}

typedef struct shadow_job {
    const oclshade_shadow_params *p;
    unsigned outputs;
    oclshade_pyramid_layout lay;
    oclshade_sun sun;
} shadow_job;

static oclshade_status check_method_outputs(oclshade *lib, oclshade_method method, unsigned outputs)
{
    if (!method_ok(method))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "method must be OCLSHADE_EXACT, OCLSHADE_PAPER, "
                         "OCLSHADE_MAXMIP or OCLSHADE_DDA (1..4), got %d", (int)method);
    if (outputs == 0 || outputs > 7u)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "outputs must be a non-empty set of OCLSHADE_OUT_MASK, "
                         "OCLSHADE_OUT_SELF and OCLSHADE_OUT_COEFFICIENT bits (1..7), got %u", outputs);
    return OCLSHADE_OK;
}

static oclshade_status shadow_job_for(oclshade *lib, const oclshade_shadow_params *p, shadow_job *j)
{
    oclshade_status st;
    memset(j, 0, sizeof *j);
    if (p == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params must point to oclshade_shadow_params, got NULL");
    if ((st = ocls_check_size(lib, "rows", p->rows, "cols", p->cols)) != OCLSHADE_OK) return st;
    if (!(isfinite(p->dx) && p->dx > 0.0 && isfinite(p->dy) && p->dy > 0.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "dx and dy must be positive finite cell sizes, got dx %g, dy %g",
                         p->dx, p->dy);
    if (p->origin_row < 0 || p->origin_col < 0 || p->origin_row > OCLS_MAX_COORDINATE - p->rows ||
        p->origin_col > OCLS_MAX_COORDINATE - p->cols)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "origin_row and origin_col must be >= 0 with origin + size "
                         "<= 2^30, got origin (%d, %d) for %d x %d", p->origin_row, p->origin_col, p->rows, p->cols);
    if ((p->block_rows != 0 || p->block_cols != 0) &&
        (p->block_rows < 1 || p->block_cols < 1 || p->block_row0 < 0 || p->block_col0 < 0 ||
         p->block_row0 > p->rows - p->block_rows || p->block_col0 > p->cols - p->block_cols))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "block_row0 / block_rows and block_col0 / block_cols must "
                         "give a block inside the %d x %d map (0 x 0: all of it), got rows %d + %d, cols %d + %d",
                         p->rows, p->cols, p->block_row0, p->block_rows, p->block_col0, p->block_cols);
    if (!isfinite(p->azimuth))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "azimuth must be a finite number of degrees, got %g", p->azimuth);
    if (!(isfinite(p->elevation) && p->elevation >= -90.0 && p->elevation <= 90.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "elevation must be in [-90, 90] degrees, got %g", p->elevation);
    if (!(p->k_dark >= 0.0 && p->k_dark <= 1.0 && p->k_bright >= 0.0 && p->k_bright <= 1.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "k_dark and k_bright must be in [0, 1] (paper 000 eq. 1), "
                         "got k_dark %g, k_bright %g", p->k_dark, p->k_bright);
    j->outputs = (p->mask.buffer ? OCLSHADE_OUT_MASK : 0u) | (p->self_shadow.buffer ? OCLSHADE_OUT_SELF : 0u) |
                 (p->coefficient.buffer ? OCLSHADE_OUT_COEFFICIENT : 0u);
    if (j->outputs == 0)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "at least one of mask, self_shadow, coefficient must have a buffer");
    if ((st = check_method_outputs(lib, p->method, j->outputs)) != OCLSHADE_OK) return st;
    j->p = p;
    oclshade_pyramid_layout_for(p->rows, p->cols, &j->lay);
    oclshade_sun_for(p->azimuth, p->elevation, p->dx, p->dy, &j->sun);
    return OCLSHADE_OK;
}

/* oclshade/shadows.py ShadowCaster.cast: the certificates, then the cells (ShadowCaster._args). */
static oclshade_status shadow_body(ocls_pass *ps, const void *params)
{
    const shadow_job *j = (const shadow_job *)params;
    const oclshade_shadow_params *p = j->p;
    oclshade *lib = ps->lib;
    const size_t n1 = (size_t)p->cols;
    cl_mem heights, mask, self, coef, cert = NULL;
    const int tile = ocls_knob(lib, K_SHADOW_CERT_TILE);
    const int tr = (p->rows + tile - 1) / tile, tc = (p->cols + tile - 1) / tile;
    oclshade_status st;
    /* with a block window a staged output is copied in first, so that the cells outside the block
       come back as they were */
    oclshade_status (*bind_out)(ocls_pass *, const oclshade_field *, int, size_t, const char *, cl_mem *) =
        p->block_rows == 0 ? ocls_bind_out : ocls_bind_inout;
    if ((st = ocls_bind_in(ps, &p->heights, p->rows, 4 * n1, "heights", &heights)) != OCLSHADE_OK ||
        (st = bind_out(ps, &p->mask, p->rows, n1, "mask", &mask)) != OCLSHADE_OK ||
        (st = bind_out(ps, &p->self_shadow, p->rows, n1, "self_shadow", &self)) != OCLSHADE_OK ||
        (st = bind_out(ps, &p->coefficient, p->rows, 4 * n1, "coefficient", &coef)) != OCLSHADE_OK ||
        (CERTIFIED(p->method) &&
         (st = ocls_scratch(ps, (size_t)tr * (size_t)tc * CERT_K * 4u, "certificates", &cert)) != OCLSHADE_OK) ||
        !ps->run)
        return st;
    /* the block (the whole map by default) and, for it, the packet run (ShadowCaster._features) */
    const int whole = p->block_rows == 0;
    const int r0 = whole ? 0 : p->block_row0, c0 = whole ? 0 : p->block_col0;
    const int br = whole ? p->rows : p->block_rows, bc = whole ? p->cols : p->block_cols;
    int lanes = ocls_knob(lib, K_SHADOW_LANES), run = ocls_knob(lib, K_SHADOW_RUN);
    const int step = gcd_int(c0, c0 + bc == p->cols ? 0 : bc);
    if (lanes > 0 && CERTIFIED(p->method) && step != 0 && step % run != 0) {
        run = gcd_int(run, step);
        if (run < lanes) lanes = 0;
    }
    ocls_defines d;
    shadow_defines(p->method, j->outputs, lanes, run, tile, ocls_knob(lib, K_SHADOW_OWN_BUILTINS),
                   ocls_knob(lib, K_SHADOW_GATHER), &d);
    const int packets = lanes > 0 && CERTIFIED(p->method);
    kernel_entry *k, *certify = NULL;
    st = ocls_kernel(ps, "shadow.cl", &d, packets ? "shadow_cells_packet" : "shadow_cells", &k);
    if (st == OCLSHADE_OK && CERTIFIED(p->method)) st = ocls_kernel(ps, "shadow.cl", &d, "shadow_certify", &certify);
    if (st != OCLSHADE_OK) return st;
    const cl_int H = p->rows, W = p->cols, nlev = j->lay.levels, mode = j->sun.mode;
    cl_int2 origin;   /* (column, row) of the window's first cell in the whole map */
    origin.s[0] = p->origin_col;
    origin.s[1] = p->origin_row;
    cl_float4 ray, vec;
    cl_float2 cell, kcoef;
    for (int i = 0; i < 4; ++i) { ray.s[i] = j->sun.ray[i]; vec.s[i] = j->sun.vector[i]; }
    cell.s[0] = (cl_float)p->dx;
    cell.s[1] = (cl_float)p->dy;
    kcoef.s[0] = (cl_float)p->k_dark;
    kcoef.s[1] = (cl_float)p->k_bright;
    if (certify != NULL && mode == 0) {   /* ShadowCaster._certifier: grid_2d's defaults (64, 16) */
        const ocls_arg a[] = {OCLS_ARG(H), OCLS_ARG(W), OCLS_ARG(origin), OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets),
                              OCLS_ARG(nlev), OCLS_ARG(ray), OCLS_ARG(cert)};
        st = ocls_set_args(ps, certify, a, 8);
        if (st == OCLSHADE_OK && whole) st = ocls_launch(ps, certify, tc, tr, 64, 16);
        else if (st == OCLSHADE_OK)   /* the tiles the block touches */
            st = ocls_launch_window(ps, certify, c0 / tile, r0 / tile, (c0 + bc + tile - 1) / tile - c0 / tile,
                                    (r0 + br + tile - 1) / tile - r0 / tile, 64, 16);
    }
    /* an output not compiled in gets a NULL buffer (allowed for __global pointers) */
    const ocls_arg a[] = {OCLS_ARG(heights), OCLS_ARG(H), OCLS_ARG(W), OCLS_ARG(origin), OCLS_ARG(p->pyramid),
                          OCLS_ARG(p->offsets), OCLS_ARG(nlev), OCLS_ARG(ray), OCLS_ARG(vec), OCLS_ARG(cell),
                          OCLS_ARG(kcoef), OCLS_ARG(mode), OCLS_ARG(mask), OCLS_ARG(self), OCLS_ARG(coef),
                          OCLS_ARG(cert)};
    if (st == OCLSHADE_OK) st = ocls_set_args(ps, k, a, certify != NULL ? 16 : 15);
    const size_t group = (size_t)ocls_knob(lib, K_SHADOW_GROUP);
    if (st == OCLSHADE_OK && whole)
        st = ocls_launch(ps, k, packets ? (W + run - 1) / run : W, H, group, 16);
    else if (st == OCLSHADE_OK)   /* exactly the block's work-items */
        st = ocls_launch_window(ps, k, packets ? c0 / run : c0, r0, packets ? (bc + run - 1) / run : bc, br, group, 16);
    return st;
}

oclshade_status oclshade_shadows_scratch_size(oclshade *lib, const oclshade_shadow_params *params, size_t *bytes)
{
    shadow_job j;
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st == OCLSHADE_OK) st = shadow_job_for(lib, params, &j);
    return st != OCLSHADE_OK ? st : ocls_plan(lib, shadow_body, &j, bytes);
}

/* An output is also read when a block window stages it (not packed at offset 0): its cells
 * outside the block are copied in and back. */
static int output_access(const oclshade_shadow_params *p, const oclshade_field *f, size_t row_bytes)
{
    const int staged = !(f->offset == 0 && (f->row_pitch == 0 || f->row_pitch == row_bytes));
    return p->block_rows != 0 && staged ? OCLS_INOUT : OCLS_OUT;
}

oclshade_status oclshade_enqueue_shadows(oclshade *lib, cl_command_queue queue, const oclshade_shadow_params *p,
                                         cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                         cl_event *event)
{
    shadow_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = shadow_job_for(lib, p, &j);
    if (st != OCLSHADE_OK) return st;
    const size_t n1 = (size_t)p->cols;
    if ((st = ocls_use_field(lib, &uses, "heights", &p->heights, p->rows, 4 * n1, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "pyramid", p->pyramid, j.lay.pyramid_bytes, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "offsets", p->offsets, j.lay.offsets_bytes, OCLS_IN)) != OCLSHADE_OK ||
        (p->mask.buffer &&
         (st = ocls_use_field(lib, &uses, "mask", &p->mask, p->rows, n1, output_access(p, &p->mask, n1))) != OCLSHADE_OK) ||
        (p->self_shadow.buffer &&
         (st = ocls_use_field(lib, &uses, "self_shadow", &p->self_shadow, p->rows, n1,
                              output_access(p, &p->self_shadow, n1))) != OCLSHADE_OK) ||
        (p->coefficient.buffer &&
         (st = ocls_use_field(lib, &uses, "coefficient", &p->coefficient, p->rows, 4 * n1,
                              output_access(p, &p->coefficient, 4 * n1))) != OCLSHADE_OK))
        return st;
    return ocls_enqueue(lib, queue, p->scratch, &uses, shadow_body, &j, num_events_in_wait_list, event_wait_list, event);
}

oclshade_status oclshade_prepare(oclshade *lib, oclshade_method method, unsigned outputs)
{
    oclshade_status st = ocls_enter(lib);
    if (st != OCLSHADE_OK) return st;
    if ((st = check_method_outputs(lib, method, outputs)) != OCLSHADE_OK) return st;
    ocls_pass ps;
    ocls_pass_init(&ps, lib, 1, NULL, 0, NULL, NULL);
    ocls_defines d, base = {0};
    kernel_entry *k;
    ocls_mutex_lock(&lib->lock);
    handle_defines(lib, method, outputs, &d);
    const int lanes = ocls_knob(lib, K_PYRAMID_BASE_LANES);
    if (lanes > 1) ocls_def_int(&base, "OCLS_BASE_LANES", lanes);
    ocls_def_flag(&base, "OCLS_OWN_BUILTINS", ocls_knob(lib, K_PYRAMID_OWN_BUILTINS));
    st = ocls_kernel(&ps, "pyramid.cl", &base, "extrema_base", &k);
    const int packets = ocls_knob(lib, K_SHADOW_LANES) > 0 && CERTIFIED(method);
    if (st == OCLSHADE_OK) st = ocls_kernel(&ps, "shadow.cl", &d, packets ? "shadow_cells_packet" : "shadow_cells", &k);
    if (st == OCLSHADE_OK && CERTIFIED(method)) st = ocls_kernel(&ps, "shadow.cl", &d, "shadow_certify", &k);
    ocls_mutex_unlock(&lib->lock);
    return st;
}
