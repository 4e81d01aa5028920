/* host_passes — drives the C host API's screen-space and pyramid entry points for
 * tests/test_host_frames.py, which compares every output with the Python host's bit for bit.
 *
 * usage: host_passes COMMAND OUTDIR ARGS...
 *   mip OUTDIR IN.f32 ROWS COLS
 *       the mean mip pyramid of IN (float32, ROWS x COLS): mip.bin (the buffer as laid out)
 *       and mip_layout.txt ("rows cols byte_offset" per level 1..); checks itself that the
 *       input as a pitched field at an offset gives the same bits
 *   tables OUTDIR
 *       table_<samples>_<m>.f32 (oclshade_ssao_table) for samples 0..4 and m in M_LIST
 *   ssao OUTDIR INDIR WIDTH HEIGHT SPEC...
 *       INDIR holds position.f32, normal.f32 (float4 per pixel), projection.f64 (4 x 4
 *       row-major) and, for specs that ask, alpha.f32, normal_map.f32, tangent.f32; SPEC is
 *       samples,m,range_check,plane_test,blur,blur_size,radius,delta,seed,alpha,normal_map
 *       (blur 0 none, 1 box, 2 edge); writes ao_<k>.f32 per spec, and checks itself that the
 *       first spec gives the same bits with pitched inputs and output and with every ssao
 *       lanes knob.
 *   terrain OUTDIR HEIGHTS.f64 ROWS COLS DX DY RADIUS METHOD CAMERA [TEXDIR]
 *       relative heights, extrema pyramid, dilated levels, the G-buffer and its shading
 *       normals: relative.f32, offset.f64, dilated.f32, dilated_table.i32,
 *       gbuffer_<field>.f32, normals.f32, camera.f64 (view, projection, sx, sy, near, far);
 *       METHOD 1 bisect, 2 march, 3 dda; CAMERA "look:X,Y,Z,TX,TY,TZ,FOV,NEAR,FAR,W,H",
 *       "ortho:X,Y,Z,TX,TY,TZ,HEIGHT,NEAR,FAR,W,H" or "matrices:W,H" (then TEXDIR or
 *       the current folder holds view.f64 and projection.f64); a TEXDIR holding texture.f32,
 *       texture_levels.i32 and texture_count.txt ("levels texels"): the colour texture.  Checks itself that
 *       pitched outputs, other descend / group knobs and another leaf (dilated levels
 *       rebuilt) give the same bits.
 *   pixels OUTDIR HEIGHTS.f64 ROWS COLS DX DY INDIR WIDTH HEIGHT AZ,EL METHOD FORCE_Q BIAS NAMAX KDARK KBRIGHT
 *       INDIR holds the G-buffer's position.f32, uv.f32, uv_grad.f32; the mean mip pyramid of
 *       the relative heights (device), read back, the coarse grids (host), uploaded, then
 *       per-pixel shadows: mip.bin, coarse.f32, coarse_offsets.i32, flag.u8, coef.f32,
 *       lod.u8; checks itself that pitched fields and another group give the same bits.
 *   compose OUTDIR INDIR WIDTH HEIGHT SSAA AZ,EL INTENSITY SKY_R,G,B BG_R,G,B SHADOW AO LINEAR [LIGHT]
 *       INDIR holds position.f32, normal.f32, albedo.f32, rotation.f64 (3 x 3) and, where
 *       SHADOW / AO is 1, shadow.f32 / ao.f32 (samples: WIDTH SSAA x HEIGHT SSAA); writes
 *       image.u8 (image.f32 with LINEAR 1); checks itself that pitched fields give the same
 *       image.  LIGHT X,Y,Z,DISTANCE: a point light at world (X, Y, Z), falloff reference
 *       distance DISTANCE (0: none) instead of the sun; INDIR then holds translation.f64 (3).
 *   horizon OUTDIR HEIGHTS.f64 ROWS COLS DX DY CURVATURE DEFINITION N [MAX_DISTANCE [ROW_SCALES.f64 [COLUMNS [BANDS]]]]
 *       horizon angles at the N azimuths 360 k / N (angle_<k>.f32) and the sky-view factor
 *       sums over them (svf.f32: float2 per cell, zeroed by oclshade_enqueue_zero), within
 *       the search radius MAX_DISTANCE (default 0: the whole map), each band of rows at its
 *       own cell sizes with ROW_SCALES (rows x COLUMNS doubles, 2 or 4 (default 2): row_scales,
 *       row_scale_columns; rows x BANDS x COLUMNS with BANDS > 0: row_scale_bands, in blocks of
 *       rows by column bands); checks itself that a
 *       pitched angle field and another group (at azimuth 360 / N) and, with a radius, at every
 *       azimuth sweep_cells 0 and 256 (walked, swept) and sweep_far 2 (swept past the reach),
 *       and swept at lanes 1, 4, 8 and 16, give the same bits; over the whole map, that all N azimuths in one call (n_azimuths)
 *       give the same bands and sums at batch 1, 8 and 64, and into a pitched field.
 *   sun_disc OUTDIR HEIGHTS.f64 ROWS COLS DX DY AZ EL RADIUS COLUMNS CURVATURE MAX_DISTANCE
 *       soft shadows (oclshade_sun_disc) into fraction.f32; checks itself that a pitched angle
 *       field gives the same bits, and so do the strips summed here from oclshade_sun_disc_strips
 *       and clamped oclshade_enqueue_horizon calls.
 *   sunshine OUTDIR HEIGHTS.f64 ROWS COLS DX DY N AZ,EL,SECONDS...
 *       sunshine sums over the (daylight) suns: N 0 by each sun's exact mask (shadow pass),
 *       also with pitched heights (pitched_*); N > 0 by the horizons of N grid azimuths;
 *       sun.u32, cast.u32, beam.f32 (float2 per cell).
 *   envmap OUTDIR LATLONG.f32 H W N OH OW FACES.f32
 *       cube_border of FACES (a bordered cube of face N): border.f32; the lat-long map
 *       (H x W float4) resampled into a cube of face N (cube.f32, bordered) and back into an
 *       OH x OW lat-long map (latlong.f32); checks itself that pitched lat-long fields at
 *       offsets give the same bits.
 * Prints "ok" and exits 0 on success. */
#include "oclshade.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static oclshade *lib;
static const char *outdir;
static cl_context ctx;
static cl_device_id device;
static cl_command_queue queue;

#include "host_test_util.h"

/* The bytes (exactly n of them) of dir/name (dir NULL: name is the path), or NULL when the
 * file does not exist and is optional. */
static void *read_file(const char *dir, const char *name, size_t n, int optional)
{
    char path[4096];
    snprintf(path, sizeof path, "%s%s%s", dir ? dir : "", dir ? "/" : "", name);
    FILE *f = fopen(path, "rb");
    if (f == NULL && optional) return NULL;
    void *data = xmalloc(n);
    if (f == NULL || fread(data, 1, n, f) != n) fail(path);
    fclose(f);
    return data;
}

static cl_mem buffer(size_t n, const void *host)
{
    cl_int err;
    cl_mem m = clCreateBuffer(ctx, CL_MEM_READ_WRITE | (host ? CL_MEM_COPY_HOST_PTR : 0), n ? n : 1, (void *)host, &err);
    CLCHECK(err);
    return m;
}

static void *read_back(cl_mem m, size_t n)
{
    void *host = xmalloc(n);
    CLCHECK(clEnqueueReadBuffer(queue, m, CL_TRUE, 0, n, host, 0, NULL, NULL));
    return host;
}

/* A scratch buffer of `bytes` (NULL for 0). */
static cl_mem scratch_of(size_t bytes) { return bytes ? buffer(bytes, NULL) : NULL; }

static void release(cl_mem m)
{
    if (m) clReleaseMemObject(m);
}

/* A copy of rows x row_bytes packed host data in a buffer at byte `offset` with rows `pitch`
 * apart (the gaps filled with 0xAB), as a field. */
static oclshade_field pitched_copy(const void *packed, int rows, size_t row_bytes, size_t offset, size_t pitch)
{
    unsigned char *host = (unsigned char *)xmalloc(offset + (size_t)rows * pitch);
    memset(host, 0xAB, offset + (size_t)rows * pitch);
    for (int r = 0; r < rows; ++r) memcpy(host + offset + (size_t)r * pitch, (const unsigned char *)packed + (size_t)r * row_bytes, row_bytes);
    oclshade_field f = {buffer(offset + (size_t)rows * pitch, host), offset, pitch};
    free(host);
    return f;
}

