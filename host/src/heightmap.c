/* heightmap.c — relative heights, the extrema pyramid, the mean mip pyramid and the
 * level-q grids of per-pixel shadows (kernels/pyramid.cl; oclshade/heightmap.py,
 * oclshade/pyramid.py, oclshade/screen_shadows.py coarse_grid). */
#include "internal.h"

#include <float.h>
#include <limits.h>
#include <math.h>
#include <string.h>

int ocls_extent(int n0, int level) { return ((n0 - 1) >> level) + 1; }

/* ------------------------------------------------------------------ heights */

oclshade_status oclshade_relative_heights(const double *heights, size_t count, float *out, double *offset_out)
{
    if (heights == NULL || out == NULL || count == 0) return OCLSHADE_INVALID_ARGUMENT;
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < count; ++i) {
        const double v = heights[i];
        if (isinf(v)) return OCLSHADE_INVALID_ARGUMENT;
        if (v < lo) lo = v;        /* NaN compares false */
        if (v > hi) hi = v;
    }
    /* Heightmap.__post_init__: 0.5 * nanmin + 0.5 * nanmax (no overflow), 0 for an all-NaN map */
    const double offset = lo <= hi ? 0.5 * lo + 0.5 * hi : 0.0;
    if (lo <= hi && 0.5 * hi - 0.5 * lo > FLT_MAX) return OCLSHADE_INVALID_ARGUMENT;   /* check_float32 */
    for (size_t i = 0; i < count; ++i) out[i] = (float)(heights[i] - offset);
    if (offset_out != NULL) *offset_out = offset;
    return OCLSHADE_OK;
}

oclshade_status oclshade_height_range(const float *rel, size_t count, float *lo_out, float *hi_out)
{
    if (rel == NULL || lo_out == NULL || hi_out == NULL) return OCLSHADE_INVALID_ARGUMENT;
    float lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < count; ++i) {
        const float v = rel[i];
        if (!isfinite(v)) continue;
        if (v < lo) lo = v;
        if (v > hi) hi = v;
    }
    *lo_out = lo <= hi ? lo : 0.0f;
    *hi_out = lo <= hi ? hi : 0.0f;
    return OCLSHADE_OK;
}

/* ------------------------------------------------------------------ extrema pyramid */

oclshade_status oclshade_pyramid_layout_for(int rows, int cols, oclshade_pyramid_layout *out)
{
    if (out == NULL || rows < 1 || cols < 1 || (long long)rows * cols > INT_MAX) return OCLSHADE_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    /* oclshade/pyramid.py extrema_shapes: levels 1.. of the patch grid
     * max(rows-1,1) x max(cols-1,1), halving (ceil) down to 1 x 1; at least one */
    int r = rows > 1 ? rows - 1 : 1, c = cols > 1 ? cols - 1 : 1;
    int l = 0, total = 0;
    out->level_rows[0] = rows;
    out->level_cols[0] = cols;
    out->offsets[0] = -1;
    do {
        r = r / 2 + r % 2;
        c = c / 2 + c % 2;
        ++l;
        out->level_rows[l] = r;
        out->level_cols[l] = c;
        out->offsets[l] = total;
        total += r * c;   /* < rows * cols: no overflow */
    } while (r != 1 || c != 1);
    out->levels = l + 1;
    out->texels = total;
    out->pyramid_bytes = (size_t)total * 8u;
    out->offsets_bytes = (size_t)out->levels * 4u;
    return OCLSHADE_OK;
}

typedef struct extrema_job {
    const oclshade_field *heights;
    int rows, cols;
    cl_mem pyramid, offsets;
    oclshade_pyramid_layout lay;
} extrema_job;

