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
    sincos_degrees(azimuth, &s, &c);   /* cos 2a and sin 2a from them, as stretch_of */
    return sqrt(1.0 + p * (c * c - s * s) + q * (2.0 * s * c));
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
                           int gather, int sun_table, ocls_defines *d)
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
    ocls_def_flag(d, "OCLS_SUN_TABLE", sun_table);
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
    shadow_defines(method, outputs, 0, 1024, 16, 0, 0, 0, &d);
    return ocls_options(&d, buf, size);
}

/* The handle's knobs (lock held). */
static void handle_defines(oclshade *lib, oclshade_method method, unsigned outputs, ocls_defines *d)
{
    shadow_defines(method, outputs, ocls_knob(lib, K_SHADOW_LANES), ocls_knob(lib, K_SHADOW_RUN),
                   ocls_knob(lib, K_SHADOW_CERT_TILE), ocls_knob(lib, K_SHADOW_OWN_BUILTINS),
                   ocls_knob(lib, K_SHADOW_GATHER), 0, d);
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
    /* a sun field (field_row_blocks > 0): kernels/shadow.cl's sun table, malloc'd (shadow_job_free) */
    cl_int *band;              /* rows + cols: a row's band times the column bands, a column's band */
    cl_float4 *table;          /* 2 per block: its ray and sun vector (oclshade_sun_for) */
    cl_int *modes;             /* 1 per block */
    int blocks, column_step;   /* the blocks; the gcd of their first columns (0: all at column 0) */
} shadow_job;

static void shadow_job_free(shadow_job *j)
{
    free(j->band);
    free(j->table);
    free(j->modes);
    j->band = j->modes = NULL;
    j->table = NULL;
}

/* The field's edges checked (increasing from 0 to n), named by `what`. */
static oclshade_status check_edges(oclshade *lib, const char *what, const int *edges, int count, int n)
{
    if (edges == NULL)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s must point to %d + 1 edges, got NULL", what, count);
    if (edges[0] != 0 || edges[count] != n)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s must run from 0 to %d, got %d .. %d", what, n, edges[0],
                         edges[count]);
    for (int k = 0; k < count; ++k)
        if (edges[k + 1] <= edges[k])
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s must increase, got [%d] = %d, [%d] = %d", what, k,
                             edges[k], k + 1, edges[k + 1]);
    return OCLSHADE_OK;
}