/* The packed rows of a pitched field read back; also checks the gaps kept their 0xAB. */
static void *read_pitched(const oclshade_field *f, int rows, size_t row_bytes)
{
    const size_t total = f->offset + (size_t)rows * f->row_pitch;
    unsigned char *host = (unsigned char *)read_back(f->buffer, total), *out = (unsigned char *)xmalloc((size_t)rows * row_bytes);
    for (size_t i = 0; i < f->offset; ++i)
        if (host[i] != 0xAB) fail("a pitched output wrote before its offset");
    for (int r = 0; r < rows; ++r) {
        memcpy(out + (size_t)r * row_bytes, host + f->offset + (size_t)r * f->row_pitch, row_bytes);
        for (size_t i = row_bytes; i < f->row_pitch; ++i)
            if (host[f->offset + (size_t)r * f->row_pitch + i] != 0xAB) fail("a pitched output wrote into a row gap");
    }
    free(host);
    return out;
}

/* ------------------------------------------------------------------ mip */

static void run_mip(int argc, char **argv)
{
    if (argc != 3) fail("usage: host_passes mip OUTDIR IN.f32 ROWS COLS");
    const int rows = atoi(argv[1]), cols = atoi(argv[2]);
    const size_t n = (size_t)rows * (size_t)cols;
    float *values = (float *)read_file(NULL, argv[0], 4 * n, 0);
    oclshade_mip_layout lay;
    CHECK(oclshade_mip_layout_for(lib, rows, cols, &lay));
    cl_mem d_values = buffer(4 * n, values), d_mip = buffer(lay.bytes, NULL);
    const oclshade_field packed = oclshade_field_of(d_values);
    size_t bytes = 1;
    CHECK(oclshade_mip_pyramid_scratch_size(lib, &packed, rows, cols, &bytes));
    if (bytes != 0) fail("mip: a packed input needs no scratch");
    cl_event built = NULL;
    CHECK(oclshade_enqueue_mip_pyramid(lib, queue, &packed, rows, cols, d_mip, NULL, 0, NULL, &built));
    if (built == NULL) fail("mip: no event returned");   /* also for a 1 x 1 map, where nothing is launched */
    CLCHECK(clWaitForEvents(1, &built));
    clReleaseEvent(built);
    void *mip = read_back(d_mip, lay.bytes ? lay.bytes : 1);
    write_file("mip.bin", mip, lay.bytes);
    FILE *f;
    char path[4096];
    snprintf(path, sizeof path, "%s/mip_layout.txt", outdir);
    if ((f = fopen(path, "w")) == NULL) fail(path);
    for (int l = 1; l < lay.levels; ++l) fprintf(f, "%d %d %lu\n", lay.level_rows[l], lay.level_cols[l], (unsigned long)lay.offsets[l]);
    fclose(f);
    /* the same input at an offset with padded rows: copied into the scratch, same bits */
    oclshade_field pitched = pitched_copy(values, rows, 4u * (size_t)cols, 256, 4u * (size_t)cols + 20);
    CHECK(oclshade_mip_pyramid_scratch_size(lib, &pitched, rows, cols, &bytes));
    cl_mem scratch = scratch_of(bytes), d_mip2 = buffer(lay.bytes, NULL);
    CHECK(oclshade_enqueue_mip_pyramid(lib, queue, &pitched, rows, cols, d_mip2, scratch, 0, NULL, NULL));
    void *mip2 = read_back(d_mip2, lay.bytes ? lay.bytes : 1);
    for (int l = 1; l < lay.levels; ++l)
        if (memcmp((char *)mip + lay.offsets[l], (char *)mip2 + lay.offsets[l], 4u * (size_t)lay.level_rows[l] * (size_t)lay.level_cols[l]))
            fail("mip: the pitched input gives other levels");
    printf("mip: pitched input, same levels\n");
    release(d_values); release(d_mip); release(d_mip2); release(pitched.buffer); release(scratch);
    free(values); free(mip); free(mip2);
}

/* ------------------------------------------------------------------ tables */

static const int M_LIST[] = {4, 5, 8, 13, 32, 100, 256};

static void run_tables(void)
{
    for (int s = OCLSHADE_AO_PAPER; s <= OCLSHADE_AO_RAYS; ++s) {
        for (size_t i = 0; i < sizeof M_LIST / sizeof M_LIST[0]; ++i) {
            float table[3 * 256];
            int mpad = 0;
            CHECK(oclshade_ssao_table((oclshade_ao_samples)s, M_LIST[i], table, &mpad));
            char name[64];
            snprintf(name, sizeof name, "table_%d_%d.f32", s, M_LIST[i]);
            write_file(name, table, 12u * (size_t)mpad);
        }
    }
    float t[768];
    if (oclshade_ssao_table(OCLSHADE_AO_RAYS, 3, t, NULL) != OCLSHADE_INVALID_ARGUMENT ||
        oclshade_ssao_table(OCLSHADE_AO_RAYS, 257, t, NULL) != OCLSHADE_INVALID_ARGUMENT ||
        oclshade_ssao_table((oclshade_ao_samples)5, 8, t, NULL) != OCLSHADE_INVALID_ARGUMENT)
        fail("tables: bad m or samples accepted");
}

/* ------------------------------------------------------------------ ssao */

typedef struct ssao_inputs {
    int width, height;
    float *position, *normal, *alpha, *normal_map, *tangent;
    double projection[16];
} ssao_inputs;

/* Runs one spec; pitched: inputs and output as pitched fields at offsets. */
static float *ssao_once(const ssao_inputs *in, const char *spec, int pitched)
{
    oclshade_ssao_params p;
    oclshade_ssao_params_init(&p);
    int samples, blur, alpha, nmap;
    if (sscanf(spec, "%d,%d,%d,%d,%d,%d,%lf,%lf,%u,%d,%d", &samples, &p.m, &p.range_check, &p.plane_test, &blur,
               &p.blur_size, &p.radius, &p.delta, &p.seed, &alpha, &nmap) != 11)
        fail("bad ssao spec");
    p.samples = (oclshade_ao_samples)samples;
    p.blur = (oclshade_blur)blur;
    p.width = in->width;
    p.height = in->height;
    memcpy(p.projection, in->projection, sizeof p.projection);
    const int rows = in->height;
    const size_t w = (size_t)in->width, n = w * (size_t)rows;
    const float *host[5] = {in->position, in->normal, alpha ? in->alpha : NULL, nmap ? in->normal_map : NULL,
                            nmap ? in->tangent : NULL};
    oclshade_field *fields[5] = {&p.position, &p.normal, &p.alpha, &p.normal_map, &p.tangent};
    const size_t row_bytes[5] = {16 * w, 16 * w, 4 * w, 16 * w, 16 * w};
    for (int i = 0; i < 5; ++i) {
        if (host[i] == NULL) continue;
        if ((i == 2 && in->alpha == NULL) || (i >= 3 && in->normal_map == NULL)) fail("ssao: spec asks for a missing map");
        *fields[i] = pitched ? pitched_copy(host[i], rows, row_bytes[i], 384, row_bytes[i] + 16)
                             : oclshade_field_of(buffer((size_t)rows * row_bytes[i], host[i]));
    }
    float *ones = (float *)xmalloc(4 * n);
    p.ao = pitched ? pitched_copy(ones, rows, 4 * w, 128, 4 * w + 12) : oclshade_field_of(buffer(4 * n, NULL));
    size_t bytes = 0;
    CHECK(oclshade_ssao_scratch_size(lib, &p, &bytes));
    p.scratch = scratch_of(bytes);
    cl_event done;
    CHECK(oclshade_enqueue_ssao(lib, queue, &p, 0, NULL, &done));
    CLCHECK(clWaitForEvents(1, &done));
    clReleaseEvent(done);
    float *ao = pitched ? (float *)read_pitched(&p.ao, rows, 4 * w) : (float *)read_back(p.ao.buffer, 4 * n);
    for (int i = 0; i < 5; ++i) release(fields[i]->buffer);
    release(p.ao.buffer);
    release(p.scratch);
    free(ones);
    return ao;
}

static void run_ssao(int argc, char **argv)
{
    if (argc < 4) fail("usage: host_passes ssao OUTDIR INDIR WIDTH HEIGHT SPEC...");
    const char *indir = argv[0];
    ssao_inputs in;
    memset(&in, 0, sizeof in);
    in.width = atoi(argv[1]);
    in.height = atoi(argv[2]);
    const size_t n = (size_t)in.width * (size_t)in.height;
    in.position = (float *)read_file(indir, "position.f32", 16 * n, 0);
    in.normal = (float *)read_file(indir, "normal.f32", 16 * n, 0);
    in.alpha = (float *)read_file(indir, "alpha.f32", 4 * n, 1);
    in.normal_map = (float *)read_file(indir, "normal_map.f32", 16 * n, 1);
    in.tangent = (float *)read_file(indir, "tangent.f32", 16 * n, 1);
    double *proj = (double *)read_file(indir, "projection.f64", sizeof in.projection, 0);
    memcpy(in.projection, proj, sizeof in.projection);
    free(proj);
    float *first = NULL;
    for (int k = 3; k < argc; ++k) {
        float *ao = ssao_once(&in, argv[k], 0);
        char name[64];
        snprintf(name, sizeof name, "ao_%d.f32", k - 3);
        write_file(name, ao, 4 * n);
        if (first == NULL) first = ao;
        else free(ao);
    }
    /* the first spec with pitched fields, and under every lanes knob: same bits */
    float *again = ssao_once(&in, argv[3], 1);
    if (memcmp(again, first, 4 * n) != 0) fail("ssao: pitched fields give another AO map");
    free(again);
    static const int lanes[] = {4, 8, 16}, groups[] = {16, 64, 256};
    int lanes0 = 0;
    CHECK(oclshade_get_knob(lib, "ssao", "lanes", &lanes0));
    for (int i = 0; i < 3; ++i) {
        CHECK(oclshade_set_knob(lib, "ssao", "lanes", lanes[i]));
        CHECK(oclshade_set_knob(lib, "ssao", "group", groups[i]));
        again = ssao_once(&in, argv[3], 0);
        if (memcmp(again, first, 4 * n) != 0) fail("ssao: another lanes knob gives another AO map");
        free(again);
    }
    CHECK(oclshade_set_knob(lib, "ssao", "lanes", lanes0));
    CHECK(oclshade_set_knob(lib, "ssao", "group", 64));
    printf("ssao: pitched fields and lanes 4, 8, 16: same AO\n");
    free(first);
    free(in.position); free(in.normal); free(in.alpha); free(in.normal_map); free(in.tangent);
}

