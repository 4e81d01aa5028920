/* render_frame — a whole terrain frame with the C host API on the caller's queue: terrain
 * G-buffer, smooth shading normals, per-pixel cast shadows, SSAO, compose, written as a PNG.
 * The pixels are those of `oclshade render` with the same camera, sun and settings.
 *
 * usage: render_frame HEIGHTS.f64 ROWS COLS DX DY OUT.png --camera X,Y,Z,TX,TY,TZ [options]
 *   HEIGHTS.f64   ROWS x COLS float64, row-major, row 0 north; NaN = nodata
 *   DX DY         cell sizes east-west and north-south, metres
 *   --camera X,Y,Z,TX,TY,TZ  position and target in metres: x east of the first column,
 *                 y north of the first row (the map lies at y <= 0), z up
 *   --size WxH    frame size (default 1280x720)     --fov DEG   vertical field of view (45)
 *   --sun AZ,EL   sun, degrees (default 315,45)      --radius R  the map on a sphere of radius R
 *   --method bisect|march|dda          ray caster (default bisect)
 *   --shadow-method exact|paper|maxmip|dda   per-pixel shadows (default exact); --no-shadows
 *   --ao CELLS    SSAO of radius CELLS cells (off by default); --ao-samples M (default 8)
 *   --ssaa N      N x N samples per pixel, box-filtered (default 1)
 * As `oclshade render`: near 1e-4 and far 1 times |position - target| + 2 hypot(map extent);
 * every pass runs on the supersampled frame; shadows are the sun's visibility (eq. (1) with
 * k 0: the sky lights the shadows); AO is the library default (rays, range check, box 3).
 * Uses the first device of the first OpenCL platform.  Needs zlib (the PNG). */
#include "oclshade.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#define TRY(call)                                                                                 \
    do {                                                                                          \
        oclshade_status st_ = (call);                                                             \
        if (st_ != OCLSHADE_OK) {                                                                 \
            fprintf(stderr, "%s: %s\n", oclshade_status_name(st_), oclshade_last_error(lib));     \
            exit(1);                                                                              \
        }                                                                                         \
    } while (0)

static oclshade *lib;
static cl_context ctx;

static void die(const char *what)
{
    fprintf(stderr, "render_frame: %s\n", what);
    exit(1);
}

static cl_mem device_buffer(size_t bytes, const void *host)
{
    cl_int err;
    cl_mem m = clCreateBuffer(ctx, CL_MEM_READ_WRITE | (host ? CL_MEM_COPY_HOST_PTR : 0), bytes ? bytes : 1,
                              (void *)host, &err);
    if (err != CL_SUCCESS) die("clCreateBuffer failed");
    return m;
}

/* ------------------------------------------------------------------ PNG */

static void put32(unsigned char *p, unsigned long v)
{
    p[0] = (unsigned char)(v >> 24); p[1] = (unsigned char)(v >> 16); p[2] = (unsigned char)(v >> 8); p[3] = (unsigned char)v;
}

static void chunk(FILE *f, const char *type, const unsigned char *data, unsigned long n)
{
    unsigned char head[8], tail[4];
    put32(head, n);
    memcpy(head + 4, type, 4);
    unsigned long crc = crc32(0L, (const Bytef *)type, 4);
    if (n) crc = crc32(crc, data, (uInt)n);
    put32(tail, crc);
    fwrite(head, 1, 8, f);
    if (n) fwrite(data, 1, n, f);
    fwrite(tail, 1, 4, f);
}