/* oclshade/pyramid.py build_extrema_pyramid */
static oclshade_status extrema_body(ocls_pass *ps, const void *params)
{
    const extrema_job *j = (const extrema_job *)params;
    const oclshade_pyramid_layout *lay = &j->lay;
    cl_mem heights;
    oclshade_status st = ocls_bind_in(ps, j->heights, j->rows, 4u * (size_t)j->cols, "heights", &heights);
    if (st != OCLSHADE_OK || !ps->run) return st;
    st = ocls_upload(ps, j->offsets, 0, lay->offsets, lay->offsets_bytes, "offsets");   /* [0] = -1 as Python */
    const int lanes = ocls_knob(ps->lib, K_PYRAMID_BASE_LANES), own = ocls_knob(ps->lib, K_PYRAMID_OWN_BUILTINS);
    ocls_defines base_d = {0}, reduce_d = {0};
    if (lanes > 1) ocls_def_int(&base_d, "OCLS_BASE_LANES", lanes);
    ocls_def_flag(&base_d, "OCLS_OWN_BUILTINS", own);
    ocls_def_flag(&reduce_d, "OCLS_OWN_BUILTINS", own);
    kernel_entry *base = NULL, *reduce = NULL;
    if (st == OCLSHADE_OK) st = ocls_kernel(ps, "pyramid.cl", &base_d, "extrema_base", &base);
    if (st == OCLSHADE_OK && lay->levels > 2) st = ocls_kernel(ps, "pyramid.cl", &reduce_d, "extrema_reduce", &reduce);
    const cl_int H = j->rows, W = j->cols, Hp = H > 1 ? H - 1 : 1, Wp = W > 1 ? W - 1 : 1;
    const cl_int R1 = lay->level_rows[1], C1 = lay->level_cols[1];
    if (st == OCLSHADE_OK) {
        const ocls_arg a[] = {OCLS_ARG(heights), OCLS_ARG(H), OCLS_ARG(W), OCLS_ARG(j->pyramid), OCLS_ARG(Hp),
                              OCLS_ARG(Wp), OCLS_ARG(R1), OCLS_ARG(C1)};
        st = ocls_set_args(ps, base, a, 8);
    }
    /* _run_2d: grid_2d(wanted=256, max_x=64) */
    if (st == OCLSHADE_OK) st = ocls_launch(ps, base, (C1 + lanes - 1) / lanes, R1, 256, 64);
    for (int l = 2; st == OCLSHADE_OK && l < lay->levels; ++l) {
        const cl_int in_off = lay->offsets[l - 1], rin = lay->level_rows[l - 1], cin = lay->level_cols[l - 1];
        const cl_int out_off = lay->offsets[l], r = lay->level_rows[l], c = lay->level_cols[l];
        const ocls_arg a[] = {OCLS_ARG(j->pyramid), OCLS_ARG(in_off), OCLS_ARG(rin), OCLS_ARG(cin),
                              OCLS_ARG(out_off), OCLS_ARG(r), OCLS_ARG(c)};
        st = ocls_set_args(ps, reduce, a, 7);
        if (st == OCLSHADE_OK) st = ocls_launch(ps, reduce, c, r, 256, 64);
    }
    return st;
}

static oclshade_status extrema_job_for(oclshade *lib, const oclshade_field *heights, int rows, int cols, extrema_job *j)
{
    oclshade_status st = ocls_check_size(lib, "rows", rows, "cols", cols);
    if (st != OCLSHADE_OK) return st;
    if (heights == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "heights must point to an oclshade_field, got NULL");
    memset(j, 0, sizeof *j);
    j->heights = heights;
    j->rows = rows;
    j->cols = cols;
    oclshade_pyramid_layout_for(rows, cols, &j->lay);
    return OCLSHADE_OK;
}

oclshade_status oclshade_extrema_pyramid_scratch_size(oclshade *lib, const oclshade_field *heights, int rows, int cols,
                                                      size_t *bytes)
{
    extrema_job j;
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st == OCLSHADE_OK) st = extrema_job_for(lib, heights, rows, cols, &j);
    return st != OCLSHADE_OK ? st : ocls_plan(lib, extrema_body, &j, bytes);
}

oclshade_status oclshade_enqueue_extrema_pyramid(oclshade *lib, cl_command_queue queue, const oclshade_field *heights,
                                                 int rows, int cols, cl_mem pyramid, cl_mem offsets, cl_mem scratch,
                                                 cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                 cl_event *event)
{
    extrema_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = extrema_job_for(lib, heights, rows, cols, &j);
    if (st != OCLSHADE_OK) return st;
    j.pyramid = pyramid;
    j.offsets = offsets;
    if ((st = ocls_use_field(lib, &uses, "heights", heights, rows, 4u * (size_t)cols, OCLS_IN)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "pyramid", pyramid, j.lay.pyramid_bytes, OCLS_OUT)) != OCLSHADE_OK ||
        (st = ocls_use_buffer(lib, &uses, "offsets", offsets, j.lay.offsets_bytes, OCLS_OUT)) != OCLSHADE_OK)
        return st;
    return ocls_enqueue(lib, queue, scratch, &uses, extrema_body, &j, num_events_in_wait_list, event_wait_list, event);
}

/* ------------------------------------------------------------------ mean mip pyramid */