/* ------------------------------------------------------------------ terrain */

static double *read_doubles(const char *dir, const char *name, size_t count)
{
    return (double *)read_file(dir, name, count * sizeof(double), 0);
}

static void parse_camera(const char *spec, const char *matrix_dir, oclshade_camera *cam)
{
    double v[11];
    if (strncmp(spec, "look:", 5) == 0 || strncmp(spec, "ortho:", 6) == 0) {
        const int ortho = spec[0] == 'o';
        if (sscanf(strchr(spec, ':') + 1, "%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3],
                   &v[4], &v[5], &v[6], &v[7], &v[8], &v[9], &v[10]) != 11)
            fail("bad camera");
        CHECK(oclshade_camera_look_at(v, v + 3, NULL, (int)v[9], (int)v[10],
                                      ortho ? OCLSHADE_ORTHOGRAPHIC : OCLSHADE_PERSPECTIVE, ortho ? 45.0 : v[6],
                                      ortho ? v[6] : 1.0, v[7], v[8], cam));
    } else if (strncmp(spec, "matrices:", 9) == 0) {
        int w, h;
        if (sscanf(spec + 9, "%d,%d", &w, &h) != 2) fail("bad camera");
        double *view = read_doubles(matrix_dir, "view.f64", 16), *proj = read_doubles(matrix_dir, "projection.f64", 16);
        CHECK(oclshade_camera_from_matrices(view, proj, w, h, cam));
        free(view);
        free(proj);
    } else {
        fail("bad camera");
    }
}

typedef struct map {
    int rows, cols;
    size_t n;
    double offset;
    float *rel;
    cl_mem heights, pyramid, offsets;
    oclshade_pyramid_layout lay;
} map;

/* Relative heights and their extrema pyramid on the device. */
static void load_map(map *m, const char *path, int rows, int cols)
{
    m->rows = rows;
    m->cols = cols;
    m->n = (size_t)rows * (size_t)cols;
    double *heights = (double *)read_file(NULL, path, 8 * m->n, 0);
    m->rel = (float *)xmalloc(4 * m->n);
    CHECK(oclshade_relative_heights(heights, m->n, m->rel, &m->offset));
    free(heights);
    CHECK(oclshade_pyramid_layout_for(rows, cols, &m->lay));
    m->heights = buffer(4 * m->n, m->rel);
    m->pyramid = buffer(m->lay.pyramid_bytes, NULL);
    m->offsets = buffer(m->lay.offsets_bytes, NULL);
    const oclshade_field f = oclshade_field_of(m->heights);
    CHECK(oclshade_enqueue_extrema_pyramid(lib, queue, &f, rows, cols, m->pyramid, m->offsets, NULL, 0, NULL, NULL));
    write_file("relative.f32", m->rel, 4 * m->n);
    write_file("offset.f64", &m->offset, sizeof m->offset);
}

static void free_map(map *m)
{
    release(m->heights); release(m->pyramid); release(m->offsets);
    free(m->rel);
}

static const char *const GBUFFER_FIELDS[6] = {"position", "normal", "uv", "uv_grad", "depth", "albedo"};
static const size_t GBUFFER_BYTES[6] = {16, 16, 8, 16, 4, 16};

static oclshade_field *gbuffer_field(oclshade_gbuffer *g, int i)
{
    oclshade_field *const f[6] = {&g->position, &g->normal, &g->uv, &g->uv_grad, &g->depth, &g->albedo};
    return f[i];
}

/* The dilated levels for the handle's current leaf knob. */
static void dilate(const map *m, oclshade_terrain_params *p)
{
    oclshade_dilated_layout dl;
    CHECK(oclshade_dilated_layout_for(lib, m->rows, m->cols, &dl));
    release(p->dilated);
    release(p->dilated_table);
    p->dilated = buffer(dl.bytes, NULL);
    p->dilated_table = buffer(dl.table_bytes, NULL);
    const oclshade_field f = oclshade_field_of(m->heights);
    CHECK(oclshade_enqueue_dilated_levels(lib, queue, &f, m->rows, m->cols, m->pyramid, m->offsets, p->dilated,
                                          p->dilated_table, NULL, 0, NULL, NULL));
}

/* The G-buffer (six fields, then the shading normals) read back into out[7]; pitched: every
 * output a pitched field at an offset. */
static void cast(oclshade_terrain_params *p, int pitched, void *out[7])
{
    const int h = p->camera.height;
    const size_t w = (size_t)p->camera.width;
    oclshade_field normals;
    for (int i = 0; i < 7; ++i) {
        const size_t row = (i < 6 ? GBUFFER_BYTES[i] : 16) * w;
        void *zero = xmalloc(row * (size_t)h);
        oclshade_field *f = i < 6 ? gbuffer_field(&p->gbuffer, i) : &normals;
        *f = pitched ? pitched_copy(zero, h, row, 128u * (size_t)(i + 1), row + 16u * (size_t)(i + 1))
                     : oclshade_field_of(buffer(row * (size_t)h, NULL));
        free(zero);
    }
    size_t bytes = 0, normal_bytes = 0;
    CHECK(oclshade_terrain_scratch_size(lib, p, &bytes));
    CHECK(oclshade_terrain_normals_scratch_size(lib, p, &normals, &normal_bytes));
    p->scratch = scratch_of(bytes > normal_bytes ? bytes : normal_bytes);
    CHECK(oclshade_enqueue_terrain(lib, queue, p, 0, NULL, NULL));
    CHECK(oclshade_enqueue_terrain_normals(lib, queue, p, &normals, 0, NULL, NULL));
    for (int i = 0; i < 7; ++i) {
        const size_t row = (i < 6 ? GBUFFER_BYTES[i] : 16) * w;
        oclshade_field *f = i < 6 ? gbuffer_field(&p->gbuffer, i) : &normals;
        out[i] = pitched ? read_pitched(f, h, row) : read_back(f->buffer, row * (size_t)h);
        release(f->buffer);
    }
    release(p->scratch);
    p->scratch = NULL;
}

static void same_gbuffer(void *a[7], void *b[7], size_t pixels, const char *what)
{
    for (int i = 0; i < 7; ++i) {
        if (memcmp(a[i], b[i], (i < 6 ? GBUFFER_BYTES[i] : 16) * pixels) != 0) {
            fprintf(stderr, "terrain: %s: field %s differs\n", what, i < 6 ? GBUFFER_FIELDS[i] : "normals");
            exit(1);
        }
        free(b[i]);
    }
}