/* ShadowCaster._table_buffers (oclshade/shadows.py _sun_table) of the checked field. */
static oclshade_status field_table(oclshade *lib, const oclshade_shadow_params *p, shadow_job *j)
{
    const int nrb = p->field_row_blocks, ncb = p->field_col_blocks;
    oclshade_status st;
    if (p->block_rows != 0)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "a sun field (field_row_blocks %d) is the whole map's: "
                         "block_rows and block_cols must be 0", nrb);
    if ((st = check_edges(lib, "field_row_edges", p->field_row_edges, nrb, p->rows)) != OCLSHADE_OK ||
        (st = check_edges(lib, "field_col_edges", p->field_col_edges, ncb, p->cols)) != OCLSHADE_OK)
        return st;
    if (p->field_suns == NULL)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "field_suns must point to %d x 2 degrees, got NULL",
                         nrb * ncb);
    j->blocks = nrb * ncb;
    j->band = (cl_int *)malloc(sizeof *j->band * ((size_t)p->rows + (size_t)p->cols));
    j->table = (cl_float4 *)malloc(sizeof *j->table * 2 * (size_t)j->blocks);
    j->modes = (cl_int *)malloc(sizeof *j->modes * (size_t)j->blocks);
    if (j->band == NULL || j->table == NULL || j->modes == NULL)
        return ocls_fail(lib, OCLSHADE_OUT_OF_MEMORY, 0, "no host memory for a sun table of %d blocks", j->blocks);
    for (int k = 0; k < j->blocks; ++k) {
        const double az = p->field_suns[2 * k], el = p->field_suns[2 * k + 1];
        oclshade_sun sun;
        if (!isfinite(az) || !(isfinite(el) && el >= -90.0 && el <= 90.0))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "field_suns of block %d must be a finite azimuth and an "
                             "elevation in [-90, 90] degrees, got %g, %g", k, az, el);
        oclshade_sun_for(az, el, p->dx, p->dy, &sun);
        for (int i = 0; i < 4; ++i) {
            j->table[2 * k].s[i] = sun.ray[i];
            j->table[2 * k + 1].s[i] = sun.vector[i];
        }
        j->modes[k] = sun.mode;
    }
    for (int a = 0; a < nrb; ++a)
        for (int r = p->field_row_edges[a]; r < p->field_row_edges[a + 1]; ++r) j->band[r] = a * ncb;
    for (int b = 0; b < ncb; ++b) {
        for (int c = p->field_col_edges[b]; c < p->field_col_edges[b + 1]; ++c) j->band[p->rows + c] = b;
        j->column_step = gcd_int(j->column_step, p->field_col_edges[b]);
    }
    return OCLSHADE_OK;
}

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
    if (p->field_row_blocks < 0 || p->field_col_blocks < 0 || (p->field_row_blocks == 0) != (p->field_col_blocks == 0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "field_row_blocks and field_col_blocks must both be 0 (one "
                         "sun) or both >= 1, got %d, %d", p->field_row_blocks, p->field_col_blocks);
    if (p->field_row_blocks > 0 && (st = field_table(lib, p, j)) != OCLSHADE_OK) return st;
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
    cl_mem band = NULL, table = NULL, modes = NULL;
    const size_t band_bytes = sizeof *j->band * ((size_t)p->rows + n1), table_bytes = sizeof *j->table * 2 * (size_t)j->blocks,
                 modes_bytes = sizeof *j->modes * (size_t)j->blocks;
    if ((st = ocls_bind_in(ps, &p->heights, p->rows, 4 * n1, "heights", &heights)) != OCLSHADE_OK ||
        (st = bind_out(ps, &p->mask, p->rows, n1, "mask", &mask)) != OCLSHADE_OK ||
        (st = bind_out(ps, &p->self_shadow, p->rows, n1, "self_shadow", &self)) != OCLSHADE_OK ||
        (st = bind_out(ps, &p->coefficient, p->rows, 4 * n1, "coefficient", &coef)) != OCLSHADE_OK ||
        (CERTIFIED(p->method) &&
         (st = ocls_scratch(ps, (size_t)tr * (size_t)tc * CERT_K * 4u, "certificates", &cert)) != OCLSHADE_OK) ||
        (j->blocks > 0 &&
         ((st = ocls_scratch(ps, band_bytes, "sun table bands", &band)) != OCLSHADE_OK ||
          (st = ocls_scratch(ps, table_bytes, "sun table", &table)) != OCLSHADE_OK ||
          (st = ocls_scratch(ps, modes_bytes, "sun table modes", &modes)) != OCLSHADE_OK)) ||
        !ps->run)
        return st;
    if (j->blocks > 0 &&
        ((st = ocls_upload(ps, band, 0, j->band, band_bytes, "sun table bands")) != OCLSHADE_OK ||
         (st = ocls_upload(ps, table, 0, j->table, table_bytes, "sun table")) != OCLSHADE_OK ||
         (st = ocls_upload(ps, modes, 0, j->modes, modes_bytes, "sun table modes")) != OCLSHADE_OK))
        return st;
    /* the block (the whole map by default) and, for it, the packet run (ShadowCaster._features) */
    const int whole = p->block_rows == 0;
    const int r0 = whole ? 0 : p->block_row0, c0 = whole ? 0 : p->block_col0;
    const int br = whole ? p->rows : p->block_rows, bc = whole ? p->cols : p->block_cols;
    int lanes = ocls_knob(lib, K_SHADOW_LANES), run = ocls_knob(lib, K_SHADOW_RUN);
    const int step = j->blocks > 0 ? j->column_step : gcd_int(c0, c0 + bc == p->cols ? 0 : bc);
    if (lanes > 0 && CERTIFIED(p->method) && step != 0 && step % run != 0) {
        run = gcd_int(run, step);
        if (run < lanes) lanes = 0;
    }
    ocls_defines d;
    shadow_defines(p->method, j->outputs, lanes, run, tile, ocls_knob(lib, K_SHADOW_OWN_BUILTINS),
                   ocls_knob(lib, K_SHADOW_GATHER), j->blocks > 0, &d);
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
    if (certify != NULL && (mode == 0 || j->blocks > 0)) {   /* ShadowCaster._certifier: grid_2d's (64, 16) */
        const ocls_arg a[] = {OCLS_ARG(H), OCLS_ARG(W), OCLS_ARG(origin), OCLS_ARG(p->pyramid), OCLS_ARG(p->offsets),
                              OCLS_ARG(nlev), OCLS_ARG(ray), OCLS_ARG(cert), OCLS_ARG(band), OCLS_ARG(table),
                              OCLS_ARG(modes)};
        st = ocls_set_args(ps, certify, a, j->blocks > 0 ? 11 : 8);
        if (st == OCLSHADE_OK && whole) st = ocls_launch(ps, certify, tc, tr, 64, 16);
        else if (st == OCLSHADE_OK)   /* the tiles the block touches */
            st = ocls_launch_window(ps, certify, c0 / tile, r0 / tile, (c0 + bc + tile - 1) / tile - c0 / tile,
                                    (r0 + br + tile - 1) / tile - r0 / tile, 64, 16);
    }
    /* an output not compiled in gets a NULL buffer (allowed for __global pointers) */
    ocls_arg a[19] = {OCLS_ARG(heights), OCLS_ARG(H), OCLS_ARG(W), OCLS_ARG(origin), OCLS_ARG(p->pyramid),
                      OCLS_ARG(p->offsets), OCLS_ARG(nlev), OCLS_ARG(ray), OCLS_ARG(vec), OCLS_ARG(cell),
                      OCLS_ARG(kcoef), OCLS_ARG(mode), OCLS_ARG(mask), OCLS_ARG(self), OCLS_ARG(coef)};
    int nargs = 15;
    if (certify != NULL) a[nargs++] = (ocls_arg)OCLS_ARG(cert);
    if (j->blocks > 0) {   /* the sun table after the certificates (kernels/shadow.cl OCLS_SUN_PARAMS) */
        a[nargs++] = (ocls_arg)OCLS_ARG(band);
        a[nargs++] = (ocls_arg)OCLS_ARG(table);
        a[nargs++] = (ocls_arg)OCLS_ARG(modes);
    }
    if (st == OCLSHADE_OK) st = ocls_set_args(ps, k, a, nargs);
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
    if (st == OCLSHADE_OK) st = ocls_plan(lib, shadow_body, &j, bytes);
    shadow_job_free(&j);
    return st;
}