oclshade_status oclshade_mip_layout_for(oclshade *lib, int rows, int cols, oclshade_mip_layout *out)
{
    oclshade_status st = ocls_enter(lib);
    if (st != OCLSHADE_OK) return st;
    if (out == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "out must not be NULL");
    if ((st = ocls_check_size(lib, "rows", rows, "cols", cols)) != OCLSHADE_OK) return st;
    memset(out, 0, sizeof *out);
    /* oclshade/pyramid.py level_shapes: each ceil(half) of the one below, down to 1 x 1 */
    int l = 0, r = rows, c = cols;
    size_t total = 0;
    out->level_rows[0] = rows;
    out->level_cols[0] = cols;
    while (r != 1 || c != 1) {
        r = (r + 1) / 2;
        c = (c + 1) / 2;
        ++l;
        out->level_rows[l] = r;
        out->level_cols[l] = c;
        out->offsets[l] = (total + lib->align - 1) / lib->align * lib->align;   /* sub-buffer views start aligned */
        total = out->offsets[l] + 4u * (size_t)r * (size_t)c;
    }
    out->levels = l + 1;
    out->bytes = total;
    return OCLSHADE_OK;
}

typedef struct mip_job {
    const oclshade_field *values;
    cl_mem mip;
    oclshade_mip_layout lay;
} mip_job;

/* oclshade/pyramid.py build_mip_levels: mip_reduce level by level, grid_2d(256, 64) */
static oclshade_status mip_body(ocls_pass *ps, const void *params)
{
    const mip_job *j = (const mip_job *)params;
    const oclshade_mip_layout *lay = &j->lay;
    cl_mem in;
    oclshade_status st = ocls_bind_in(ps, j->values, lay->level_rows[0], 4u * (size_t)lay->level_cols[0], "values", &in);
    if (st != OCLSHADE_OK || !ps->run || lay->levels == 1) return st;
    ocls_defines d = {0};
    kernel_entry *k;
    st = ocls_kernel(ps, "pyramid.cl", &d, "mip_reduce", &k);
    cl_mem views[OCLSHADE_MAX_LEVELS] = {NULL};
    for (int l = 1; st == OCLSHADE_OK && l < lay->levels; ++l) {
        st = ocls_view(ps->lib, j->mip, lay->offsets[l], 4u * (size_t)lay->level_rows[l] * (size_t)lay->level_cols[l],
                       "mip level", &views[l]);
        if (st != OCLSHADE_OK) break;
        const cl_mem src = l == 1 ? in : views[l - 1];
        const cl_int rin = lay->level_rows[l - 1], cin = lay->level_cols[l - 1], r = lay->level_rows[l],
                     c = lay->level_cols[l];
        const ocls_arg a[] = {OCLS_ARG(src), OCLS_ARG(rin), OCLS_ARG(cin), OCLS_ARG(views[l]), OCLS_ARG(r), OCLS_ARG(c)};
        st = ocls_set_args(ps, k, a, 6);
        if (st == OCLSHADE_OK) st = ocls_launch(ps, k, c, r, 256, 64);
    }
    for (int l = 1; l < lay->levels; ++l)
        if (views[l]) clReleaseMemObject(views[l]);   /* kept by OpenCL for the launches */
    return st;
}

static oclshade_status mip_job_for(oclshade *lib, const oclshade_field *values, int rows, int cols, mip_job *j)
{
    memset(j, 0, sizeof *j);
    if (values == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "values must point to an oclshade_field, got NULL");
    j->values = values;
    return oclshade_mip_layout_for(lib, rows, cols, &j->lay);
}

oclshade_status oclshade_mip_pyramid_scratch_size(oclshade *lib, const oclshade_field *values, int rows, int cols,
                                                  size_t *bytes)
{
    mip_job j;
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st == OCLSHADE_OK) st = mip_job_for(lib, values, rows, cols, &j);
    return st != OCLSHADE_OK ? st : ocls_plan(lib, mip_body, &j, bytes);
}

oclshade_status oclshade_enqueue_mip_pyramid(oclshade *lib, cl_command_queue queue, const oclshade_field *values,
                                             int rows, int cols, cl_mem mip, cl_mem scratch,
                                             cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                             cl_event *event)
{
    mip_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = mip_job_for(lib, values, rows, cols, &j);
    if (st != OCLSHADE_OK) return st;
    j.mip = mip;
    if ((st = ocls_use_field(lib, &uses, "values", values, rows, 4u * (size_t)cols, OCLS_IN)) != OCLSHADE_OK ||
        (j.lay.levels > 1 && (st = ocls_use_buffer(lib, &uses, "mip", mip, j.lay.bytes, OCLS_OUT)) != OCLSHADE_OK))
        return st;
    return ocls_enqueue(lib, queue, scratch, &uses, mip_body, &j, num_events_in_wait_list, event_wait_list, event);
}