static void run_terrain(int argc, char **argv)
{
    if (argc < 8) fail("usage: host_passes terrain OUTDIR HEIGHTS.f64 ROWS COLS DX DY RADIUS METHOD CAMERA [TEXDIR]");
    map m;
    load_map(&m, argv[0], atoi(argv[1]), atoi(argv[2]));
    oclshade_terrain_params p;
    oclshade_terrain_params_init(&p);
    p.rows = m.rows; p.cols = m.cols;
    p.dx = strtod(argv[3], NULL); p.dy = strtod(argv[4], NULL);
    p.radius = strtod(argv[5], NULL);
    p.method = (oclshade_caster)atoi(argv[6]);
    const char *texdir = argc > 8 ? argv[8] : ".";
    parse_camera(argv[7], texdir, &p.camera);
    double cam[36];
    memcpy(cam, p.camera.view, sizeof p.camera.view);
    memcpy(cam + 16, p.camera.projection_matrix, sizeof p.camera.projection_matrix);
    cam[32] = p.camera.sx; cam[33] = p.camera.sy; cam[34] = p.camera.near_depth; cam[35] = p.camera.far_depth;
    write_file("camera.f64", cam, sizeof cam);
    p.heights = oclshade_field_of(m.heights);
    p.offset = m.offset;
    CHECK(oclshade_height_range(m.rel, m.n, &p.hmin, &p.hmax));
    p.pyramid = m.pyramid;
    p.offsets = m.offsets;
    char path[4096];
    snprintf(path, sizeof path, "%s/texture_count.txt", texdir);
    FILE *f = argc > 8 ? fopen(path, "r") : NULL;
    if (f != NULL) {
        int count = 0;
        unsigned long texels = 0;
        if (fscanf(f, "%d %lu", &count, &texels) != 2) fail(path);
        fclose(f);
        float *tex = (float *)read_file(texdir, "texture.f32", 16 * texels, 0);
        int *levels = (int *)read_file(texdir, "texture_levels.i32", 16u * (size_t)count, 0);
        p.texture = buffer(16 * texels, tex);
        p.texture_levels = buffer(16u * (size_t)count, levels);
        p.texture_count = count;
        free(tex);
        free(levels);
    }
    dilate(&m, &p);
    oclshade_dilated_layout dl;
    CHECK(oclshade_dilated_layout_for(lib, m.rows, m.cols, &dl));
    void *dil = read_back(p.dilated, dl.bytes), *table = read_back(p.dilated_table, dl.table_bytes);
    write_file("dilated.f32", dil, dl.bytes);
    write_file("dilated_table.i32", table, dl.table_bytes);
    free(dil); free(table);
    void *fields[7], *again[7];
    cast(&p, 0, fields);
    const size_t pixels = (size_t)p.camera.width * (size_t)p.camera.height;
    for (int i = 0; i < 7; ++i) {
        char name[64];
        snprintf(name, sizeof name, i < 6 ? "gbuffer_%s.f32" : "normals.f32", i < 6 ? GBUFFER_FIELDS[i] : "");
        write_file(name, fields[i], (i < 6 ? GBUFFER_BYTES[i] : 16) * pixels);
    }
    cast(&p, 1, again);
    same_gbuffer(fields, again, pixels, "pitched outputs");
    int leaf0 = 0;
    CHECK(oclshade_get_knob(lib, "terrain", "leaf", &leaf0));
    CHECK(oclshade_set_knob(lib, "terrain", "descend", 1));
    CHECK(oclshade_set_knob(lib, "terrain", "group", 16));
    CHECK(oclshade_set_knob(lib, "terrain", "leaf", leaf0 == 0 ? 3 : 0));
    dilate(&m, &p);
    cast(&p, 0, again);
    same_gbuffer(fields, again, pixels, "descend 1, group 16, another leaf");
    printf("terrain: pitched outputs and other knobs: same G-buffer\n");
    for (int i = 0; i < 7; ++i) free(fields[i]);
    release(p.dilated); release(p.dilated_table); release(p.texture); release(p.texture_levels);
    free_map(&m);
}

/* ------------------------------------------------------------------ pixels */

static void *pixel_pass(oclshade_pixel_shadow_params *p, int pitched, void **coef_out, void **lod_out)
{
    const int h = p->height;
    const size_t w = (size_t)p->width;
    void *zero = xmalloc(4 * w * (size_t)h);
    p->flag = pitched ? pitched_copy(zero, h, w, 256, w + 3) : oclshade_field_of(buffer(w * (size_t)h, NULL));
    p->coefficient = pitched ? pitched_copy(zero, h, 4 * w, 128, 4 * w + 8) : oclshade_field_of(buffer(4 * w * (size_t)h, NULL));
    p->lod = oclshade_field_of(buffer(w * (size_t)h, NULL));
    free(zero);
    size_t bytes = 0;
    CHECK(oclshade_pixel_shadows_scratch_size(lib, p, &bytes));
    p->scratch = scratch_of(bytes);
    CHECK(oclshade_enqueue_pixel_shadows(lib, queue, p, 0, NULL, NULL));
    void *flag = pitched ? read_pitched(&p->flag, h, w) : read_back(p->flag.buffer, w * (size_t)h);
    *coef_out = pitched ? read_pitched(&p->coefficient, h, 4 * w) : read_back(p->coefficient.buffer, 4 * w * (size_t)h);
    *lod_out = read_back(p->lod.buffer, w * (size_t)h);
    release(p->flag.buffer); release(p->coefficient.buffer); release(p->lod.buffer); release(p->scratch);
    return flag;
}

static void run_pixels(int argc, char **argv)
{
    if (argc != 15) fail("usage: host_passes pixels OUTDIR HEIGHTS.f64 ROWS COLS DX DY INDIR WIDTH HEIGHT AZ,EL METHOD "
                         "FORCE_Q BIAS NAMAX KDARK KBRIGHT");
    map m;
    load_map(&m, argv[0], atoi(argv[1]), atoi(argv[2]));
    oclshade_pixel_shadow_params p;
    oclshade_pixel_shadow_params_init(&p);
    p.rows = m.rows; p.cols = m.cols;
    p.dx = strtod(argv[3], NULL); p.dy = strtod(argv[4], NULL);
    const char *indir = argv[5];
    p.width = atoi(argv[6]); p.height = atoi(argv[7]);
    if (sscanf(argv[8], "%lf,%lf", &p.azimuth, &p.elevation) != 2) fail("bad sun");
    p.method = (oclshade_method)atoi(argv[9]);
    p.force_q = atoi(argv[10]); p.bias = atoi(argv[11]); p.n_a_max = atoi(argv[12]);
    p.k_dark = strtod(argv[13], NULL); p.k_bright = strtod(argv[14], NULL);
    /* the level-q grids: the mip pyramid on the device, read back, the grids on the host */
    oclshade_mip_layout ml;
    CHECK(oclshade_mip_layout_for(lib, m.rows, m.cols, &ml));
    cl_mem d_mip = buffer(ml.bytes, NULL);
    const oclshade_field hf = oclshade_field_of(m.heights);
    CHECK(oclshade_enqueue_mip_pyramid(lib, queue, &hf, m.rows, m.cols, d_mip, NULL, 0, NULL, NULL));
    void *mip = read_back(d_mip, ml.bytes ? ml.bytes : 1);
    write_file("mip.bin", mip, ml.bytes);
    oclshade_coarse_layout cl;
    CHECK(oclshade_coarse_layout_for(m.rows, m.cols, &cl));
    float *grids = (float *)xmalloc(cl.grids_bytes);
    int *grid_offsets = (int *)xmalloc(cl.offsets_bytes);
    CHECK(oclshade_coarse_grids(m.rel, mip, &ml, m.rows, m.cols, grids, grid_offsets));
    write_file("coarse.f32", grids, cl.grids_bytes);
    write_file("coarse_offsets.i32", grid_offsets, cl.offsets_bytes);
    p.heights = hf;
    p.pyramid = m.pyramid; p.offsets = m.offsets;
    p.coarse = buffer(cl.grids_bytes, grids);
    p.coarse_offsets = buffer(cl.offsets_bytes, grid_offsets);
    const size_t n = (size_t)p.width * (size_t)p.height;
    float *pos = (float *)read_file(indir, "position.f32", 16 * n, 0), *uv = (float *)read_file(indir, "uv.f32", 8 * n, 0);
    float *grad = (float *)read_file(indir, "uv_grad.f32", 16 * n, 0);
    p.position = oclshade_field_of(buffer(16 * n, pos));
    p.uv = oclshade_field_of(buffer(8 * n, uv));
    p.uv_grad = oclshade_field_of(buffer(16 * n, grad));
    void *coef, *lod, *coef2, *lod2;
    void *flag = pixel_pass(&p, 0, &coef, &lod);
    write_file("flag.u8", flag, n);
    write_file("coef.f32", coef, 4 * n);
    write_file("lod.u8", lod, n);
    /* pitched inputs and outputs, another group: same bits */
    release(p.position.buffer); release(p.uv.buffer);
    p.position = pitched_copy(pos, p.height, 16u * (size_t)p.width, 640, 16u * (size_t)p.width + 48);
    p.uv = pitched_copy(uv, p.height, 8u * (size_t)p.width, 128, 8u * (size_t)p.width + 8);
    CHECK(oclshade_set_knob(lib, "screen_shadows", "group", 16));
    void *flag2 = pixel_pass(&p, 1, &coef2, &lod2);
    if (memcmp(flag, flag2, n) || memcmp(coef, coef2, 4 * n) || memcmp(lod, lod2, n))
        fail("pixels: pitched fields or group 16 give other outputs");
    printf("pixels: pitched fields and group 16: same outputs\n");
    release(p.position.buffer); release(p.uv.buffer); release(p.uv_grad.buffer);
    release(p.coarse); release(p.coarse_offsets); release(d_mip);
    free(flag); free(coef); free(lod); free(flag2); free(coef2); free(lod2);
    free(mip); free(grids); free(grid_offsets); free(pos); free(uv); free(grad);
    free_map(&m);
}

/* ------------------------------------------------------------------ compose */