/* An 8-bit RGB PNG of the RGBA pixels (alpha dropped), each row with filter 0. */
static void write_png(const char *path, const unsigned char *rgba, int width, int height)
{
    const size_t row = 1 + 3 * (size_t)width, raw_size = row * (size_t)height;
    unsigned char *raw = (unsigned char *)malloc(raw_size);
    uLongf packed_size = compressBound((uLong)raw_size);
    unsigned char *packed = (unsigned char *)malloc(packed_size);
    if (raw == NULL || packed == NULL) die("out of memory");
    for (int y = 0; y < height; ++y) {
        raw[(size_t)y * row] = 0;
        for (int x = 0; x < width; ++x)
            memcpy(raw + (size_t)y * row + 1 + 3 * (size_t)x, rgba + 4 * ((size_t)y * (size_t)width + (size_t)x), 3);
    }
    if (compress2(packed, &packed_size, raw, (uLong)raw_size, Z_DEFAULT_COMPRESSION) != Z_OK) die("zlib compress failed");
    unsigned char ihdr[13] = {0};
    put32(ihdr, (unsigned long)width);
    put32(ihdr + 4, (unsigned long)height);
    ihdr[8] = 8;   /* bits per channel */
    ihdr[9] = 2;   /* RGB */
    FILE *f = fopen(path, "wb");
    if (f == NULL) die("cannot open the output PNG");
    fwrite("\x89PNG\r\n\x1a\n", 1, 8, f);
    chunk(f, "IHDR", ihdr, 13);
    chunk(f, "IDAT", packed, packed_size);
    chunk(f, "IEND", NULL, 0);
    if (ferror(f) || fclose(f) != 0) die("cannot write the output PNG");
    free(raw);
    free(packed);
}

/* ------------------------------------------------------------------ options */

typedef struct options {
    int width, height, ssaa, shadows, ao_samples;
    double camera[6], fov, azimuth, elevation, radius, ao_cells;
    oclshade_caster caster;
    oclshade_method shadow_method;
} options;

static int pick(const char *value, const char *const *names, int count, const char *what)
{
    for (int i = 0; i < count; ++i)
        if (strcmp(value, names[i]) == 0) return i + 1;
    fprintf(stderr, "render_frame: %s must be one of", what);
    for (int i = 0; i < count; ++i) fprintf(stderr, " %s", names[i]);
    fprintf(stderr, ", got %s\n", value);
    exit(2);
}

static void parse(int argc, char **argv, options *o)
{
    static const char *const casters[] = {"bisect", "march", "dda"};
    static const char *const methods[] = {"exact", "paper", "maxmip", "dda"};
    int have_camera = 0;
    o->width = 1280; o->height = 720; o->ssaa = 1; o->shadows = 1; o->ao_samples = 8;
    o->fov = 45.0; o->azimuth = 315.0; o->elevation = 45.0; o->radius = 0.0; o->ao_cells = 0.0;
    o->caster = OCLSHADE_CAST_BISECT;
    o->shadow_method = OCLSHADE_EXACT;
    for (int i = 0; i < argc; ++i) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        int used = 1, ok = 1;
        if (strcmp(a, "--camera") == 0) {
            ok = sscanf(v, "%lf,%lf,%lf,%lf,%lf,%lf", &o->camera[0], &o->camera[1], &o->camera[2], &o->camera[3],
                        &o->camera[4], &o->camera[5]) == 6;
            have_camera = 1;
        } else if (strcmp(a, "--size") == 0) ok = sscanf(v, "%dx%d", &o->width, &o->height) == 2;
        else if (strcmp(a, "--fov") == 0) o->fov = strtod(v, NULL);
        else if (strcmp(a, "--sun") == 0) ok = sscanf(v, "%lf,%lf", &o->azimuth, &o->elevation) == 2;
        else if (strcmp(a, "--radius") == 0) o->radius = strtod(v, NULL);
        else if (strcmp(a, "--method") == 0) o->caster = (oclshade_caster)pick(v, casters, 3, "--method");
        else if (strcmp(a, "--shadow-method") == 0) o->shadow_method = (oclshade_method)pick(v, methods, 4, "--shadow-method");
        else if (strcmp(a, "--ao") == 0) o->ao_cells = strtod(v, NULL);
        else if (strcmp(a, "--ao-samples") == 0) o->ao_samples = atoi(v);
        else if (strcmp(a, "--ssaa") == 0) o->ssaa = atoi(v);
        else if (strcmp(a, "--no-shadows") == 0) { o->shadows = 0; used = 0; }
        else { fprintf(stderr, "render_frame: unknown option %s\n", a); exit(2); }
        if (!ok) { fprintf(stderr, "render_frame: bad value for %s: %s\n", a, v); exit(2); }
        i += used;
    }
    if (!have_camera) die("--camera X,Y,Z,TX,TY,TZ is required");
}