/* ------------------------------------------------------------------ coarse grids */

oclshade_status oclshade_coarse_layout_for(int rows, int cols, oclshade_coarse_layout *out)
{
    oclshade_pyramid_layout pyr;
    if (out == NULL || oclshade_pyramid_layout_for(rows, cols, &pyr) != OCLSHADE_OK) return OCLSHADE_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    const int hp = rows > 1 ? rows - 1 : 1, wp = cols > 1 ? cols - 1 : 1;
    size_t total = 0;
    out->levels = pyr.levels;
    out->offsets[0] = -1;
    for (int q = 1; q < pyr.levels; ++q) {
        out->grid_rows[q] = ocls_extent(hp, q) + 1;
        out->grid_cols[q] = ocls_extent(wp, q) + 1;
        out->offsets[q] = (int)total;
        total += (size_t)out->grid_rows[q] * (size_t)out->grid_cols[q];
    }
    out->grids_bytes = 4u * total;
    out->offsets_bytes = 4u * (size_t)pyr.levels;
    return OCLSHADE_OK;
}

/* screen_shadows.py coarse_grid's axis(): the mip samples (i0, i1) and weight f of corner k. */
static void coarse_axis(int k, int s, int n_samples, int n_mip, int *i0, int *i1, double *f)
{
    double pos = (double)k * (double)s;
    if (pos > (double)(n_samples - 1)) pos = (double)(n_samples - 1);
    double m = (pos - (double)(s - 1) / 2.0) / (double)s;
    if (m < 0.0) m = 0.0;                                   /* np.clip */
    if (m > (double)(n_mip - 1)) m = (double)(n_mip - 1);
    int lo = (int)floor(m);
    const int cap = n_mip - 2 > 0 ? n_mip - 2 : 0;
    if (lo > cap) lo = cap;
    *i0 = lo;
    *i1 = lo + 1 < n_mip - 1 ? lo + 1 : n_mip - 1;
    *f = m - (double)lo;
}

/* screen_shadows.py _lerp: a at f == 0, b at f == 1 (NaN on the other side does not leak). */
static double lerp(double a, double b, double f)
{
    if (f == 0.0) return a;
    if (f == 1.0) return b;
    return a + (b - a) * f;
}

oclshade_status oclshade_coarse_grids(const float *heights, const void *mip, const oclshade_mip_layout *ml, int rows,
                                      int cols, float *grids, int *offsets)
{
    oclshade_coarse_layout cl;
    if (heights == NULL || ml == NULL || grids == NULL || offsets == NULL ||
        oclshade_coarse_layout_for(rows, cols, &cl) != OCLSHADE_OK || ml->level_rows[0] != rows ||
        ml->level_cols[0] != cols || (ml->levels > 1 && mip == NULL))
        return OCLSHADE_INVALID_ARGUMENT;
    for (int q = 0; q < cl.levels; ++q) offsets[q] = cl.offsets[q];
    for (int q = 1; q < cl.levels; ++q) {
        const int level = q < ml->levels - 1 ? q : ml->levels - 1;   /* mips[min(q, len(mips) - 1)] */
        const float *m = level == 0 ? heights : (const float *)((const char *)mip + ml->offsets[level]);
        const int mr = ml->level_rows[level], mc = ml->level_cols[level], s = 1 << q;
        float *out = grids + cl.offsets[q];
        for (int r = 0; r < cl.grid_rows[q]; ++r) {
            int r0, r1, c0, c1;
            double fy, fx;
            coarse_axis(r, s, rows, mr, &r0, &r1, &fy);
            for (int c = 0; c < cl.grid_cols[q]; ++c) {
                coarse_axis(c, s, cols, mc, &c0, &c1, &fx);
                const double top = lerp(m[r0 * mc + c0], m[r0 * mc + c1], fx);
                const double bottom = lerp(m[r1 * mc + c0], m[r1 * mc + c1], fx);
                out[r * cl.grid_cols[q] + c] = (float)lerp(top, bottom, fy);
            }
        }
    }
    return OCLSHADE_OK;
}