static void *compose_once(oclshade_compose_params *p, float *host[5], int pitched)
{
    const int sh = p->height * p->ssaa;
    const size_t sw = (size_t)p->width * (size_t)p->ssaa;
    oclshade_field *fields[5] = {&p->position, &p->normal, &p->albedo, &p->shadow, &p->ao};
    const size_t rows[5] = {16 * sw, 16 * sw, 16 * sw, 4 * sw, 4 * sw};
    for (int i = 0; i < 5; ++i)
        *fields[i] = host[i] == NULL ? oclshade_field_of(NULL)
                     : pitched ? pitched_copy(host[i], sh, rows[i], 128u * (size_t)(i + 1), rows[i] + 32)
                               : oclshade_field_of(buffer((size_t)sh * rows[i], host[i]));
    const size_t row = (p->linear ? 16u : 4u) * (size_t)p->width;
    void *zero = xmalloc(row * (size_t)p->height);
    p->image = pitched ? pitched_copy(zero, p->height, row, 384, row + 4) : oclshade_field_of(buffer(row * (size_t)p->height, NULL));
    free(zero);
    size_t bytes = 0;
    CHECK(oclshade_compose_scratch_size(lib, p, &bytes));
    p->scratch = scratch_of(bytes);
    CHECK(oclshade_enqueue_compose(lib, queue, p, 0, NULL, NULL));
    void *image = pitched ? read_pitched(&p->image, p->height, row) : read_back(p->image.buffer, row * (size_t)p->height);
    for (int i = 0; i < 5; ++i) release(fields[i]->buffer);
    release(p->image.buffer);
    release(p->scratch);
    return image;
}

static void run_compose(int argc, char **argv)
{
    if (argc != 11 && argc != 12)
        fail("usage: host_passes compose OUTDIR INDIR WIDTH HEIGHT SSAA AZ,EL INTENSITY SKY BG SHADOW AO LINEAR [LIGHT]");
    const char *indir = argv[0];
    oclshade_compose_params p;
    oclshade_compose_params_init(&p);
    p.width = atoi(argv[1]); p.height = atoi(argv[2]); p.ssaa = atoi(argv[3]);
    if (sscanf(argv[4], "%lf,%lf", &p.azimuth, &p.elevation) != 2) fail("bad sun");
    p.sun_intensity = strtod(argv[5], NULL);
    p.linear = atoi(argv[10]);
    if (sscanf(argv[6], "%lf,%lf,%lf", &p.sky[0], &p.sky[1], &p.sky[2]) != 3 ||
        sscanf(argv[7], "%lf,%lf,%lf", &p.background[0], &p.background[1], &p.background[2]) != 3)
        fail("bad colour");
    double *rot = read_doubles(indir, "rotation.f64", 9);
    memcpy(p.rotation, rot, sizeof p.rotation);
    free(rot);
    if (argc == 12) {
        p.point_light = 1;
        if (sscanf(argv[11], "%lf,%lf,%lf,%lf", &p.light_position[0], &p.light_position[1], &p.light_position[2],
                   &p.light_distance) != 4)
            fail("bad light");
        double *t = read_doubles(indir, "translation.f64", 3);
        memcpy(p.translation, t, sizeof p.translation);
        free(t);
    }
    const size_t samples = (size_t)p.width * (size_t)p.height * (size_t)p.ssaa * (size_t)p.ssaa;
    float *host[5] = {(float *)read_file(indir, "position.f32", 16 * samples, 0),
                      (float *)read_file(indir, "normal.f32", 16 * samples, 0),
                      (float *)read_file(indir, "albedo.f32", 16 * samples, 0),
                      atoi(argv[8]) ? (float *)read_file(indir, "shadow.f32", 4 * samples, 0) : NULL,
                      atoi(argv[9]) ? (float *)read_file(indir, "ao.f32", 4 * samples, 0) : NULL};
    const size_t bytes = (p.linear ? 16u : 4u) * (size_t)p.width * (size_t)p.height;
    void *image = compose_once(&p, host, 0);
    write_file(p.linear ? "image.f32" : "image.u8", image, bytes);
    void *again = compose_once(&p, host, 1);
    if (memcmp(image, again, bytes) != 0) fail("compose: pitched fields give another image");
    printf("compose: pitched fields: same image\n");
    free(image); free(again);
    for (int i = 0; i < 5; ++i) free(host[i]);
}

/* ------------------------------------------------------------------ sunshine and horizons */

static double horizon_max_distance = 0.0;   /* run_horizon's MAX_DISTANCE */
static const double *horizon_row_scales;     /* run_horizon's ROW_SCALES (NULL: none) */
static int horizon_row_scale_columns = 2;     /* run_horizon's COLUMNS */
static int horizon_row_scale_bands = 0;       /* run_horizon's BANDS */

/* One oclshade_enqueue_horizon call into `angle` and/or `svf`: the azimuth azimuths[0] (n 0), or the
 * n azimuths in one call (n_azimuths: kernels/horizon.cl "Batches"; `angle` then n bands of rows). */
static void horizon_call(const map *m, double dx, double dy, double curvature, const double *azimuths, int n,
                         oclshade_field *angle, cl_mem svf, int definition)
{
    oclshade_horizon_params p;
    oclshade_horizon_params_init(&p);
    p.heights = oclshade_field_of(m->heights);
    p.rows = m->rows; p.cols = m->cols; p.dx = dx; p.dy = dy;
    p.pyramid = m->pyramid; p.offsets = m->offsets;
    p.azimuth = azimuths[0];
    if (n > 0) { p.azimuths = azimuths; p.n_azimuths = n; }
    p.curvature = curvature;
    p.max_distance = horizon_max_distance;
    p.row_scales = horizon_row_scales;
    p.row_scale_columns = horizon_row_scale_columns;
    p.row_scale_bands = horizon_row_scale_bands;
    if (angle) p.angle = *angle;
    p.svf = svf;
    p.svf_definition = (oclshade_svf_definition)definition;
    size_t bytes = 0;
    CHECK(oclshade_horizon_scratch_size(lib, &p, &bytes));
    p.scratch = scratch_of(bytes);
    CHECK(oclshade_enqueue_horizon(lib, queue, &p, 0, NULL, NULL));
    CLCHECK(clFinish(queue));
    release(p.scratch);
}

static void horizon_band(const map *m, double dx, double dy, double curvature, double azimuth, oclshade_field *angle,
                         cl_mem svf, int definition)
{
    horizon_call(m, dx, dy, curvature, &azimuth, 0, angle, svf, definition);
}

/* All n azimuths 360 k / n in one call into `angle` (n bands of rows) and/or `svf`. */
static void horizon_bands(const map *m, double dx, double dy, double curvature, int n, oclshade_field *angle,
                          cl_mem svf, int definition)
{
    double *azimuths = (double *)xmalloc(sizeof *azimuths * (size_t)n);
    for (int k = 0; k < n; ++k) azimuths[k] = 360.0 * k / n;
    horizon_call(m, dx, dy, curvature, azimuths, n, angle, svf, definition);
    free(azimuths);
}

/* The whole map's n azimuths in one call give the bands and sums of one call per azimuth
 * (`bands`: n packed bands; `svf`: their sums), at batch 1, 8 and 64, a pitched field too, and
 * either level search (knob scan: the other value than the handle's with batch 8). */
static void check_horizon_batches(const map *m, double dx, double dy, double curvature, int n, int definition,
                                  const unsigned char *bands, const void *svf)
{
    const size_t row = 4 * (size_t)m->cols, band = 4 * m->n;
    int default_batch = 0, default_scan = 0;
    CHECK(oclshade_get_knob(lib, "horizon", "batch", &default_batch));
    CHECK(oclshade_get_knob(lib, "horizon", "scan", &default_scan));
    static const int batches[] = {1, 8, 64};
    for (size_t b = 0; b < sizeof batches / sizeof batches[0]; ++b) {
        CHECK(oclshade_set_knob(lib, "horizon", "batch", batches[b]));
        CHECK(oclshade_set_knob(lib, "horizon", "scan", batches[b] == 8 ? !default_scan : default_scan));
        cl_mem d_angles = buffer(band * (size_t)n, NULL), d_svf = buffer(8 * m->n, NULL);
        CHECK(oclshade_enqueue_zero(lib, queue, d_svf, 8 * m->n, 0, NULL, NULL));
        oclshade_field angles = oclshade_field_of(d_angles);
        horizon_bands(m, dx, dy, curvature, n, &angles, NULL, definition);
        horizon_bands(m, dx, dy, curvature, n, NULL, d_svf, definition);
        void *got = read_back(d_angles, band * (size_t)n), *sums = read_back(d_svf, 8 * m->n);
        if (memcmp(got, bands, band * (size_t)n) != 0) fail("horizon: the azimuths in one call differ from one call each");
        if (memcmp(sums, svf, 8 * m->n) != 0) fail("horizon: the sky-view sums in one call differ from one call each");
        if (batches[b] == 8) {   /* a pitched field at an offset, the angles and the sums at once */
            oclshade_field pitched = pitched_copy(bands, n * m->rows, row, 256, row + 68);
            CHECK(oclshade_enqueue_zero(lib, queue, d_svf, 8 * m->n, 0, NULL, NULL));
            horizon_bands(m, dx, dy, curvature, n, &pitched, d_svf, definition);
            void *again = read_pitched(&pitched, n * m->rows, row), *sums2 = read_back(d_svf, 8 * m->n);
            if (memcmp(again, bands, band * (size_t)n) != 0) fail("horizon: a pitched field of the bands differs");
            if (memcmp(sums2, svf, 8 * m->n) != 0) fail("horizon: the sums with the angles differ");
            free(again); free(sums2);
            release(pitched.buffer);
        }
        free(got); free(sums);
        release(d_angles); release(d_svf);
    }
    CHECK(oclshade_set_knob(lib, "horizon", "batch", default_batch));
    CHECK(oclshade_set_knob(lib, "horizon", "scan", default_scan));
}