/* ------------------------------------------------------------------ the frame */

static size_t larger(size_t a, size_t b) { return a > b ? a : b; }

int main(int argc, char **argv)
{
    if (argc < 7) {
        fprintf(stderr, "usage: %s HEIGHTS.f64 ROWS COLS DX DY OUT.png --camera X,Y,Z,TX,TY,TZ [--size WxH] [--fov DEG] "
                        "[--sun AZ,EL] [--radius R] [--method M] [--shadow-method M] [--no-shadows] [--ao CELLS] "
                        "[--ao-samples M] [--ssaa N]\n", argv[0]);
        return 2;
    }
    const int rows = atoi(argv[2]), cols = atoi(argv[3]);
    const double dx = strtod(argv[4], NULL), dy = strtod(argv[5], NULL);
    options o;
    parse(argc - 7, argv + 7, &o);
    if (rows < 1 || cols < 1) die("ROWS and COLS must be >= 1");
    const size_t n = (size_t)rows * (size_t)cols;
    double *heights = (double *)malloc(8 * n);
    float *rel = (float *)malloc(4 * n);
    FILE *f = fopen(argv[1], "rb");
    if (heights == NULL || rel == NULL || f == NULL || fread(heights, 8, n, f) != n) die("cannot read HEIGHTS");
    fclose(f);

    /* the caller's OpenCL objects: the library works on them */
    cl_platform_id platform;
    cl_device_id device;
    cl_int err;
    if (clGetPlatformIDs(1, &platform, NULL) != CL_SUCCESS ||
        clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &device, NULL) != CL_SUCCESS)
        die("no OpenCL device");
    ctx = clCreateContext(NULL, 1, &device, NULL, NULL, &err);
    cl_command_queue queue = clCreateCommandQueue(ctx, device, 0, &err);
    if (err != CL_SUCCESS) die("cannot create the context and queue");
    TRY(oclshade_create(ctx, device, NULL, &lib));

    /* the map: relative heights, extrema pyramid, dilated levels (once per map) */
    double offset;
    float hmin, hmax;
    TRY(oclshade_relative_heights(heights, n, rel, &offset));
    TRY(oclshade_height_range(rel, n, &hmin, &hmax));
    oclshade_pyramid_layout lay;
    oclshade_dilated_layout dil;
    TRY(oclshade_pyramid_layout_for(rows, cols, &lay));
    TRY(oclshade_dilated_layout_for(lib, rows, cols, &dil));
    cl_mem d_heights = device_buffer(4 * n, rel), d_pyramid = device_buffer(lay.pyramid_bytes, NULL);
    cl_mem d_offsets = device_buffer(lay.offsets_bytes, NULL), d_dilated = device_buffer(dil.bytes, NULL);
    cl_mem d_table = device_buffer(dil.table_bytes, NULL);
    const oclshade_field h = oclshade_field_of(d_heights);   /* packed at offset 0: read in place */
    TRY(oclshade_enqueue_extrema_pyramid(lib, queue, &h, rows, cols, d_pyramid, d_offsets, NULL, 0, NULL, NULL));
    TRY(oclshade_enqueue_dilated_levels(lib, queue, &h, rows, cols, d_pyramid, d_offsets, d_dilated, d_table, NULL,
                                        0, NULL, NULL));

    /* the camera as `oclshade render --camera` makes it, on the supersampled frame */
    const double *pos = o.camera, *target = o.camera + 3;
    const double span[3] = {pos[0] - target[0], pos[1] - target[1], pos[2] - target[2]};
    const double reach = sqrt(span[0] * span[0] + span[1] * span[1] + span[2] * span[2]) +
                         2.0 * hypot(cols * dx, rows * dy);
    const int sw = o.width * o.ssaa, sh = o.height * o.ssaa;
    oclshade_terrain_params tp;
    oclshade_terrain_params_init(&tp);
    TRY(oclshade_camera_look_at(pos, target, NULL, sw, sh, OCLSHADE_PERSPECTIVE, o.fov, 1.0, 1e-4 * reach, reach,
                                &tp.camera));
    const size_t samples = (size_t)sw * (size_t)sh;
    tp.heights = h; tp.rows = rows; tp.cols = cols; tp.dx = dx; tp.dy = dy;
    tp.offset = offset; tp.hmin = hmin; tp.hmax = hmax; tp.radius = o.radius;
    tp.pyramid = d_pyramid; tp.offsets = d_offsets; tp.dilated = d_dilated; tp.dilated_table = d_table;
    tp.method = o.caster;
    static const size_t field_bytes[6] = {16, 16, 8, 16, 4, 16};
    cl_mem gbuffer[6];
    oclshade_field *fields[6] = {&tp.gbuffer.position, &tp.gbuffer.normal, &tp.gbuffer.uv, &tp.gbuffer.uv_grad,
                                 &tp.gbuffer.depth, &tp.gbuffer.albedo};
    for (int i = 0; i < 6; ++i) *fields[i] = oclshade_field_of(gbuffer[i] = device_buffer(field_bytes[i] * samples, NULL));
    cl_mem d_normals = device_buffer(16 * samples, NULL);
    const oclshade_field normals = oclshade_field_of(d_normals);

    /* per-pixel shadows: the level-q grids from the mean mip pyramid (once per map) */
    oclshade_pixel_shadow_params pp;
    oclshade_pixel_shadow_params_init(&pp);
    cl_mem d_mip = NULL, d_coarse = NULL, d_coarse_offsets = NULL, d_shadow = NULL;
    if (o.shadows) {
        oclshade_mip_layout ml;
        oclshade_coarse_layout cl;
        TRY(oclshade_mip_layout_for(lib, rows, cols, &ml));
        TRY(oclshade_coarse_layout_for(rows, cols, &cl));
        d_mip = device_buffer(ml.bytes, NULL);
        TRY(oclshade_enqueue_mip_pyramid(lib, queue, &h, rows, cols, d_mip, NULL, 0, NULL, NULL));
        void *mip = malloc(ml.bytes ? ml.bytes : 1);
        float *grids = (float *)malloc(cl.grids_bytes);
        int *grid_offsets = (int *)malloc(cl.offsets_bytes);
        if (mip == NULL || grids == NULL || grid_offsets == NULL) die("out of memory");
        if (ml.bytes && clEnqueueReadBuffer(queue, d_mip, CL_TRUE, 0, ml.bytes, mip, 0, NULL, NULL) != CL_SUCCESS)
            die("cannot read the mip pyramid");
        TRY(oclshade_coarse_grids(rel, mip, &ml, rows, cols, grids, grid_offsets));
        d_coarse = device_buffer(cl.grids_bytes, grids);
        d_coarse_offsets = device_buffer(cl.offsets_bytes, grid_offsets);
        free(mip); free(grids); free(grid_offsets);
        d_shadow = device_buffer(4 * samples, NULL);
        pp.heights = h; pp.rows = rows; pp.cols = cols; pp.dx = dx; pp.dy = dy;
        pp.pyramid = d_pyramid; pp.offsets = d_offsets; pp.coarse = d_coarse; pp.coarse_offsets = d_coarse_offsets;
        pp.position = tp.gbuffer.position; pp.uv = tp.gbuffer.uv; pp.uv_grad = tp.gbuffer.uv_grad;
        pp.width = sw; pp.height = sh;
        pp.azimuth = o.azimuth; pp.elevation = o.elevation;
        pp.method = o.shadow_method;
        pp.k_dark = pp.k_bright = 0.0;   /* the sun's visibility: 0 in cast shadow */
        pp.coefficient = oclshade_field_of(d_shadow);
    }

    /* SSAO on the geometric normals */
    oclshade_ssao_params ap;
    oclshade_ssao_params_init(&ap);
    cl_mem d_ao = NULL;
    if (o.ao_cells > 0.0) {
        d_ao = device_buffer(4 * samples, NULL);
        ap.position = tp.gbuffer.position; ap.normal = tp.gbuffer.normal;
        ap.width = sw; ap.height = sh;
        memcpy(ap.projection, tp.camera.projection_matrix, sizeof ap.projection);
        ap.radius = o.ao_cells * (dx > dy ? dx : dy);
        ap.m = o.ao_samples;
        ap.ao = oclshade_field_of(d_ao);
    }

    /* compose, box-filtering the samples */
    oclshade_compose_params cp;
    oclshade_compose_params_init(&cp);
    cl_mem d_image = device_buffer(4u * (size_t)o.width * (size_t)o.height, NULL);
    cp.position = tp.gbuffer.position; cp.albedo = tp.gbuffer.albedo; cp.normal = normals;
    cp.shadow = oclshade_field_of(d_shadow);
    cp.ao = oclshade_field_of(d_ao);
    cp.width = o.width; cp.height = o.height; cp.ssaa = o.ssaa;
    oclshade_compose_set_camera(&cp, &tp.camera);
    cp.azimuth = o.azimuth; cp.elevation = o.elevation;
    cp.image = oclshade_field_of(d_image);

    /* one scratch buffer for every pass: they run one after another on the in-order queue */
    size_t need = 0, bytes;
    TRY(oclshade_terrain_scratch_size(lib, &tp, &bytes)); need = larger(need, bytes);
    TRY(oclshade_terrain_normals_scratch_size(lib, &tp, &normals, &bytes)); need = larger(need, bytes);
    if (o.shadows) { TRY(oclshade_pixel_shadows_scratch_size(lib, &pp, &bytes)); need = larger(need, bytes); }
    if (d_ao) { TRY(oclshade_ssao_scratch_size(lib, &ap, &bytes)); need = larger(need, bytes); }
    TRY(oclshade_compose_scratch_size(lib, &cp, &bytes)); need = larger(need, bytes);
    cl_mem scratch = need ? device_buffer(need, NULL) : NULL;
    tp.scratch = pp.scratch = ap.scratch = cp.scratch = scratch;

    TRY(oclshade_enqueue_terrain(lib, queue, &tp, 0, NULL, NULL));
    TRY(oclshade_enqueue_terrain_normals(lib, queue, &tp, &normals, 0, NULL, NULL));
    if (o.shadows) TRY(oclshade_enqueue_pixel_shadows(lib, queue, &pp, 0, NULL, NULL));
    if (d_ao) TRY(oclshade_enqueue_ssao(lib, queue, &ap, 0, NULL, NULL));
    TRY(oclshade_enqueue_compose(lib, queue, &cp, 0, NULL, NULL));
    unsigned char *image = (unsigned char *)malloc(4u * (size_t)o.width * (size_t)o.height);
    if (image == NULL ||
        clEnqueueReadBuffer(queue, d_image, CL_TRUE, 0, 4u * (size_t)o.width * (size_t)o.height, image, 0, NULL, NULL) != CL_SUCCESS)
        die("cannot read the frame");
    write_png(argv[6], image, o.width, o.height);
    printf("%s: %dx%d frame (%dx%d samples each) of a %dx%d map\n", argv[6], o.width, o.height, o.ssaa, o.ssaa, cols, rows);

    oclshade_destroy(lib);
    cl_mem all[] = {d_heights, d_pyramid, d_offsets, d_dilated, d_table, d_normals, d_mip, d_coarse,
                    d_coarse_offsets, d_shadow, d_ao, d_image, scratch};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; ++i)
        if (all[i]) clReleaseMemObject(all[i]);
    for (int i = 0; i < 6; ++i) clReleaseMemObject(gbuffer[i]);
    clReleaseCommandQueue(queue);
    clReleaseContext(ctx);
    free(heights); free(rel); free(image);
    return 0;
}