/* An output is also read when a block window stages it (not packed at offset 0): its cells
 * outside the block are copied in and back. */
static int output_access(const oclshade_shadow_params *p, const oclshade_field *f, size_t row_bytes)
{
    const int staged = !(f->offset == 0 && (f->row_pitch == 0 || f->row_pitch == row_bytes));
    return p->block_rows != 0 && staged ? OCLS_INOUT : OCLS_OUT;
}

/* The buffers a pass of these parameters uses, and how (ocls_uses). */
static oclshade_status shadow_uses(oclshade *lib, const oclshade_shadow_params *p, const shadow_job *j, ocls_uses *uses)
{
    const size_t n1 = (size_t)p->cols;
    oclshade_status st;
    if ((st = ocls_use_field(lib, uses, "heights", &p->heights, p->rows, 4 * n1, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, uses, "pyramid", p->pyramid, j->lay.pyramid_bytes, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, uses, "offsets", p->offsets, j->lay.offsets_bytes, OCLS_IN)) != OCLSHADE_OK ||
        (p->mask.buffer &&
         (st = ocls_use_field(lib, uses, "mask", &p->mask, p->rows, n1, output_access(p, &p->mask, n1))) != OCLSHADE_OK) ||
        (p->self_shadow.buffer &&
         (st = ocls_use_field(lib, uses, "self_shadow", &p->self_shadow, p->rows, n1,
                              output_access(p, &p->self_shadow, n1))) != OCLSHADE_OK) ||
        (p->coefficient.buffer &&
         (st = ocls_use_field(lib, uses, "coefficient", &p->coefficient, p->rows, 4 * n1,
                              output_access(p, &p->coefficient, 4 * n1))) != OCLSHADE_OK))
        return st;
    return OCLSHADE_OK;
}

oclshade_status oclshade_enqueue_shadows(oclshade *lib, cl_command_queue queue, const oclshade_shadow_params *p,
                                         cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                         cl_event *event)
{
    shadow_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st != OCLSHADE_OK) return st;
    if ((st = shadow_job_for(lib, p, &j)) == OCLSHADE_OK && (st = shadow_uses(lib, p, &j, &uses)) == OCLSHADE_OK)
        st = ocls_enqueue(lib, queue, p->scratch, &uses, shadow_body, &j, num_events_in_wait_list, event_wait_list,
                          event);
    shadow_job_free(&j);   /* (the tables' uploads copied them at their enqueue) */
    return st;
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