static void run_horizon(int argc, char **argv)
{
    if (argc < 8 || argc > 12)
        fail("usage: host_passes horizon OUTDIR HEIGHTS.f64 ROWS COLS DX DY CURVATURE DEFINITION N [MAX_DISTANCE "
             "[ROW_SCALES.f64 [COLUMNS [BANDS]]]]");
    if (argc >= 9) horizon_max_distance = atof(argv[8]);
    if (argc >= 11) horizon_row_scale_columns = atoi(argv[10]);
    if (argc == 12) horizon_row_scale_bands = atoi(argv[11]);
    map m;
    load_map(&m, argv[0], atoi(argv[1]), atoi(argv[2]));
    const size_t per_row = (size_t)horizon_row_scale_columns * (size_t)(horizon_row_scale_bands > 0 ? horizon_row_scale_bands : 1);
    double *row_scales = argc >= 10 ? (double *)read_file(NULL, argv[9], 8 * per_row * (size_t)m.rows, 0) : NULL;
    horizon_row_scales = row_scales;
    const double dx = atof(argv[3]), dy = atof(argv[4]), curvature = atof(argv[5]);
    const int definition = atoi(argv[6]), n = atoi(argv[7]);
    const size_t row = 4 * (size_t)m.cols;
    cl_mem d_angle = buffer(4 * m.n, NULL), d_svf = buffer(8 * m.n, NULL);
    CHECK(oclshade_enqueue_zero(lib, queue, d_svf, 8 * m.n, 0, NULL, NULL));
    unsigned char *bands = (unsigned char *)xmalloc(4 * m.n * (size_t)(n > 0 ? n : 1));
    char name[64];
    for (int k = 0; k < n; ++k) {   /* oclshade.horizon.azimuth_grid: 360 k / n */
        oclshade_field angle = oclshade_field_of(d_angle);
        horizon_band(&m, dx, dy, curvature, 360.0 * k / n, &angle, NULL, definition);
        horizon_band(&m, dx, dy, curvature, 360.0 * k / n, NULL, d_svf, definition);
        void *band = read_back(d_angle, 4 * m.n);
        snprintf(name, sizeof name, "angle_%d.f32", k);
        write_file(name, band, 4 * m.n);
        memcpy(bands + 4 * m.n * (size_t)k, band, 4 * m.n);
        if (k == 1) {   /* a pitched output at an offset, and another group, give the same bits */
            oclshade_field pitched = pitched_copy(band, m.rows, row, 256, row + 68);
            horizon_band(&m, dx, dy, curvature, 360.0 * k / n, &pitched, NULL, definition);
            void *again = read_pitched(&pitched, m.rows, row);
            if (memcmp(again, band, 4 * m.n) != 0) fail("horizon: a pitched angle field differs");
            free(again);
            release(pitched.buffer);
            CHECK(oclshade_set_knob(lib, "horizon", "group", 16));
            horizon_band(&m, dx, dy, curvature, 360.0 * k / n, &angle, NULL, definition);
            CHECK(oclshade_set_knob(lib, "horizon", "group", 64));
            again = read_back(d_angle, 4 * m.n);
            if (memcmp(again, band, 4 * m.n) != 0) fail("horizon: group 16 differs");
            free(again);
        }
        if (horizon_max_distance > 0.0) {   /* within a radius, every azimuth: walked and swept give the same bits */
            static const struct { int cells, far; const char *what; } sweep[] = {
                {0, 0, "horizon: sweep_cells 0, sweep_far 0 (every azimuth walked) differs"},
                {256, 0, "horizon: sweep_cells 256 (every azimuth swept) differs"},
                {0, 2, "horizon: sweep_cells 0, sweep_far 2 (every azimuth swept) differs"}};
            int default_cells = 0, default_far = 0;
            CHECK(oclshade_get_knob(lib, "horizon", "sweep_cells", &default_cells));
            CHECK(oclshade_get_knob(lib, "horizon", "sweep_far", &default_far));
            for (size_t i = 0; i < sizeof sweep / sizeof sweep[0]; ++i) {
                CHECK(oclshade_set_knob(lib, "horizon", "sweep_cells", sweep[i].cells));
                CHECK(oclshade_set_knob(lib, "horizon", "sweep_far", sweep[i].far));
                horizon_band(&m, dx, dy, curvature, 360.0 * k / n, &angle, NULL, definition);
                void *again = read_back(d_angle, 4 * m.n);
                if (memcmp(again, band, 4 * m.n) != 0) {
                    fprintf(stderr, "azimuth %g: ", 360.0 * k / n);
                    fail(sweep[i].what);
                }
                free(again);
            }
            /* and swept at every lanes knob (a last column band narrower than the lanes: the last
             * run takes the ray of the block of the columns it writes) */
            static const int lanes[] = {1, 4, 8, 16};
            int default_lanes = 0;
            CHECK(oclshade_get_knob(lib, "horizon", "lanes", &default_lanes));
            CHECK(oclshade_set_knob(lib, "horizon", "sweep_far", 2));
            for (size_t i = 0; i < sizeof lanes / sizeof lanes[0]; ++i) {
                CHECK(oclshade_set_knob(lib, "horizon", "lanes", lanes[i]));
                horizon_band(&m, dx, dy, curvature, 360.0 * k / n, &angle, NULL, definition);
                void *again = read_back(d_angle, 4 * m.n);
                if (memcmp(again, band, 4 * m.n) != 0) {
                    fprintf(stderr, "azimuth %g, lanes %d: ", 360.0 * k / n, lanes[i]);
                    fail("horizon: the sweep at another lanes knob differs");
                }
                free(again);
            }
            CHECK(oclshade_set_knob(lib, "horizon", "lanes", default_lanes));
            CHECK(oclshade_set_knob(lib, "horizon", "sweep_cells", default_cells));
            CHECK(oclshade_set_knob(lib, "horizon", "sweep_far", default_far));
        }
        free(band);
    }
    void *svf = read_back(d_svf, 8 * m.n);
    write_file("svf.f32", svf, 8 * m.n);
    if (horizon_max_distance == 0.0 && n > 0) check_horizon_batches(&m, dx, dy, curvature, n, definition, bands, svf);
    free(svf);
    free(bands);
    free(row_scales);
    horizon_row_scales = NULL;
    release(d_angle); release(d_svf);
    free_map(&m);
}

/* sun_disc OUTDIR HEIGHTS.f64 ROWS COLS DX DY AZ EL RADIUS COLUMNS CURVATURE MAX_DISTANCE: soft shadows
 * (oclshade_sun_disc) into fraction.f32; checks itself that each strip's clamped angles from
 * oclshade_sun_disc_strips and oclshade_enqueue_horizon (clamped), summed here, give the same bits. */
static void run_sun_disc(int argc, char **argv)
{
    if (argc != 11)
        fail("usage: host_passes sun_disc OUTDIR HEIGHTS.f64 ROWS COLS DX DY AZ EL RADIUS COLUMNS CURVATURE MAX_DISTANCE");
    map m;
    load_map(&m, argv[0], atoi(argv[1]), atoi(argv[2]));
    oclshade_sun_disc_params p;
    oclshade_sun_disc_params_init(&p);
    p.heights = oclshade_field_of(m.heights);
    p.rows = m.rows; p.cols = m.cols; p.dx = atof(argv[3]); p.dy = atof(argv[4]);
    p.pyramid = m.pyramid; p.offsets = m.offsets;
    p.azimuth = atof(argv[5]); p.elevation = atof(argv[6]); p.radius = atof(argv[7]); p.columns = atoi(argv[8]);
    p.curvature = atof(argv[9]); p.max_distance = atof(argv[10]);
    cl_mem d_strip = buffer(4 * m.n, NULL);
    p.angle = oclshade_field_of(d_strip);
    p.work = (double *)xmalloc(sizeof(double) * m.n);
    size_t disc_bytes = 0;
    CHECK(oclshade_sun_disc_scratch_size(lib, &p, &disc_bytes));
    p.scratch = scratch_of(disc_bytes);
    float *fraction = (float *)xmalloc(4 * m.n);
    CHECK(oclshade_sun_disc(lib, queue, &p, fraction));
    write_file("fraction.f32", fraction, 4 * m.n);
    {   /* through a pitched angle field at an offset: the same bits */
        const size_t row = 4 * (size_t)m.cols;
        float *zeros = (float *)xmalloc(4 * m.n), *again = (float *)xmalloc(4 * m.n);
        memset(zeros, 0, 4 * m.n);
        p.angle = pitched_copy(zeros, m.rows, row, 256, row + 68);
        cl_mem packed_scratch = p.scratch;
        CHECK(oclshade_sun_disc_scratch_size(lib, &p, &disc_bytes));   /* (room for a packed copy) */
        p.scratch = scratch_of(disc_bytes);
        CHECK(oclshade_sun_disc(lib, queue, &p, again));
        if (p.scratch) release(p.scratch);
        p.scratch = packed_scratch;
        if (memcmp(again, fraction, 4 * m.n) != 0) fail("sun_disc: a pitched angle field differs");
        free(read_pitched(&p.angle, m.rows, row));     /* (checks the gaps kept their bytes) */
        release(p.angle.buffer);
        free(zeros); free(again);
    }
    /* the same from the parts: the strips, each one's clamped angles, the sum */
    const int columns = p.columns ? p.columns : 16;
    double *az = (double *)xmalloc(sizeof(double) * (size_t)columns), *c = (double *)xmalloc(sizeof(double) * (size_t)columns);
    double (*bounds)[2] = (double (*)[2])xmalloc(sizeof(double) * 2 * (size_t)columns);
    CHECK(oclshade_sun_disc_strips(p.azimuth, p.elevation, p.radius ? p.radius : 0.2666, columns, az, c, bounds));
    cl_mem d_angle = buffer(4 * m.n, NULL);
    double *seen = (double *)xmalloc(sizeof(double) * m.n), whole = 0.0;
    for (int k = 0; k < columns; ++k) {
        oclshade_horizon_params h;
        oclshade_horizon_params_init(&h);
        h.heights = p.heights; h.rows = m.rows; h.cols = m.cols; h.dx = p.dx; h.dy = p.dy;
        h.pyramid = m.pyramid; h.offsets = m.offsets; h.curvature = p.curvature; h.max_distance = p.max_distance;
        h.angle = oclshade_field_of(d_angle);
        h.azimuth = az[k];
        h.clamped = 1;
        h.clamp_bounds[0] = bounds[k][0];
        h.clamp_bounds[1] = bounds[k][1];
        size_t bytes = 0;
        CHECK(oclshade_horizon_scratch_size(lib, &h, &bytes));
        h.scratch = scratch_of(bytes);
        CHECK(oclshade_enqueue_horizon(lib, queue, &h, 0, NULL, NULL));
        float *angles = (float *)read_back(d_angle, 4 * m.n);
        for (size_t i = 0; i < m.n; ++i) {
            double v = (p.elevation + c[k]) - (double)angles[i];
            if (!isnan(v)) v = v < 0.0 ? 0.0 : (v > 2.0 * c[k] ? 2.0 * c[k] : v);
            seen[i] = k ? seen[i] + v : v;
        }
        whole += 2.0 * c[k];
        free(angles);
        if (h.scratch) release(h.scratch);
    }
    for (size_t i = 0; i < m.n; ++i) {
        const float f = (float)(seen[i] / whole);
        if (memcmp(&f, &fraction[i], 4) != 0) fail("sun_disc: the parts' sum differs from oclshade_sun_disc");
    }
    free(seen); free(az); free(c); free(bounds); free(fraction); free(p.work);
    release(d_angle); release(d_strip);
    if (p.scratch) release(p.scratch);
    free_map(&m);
}

typedef struct sunshine_sums { cl_mem sun, cast, beam; } sunshine_sums;

static void zero_sums(const map *m, sunshine_sums *s)
{
    s->sun = buffer(4 * m->n, NULL); s->cast = buffer(4 * m->n, NULL); s->beam = buffer(8 * m->n, NULL);
    CHECK(oclshade_enqueue_zero(lib, queue, s->sun, 4 * m->n, 0, NULL, NULL));
    CHECK(oclshade_enqueue_zero(lib, queue, s->cast, 4 * m->n, 0, NULL, NULL));
    CHECK(oclshade_enqueue_zero(lib, queue, s->beam, 8 * m->n, 0, NULL, NULL));
}

/* One sun into the sums: cast flags from `mask` (a field) or from the bands (low, high). */
static void add_sun(const map *m, const oclshade_field *heights, double dx, double dy, double az, double el,
                    unsigned seconds, const oclshade_field *mask, cl_mem low, cl_mem high, double fraction,
                    const sunshine_sums *s)
{
    oclshade_sunshine_params p;
    oclshade_sunshine_params_init(&p);
    p.heights = *heights;
    p.rows = m->rows; p.cols = m->cols; p.dx = dx; p.dy = dy;
    p.azimuth = az; p.elevation = el; p.seconds = seconds;
    if (mask) p.mask = *mask;
    p.low = oclshade_field_of(low);
    p.high = oclshade_field_of(high);
    p.fraction = fraction;
    p.sun = s->sun; p.cast = s->cast; p.beam = s->beam;
    size_t bytes = 0;
    CHECK(oclshade_sunshine_scratch_size(lib, &p, &bytes));
    p.scratch = scratch_of(bytes);
    CHECK(oclshade_enqueue_sunshine(lib, queue, &p, 0, NULL, NULL));
    CLCHECK(clFinish(queue));
    release(p.scratch);
}

/* The masks route (SunshineCaster._by_masks): each sun's exact mask by the shadow pass, then
 * sunshine_masks; heights given as `heights` (packed or pitched). */
static void sunshine_by_masks(const map *m, const oclshade_field *heights, double dx, double dy, int nsuns,
                              char **suns, sunshine_sums *s)
{
    cl_mem d_mask = buffer(m->n, NULL);
    zero_sums(m, s);
    for (int k = 0; k < nsuns; ++k) {
        double az, el;
        unsigned seconds;
        if (sscanf(suns[k], "%lf,%lf,%u", &az, &el, &seconds) != 3) fail("bad sun (AZ,EL,SECONDS)");
        oclshade_shadow_params p;
        oclshade_shadow_params_init(&p);
        p.heights = *heights;
        p.rows = m->rows; p.cols = m->cols; p.dx = dx; p.dy = dy;
        p.pyramid = m->pyramid; p.offsets = m->offsets;
        p.azimuth = az; p.elevation = el;
        p.mask = oclshade_field_of(d_mask);
        size_t bytes = 0;
        CHECK(oclshade_shadows_scratch_size(lib, &p, &bytes));
        p.scratch = scratch_of(bytes);
        CHECK(oclshade_enqueue_shadows(lib, queue, &p, 0, NULL, NULL));
        const oclshade_field mask = oclshade_field_of(d_mask);
        add_sun(m, heights, dx, dy, az, el, seconds, &mask, NULL, NULL, 0.0, s);
        release(p.scratch);
    }
    release(d_mask);
}

/* The horizon route (SunshineCaster._by_horizons): every sun between the bands of the grid
 * azimuths around it (here all n bands are computed first). */
static void sunshine_by_horizons(const map *m, double dx, double dy, int n, int nsuns, char **suns, sunshine_sums *s)
{
    cl_mem *bands = (cl_mem *)xmalloc(sizeof(cl_mem) * (size_t)n);
    for (int k = 0; k < n; ++k) {
        bands[k] = buffer(4 * m->n, NULL);
        oclshade_field angle = oclshade_field_of(bands[k]);
        horizon_band(m, dx, dy, 0.0, 360.0 * k / n, &angle, NULL, 1);
    }
    zero_sums(m, s);
    const oclshade_field heights = oclshade_field_of(m->heights);
    for (int k = 0; k < nsuns; ++k) {
        double az, el;
        unsigned seconds;
        if (sscanf(suns[k], "%lf,%lf,%u", &az, &el, &seconds) != 3) fail("bad sun (AZ,EL,SECONDS)");
        double a = fmod(az, 360.0);   /* Python's az % 360 (a tiny negative azimuth aside) */
        if (a < 0.0) a += 360.0;
        const double position = a * n / 360.0;
        int i = (int)floor(position);
        if (i > n - 1) i = n - 1;
        add_sun(m, &heights, dx, dy, az, el, seconds, NULL, bands[i], bands[(i + 1) % n], position - i, s);
    }
    for (int k = 0; k < n; ++k) release(bands[k]);
    free(bands);
}

static void write_sums(const map *m, const sunshine_sums *s, const char *prefix)
{
    char name[64];
    const struct { cl_mem mem; const char *ext; size_t size; } out[3] = {
        {s->sun, "sun.u32", 4}, {s->cast, "cast.u32", 4}, {s->beam, "beam.f32", 8}};
    for (int i = 0; i < 3; ++i) {
        void *data = read_back(out[i].mem, out[i].size * m->n);
        snprintf(name, sizeof name, "%s%s", prefix, out[i].ext);
        write_file(name, data, out[i].size * m->n);
        free(data);
    }
}

static void release_sums(sunshine_sums *s) { release(s->sun); release(s->cast); release(s->beam); }

static void run_sunshine(int argc, char **argv)
{
    if (argc < 6) fail("usage: host_passes sunshine OUTDIR HEIGHTS.f64 ROWS COLS DX DY N AZ,EL,SECONDS...");
    map m;
    load_map(&m, argv[0], atoi(argv[1]), atoi(argv[2]));
    const double dx = atof(argv[3]), dy = atof(argv[4]);
    const int n = atoi(argv[5]);
    sunshine_sums s;
    if (n == 0) {
        const oclshade_field packed = oclshade_field_of(m.heights);
        sunshine_by_masks(&m, &packed, dx, dy, argc - 6, argv + 6, &s);
        write_sums(&m, &s, "");
        /* heights as a pitched field at an offset give the same sums */
        sunshine_sums again;
        const size_t row = 4 * (size_t)m.cols;
        oclshade_field pitched = pitched_copy(m.rel, m.rows, row, 512, row + 20);
        sunshine_by_masks(&m, &pitched, dx, dy, argc - 6, argv + 6, &again);
        write_sums(&m, &again, "pitched_");
        release_sums(&again);
        release(pitched.buffer);
    } else {
        sunshine_by_horizons(&m, dx, dy, n, argc - 6, argv + 6, &s);
        write_sums(&m, &s, "");
    }
    release_sums(&s);
    free_map(&m);
}

/* ------------------------------------------------------------------ environment maps */

static void run_envmap(int argc, char **argv)
{
    if (argc != 7) fail("usage: host_passes envmap OUTDIR LATLONG.f32 H W N OH OW FACES.f32");
    const int h = atoi(argv[1]), w = atoi(argv[2]), n = atoi(argv[3]), oh = atoi(argv[4]), ow = atoi(argv[5]);
    const size_t cube_bytes = 16 * 6 * (size_t)(n + 2) * (size_t)(n + 2), in_row = 16 * (size_t)w, out_row = 16 * (size_t)ow;
    float *ll = (float *)read_file(NULL, argv[0], in_row * (size_t)h, 0);
    float *faces = (float *)read_file(NULL, argv[6], cube_bytes, 0);
    oclshade_envmap_params p;
    oclshade_envmap_params_init(&p);
    p.face = n;
    /* the border of given faces */
    p.cube = buffer(cube_bytes, faces);
    CHECK(oclshade_enqueue_cube_border(lib, queue, &p, 0, NULL, NULL));
    void *bordered = read_back(p.cube, cube_bytes);
    write_file("border.f32", bordered, cube_bytes);
    free(bordered);
    release(p.cube);
    /* lat-long -> cube -> lat-long, packed fields and then pitched ones at offsets */
    void *first_cube = NULL, *first_ll = NULL;
    for (int pitched = 0; pitched < 2; ++pitched) {
        p.cube = buffer(cube_bytes, NULL);
        p.height = h; p.width = w;
        p.latlong = pitched ? pitched_copy(ll, h, in_row, 64, in_row + 48) : oclshade_field_of(buffer(in_row * (size_t)h, ll));
        size_t bytes = 0;
        CHECK(oclshade_envmap_scratch_size(lib, &p, &bytes));
        if ((bytes != 0) != pitched) fail("envmap: scratch only for a pitched lat-long map");
        p.scratch = scratch_of(bytes);
        CHECK(oclshade_enqueue_latlong_to_cube(lib, queue, &p, 0, NULL, NULL));
        release(p.latlong.buffer); release(p.scratch);
        void *cube = read_back(p.cube, cube_bytes);
        p.height = oh; p.width = ow;
        void *zero = xmalloc(out_row * (size_t)oh);
        p.latlong = pitched ? pitched_copy(zero, oh, out_row, 32, out_row + 16) : oclshade_field_of(buffer(out_row * (size_t)oh, NULL));
        free(zero);
        CHECK(oclshade_envmap_scratch_size(lib, &p, &bytes));
        p.scratch = scratch_of(bytes);
        CHECK(oclshade_enqueue_cube_to_latlong(lib, queue, &p, 0, NULL, NULL));
        void *out = pitched ? read_pitched(&p.latlong, oh, out_row) : read_back(p.latlong.buffer, out_row * (size_t)oh);
        release(p.latlong.buffer); release(p.scratch); release(p.cube);
        if (!pitched) {
            write_file("cube.f32", cube, cube_bytes);
            write_file("latlong.f32", out, out_row * (size_t)oh);
            first_cube = cube;
            first_ll = out;
        } else {
            if (memcmp(cube, first_cube, cube_bytes) != 0) fail("envmap: a pitched lat-long input gives another cube");
            if (memcmp(out, first_ll, out_row * (size_t)oh) != 0) fail("envmap: a pitched lat-long output differs");
            free(cube); free(out);
        }
    }
    free(first_cube); free(first_ll); free(ll); free(faces);
}

/* Face FACE of a cube of N x N faces from FRAME.f32 (N x N float4), into a cube buffer filled
 * with NaN: cube_face_store alone (face.f32), then with a pitched frame (the same bytes). */
static void run_face_store(int argc, char **argv)
{
    if (argc != 3) fail("usage: host_passes face_store OUTDIR FRAME.f32 N FACE");
    const int n = atoi(argv[1]);
    const size_t row = 16 * (size_t)n, cube_bytes = 16 * 6 * (size_t)(n + 2) * (size_t)(n + 2);
    float *frame = (float *)read_file(NULL, argv[0], row * (size_t)n, 0);
    float *nan = (float *)xmalloc(cube_bytes);
    for (size_t i = 0; i < cube_bytes / 4; ++i) nan[i] = NAN;
    void *first = NULL;
    for (int pitched = 0; pitched < 2; ++pitched) {
        oclshade_envmap_params p;
        oclshade_envmap_params_init(&p);
        p.face = n;
        p.face_index = atoi(argv[2]);
        p.cube = buffer(cube_bytes, nan);
        p.frame = pitched ? pitched_copy(frame, n, row, 64, row + 32) : oclshade_field_of(buffer(row * (size_t)n, frame));
        size_t bytes = 0;
        CHECK(oclshade_envmap_scratch_size(lib, &p, &bytes));
        if ((bytes != 0) != pitched) fail("face_store: scratch only for a pitched frame");
        p.scratch = scratch_of(bytes);
        CHECK(oclshade_enqueue_cube_face_store(lib, queue, &p, 0, NULL, NULL));
        void *cube = read_back(p.cube, cube_bytes);
        release(p.frame.buffer); release(p.scratch); release(p.cube);
        if (!pitched) {
            write_file("face.f32", cube, cube_bytes);
            first = cube;
        } else {
            if (memcmp(cube, first, cube_bytes) != 0) fail("face_store: a pitched frame gives another cube");
            free(cube);
        }
    }
    free(first); free(frame); free(nan);
}

/* ------------------------------------------------------------------ main */

int main(int argc, char **argv)
{
    if (argc < 3) fail("usage: host_passes COMMAND OUTDIR ARGS...");
    outdir = argv[2];
    cl_platform_id platform;
    cl_int err;
    CLCHECK(clGetPlatformIDs(1, &platform, NULL));
    CLCHECK(clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &device, NULL));
    ctx = clCreateContext(NULL, 1, &device, NULL, NULL, &err);
    CLCHECK(err);
    queue = clCreateCommandQueue(ctx, device, 0, &err);
    CLCHECK(err);
    CHECK(oclshade_create(ctx, device, NULL, &lib));
    if (strcmp(argv[1], "mip") == 0) run_mip(argc - 3, argv + 3);
    else if (strcmp(argv[1], "tables") == 0) run_tables();
    else if (strcmp(argv[1], "ssao") == 0) run_ssao(argc - 3, argv + 3);
    else if (strcmp(argv[1], "terrain") == 0) run_terrain(argc - 3, argv + 3);
    else if (strcmp(argv[1], "pixels") == 0) run_pixels(argc - 3, argv + 3);
    else if (strcmp(argv[1], "compose") == 0) run_compose(argc - 3, argv + 3);
    else if (strcmp(argv[1], "horizon") == 0) run_horizon(argc - 3, argv + 3);
    else if (strcmp(argv[1], "sunshine") == 0) run_sunshine(argc - 3, argv + 3);
    else if (strcmp(argv[1], "sun_disc") == 0) run_sun_disc(argc - 3, argv + 3);
    else if (strcmp(argv[1], "envmap") == 0) run_envmap(argc - 3, argv + 3);
    else if (strcmp(argv[1], "face_store") == 0) run_face_store(argc - 3, argv + 3);
    else fail("unknown command");
    oclshade_destroy(lib);
    clReleaseCommandQueue(queue);
    clReleaseContext(ctx);
    printf("ok\n");
    return 0;
}
