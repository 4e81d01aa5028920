/* host_shadow_volumes.c — the C host's shadow volume entry points on inputs a Python test
 * writes (tests/test_host_shadow_volumes.py compares the outputs with MeshShadows', bit for bit).
 *
 *   host_shadow_volumes volumes OUTDIR INDIR
 *       INDIR/scene.txt (the camera line; elevation k_dark k_bright tile), frame.bin (written
 *       by oclshade.meshes.shadow_volumes.write_frame_tables), position.f32 (the G-buffer's
 *       view-space float4 per pixel), coef.f32: the tile counts of the first pass (counts.out),
 *       the mask (mask.out) and the coefficients after sv_apply (coef.out).  Checks itself
 *       that pitched fields at offsets give the same bits.
 *   host_shadow_volumes errors OUTDIR INDIR
 *       INDIR/frame.bin and damaged copies of it: the reader, the offsets helper and the
 *       argument and contract checks of the calls: "ok WHAT" or "FAIL WHAT: ..." per check.
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

static void *read_file(const char *dir, const char *name, size_t n)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "rb");
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

static void release(cl_mem m)
{
    if (m) clReleaseMemObject(m);
}

/* rows x row_bytes of packed host data as a field: packed at offset 0, or (pitched) at byte
 * 48 of a buffer with rows row_bytes + 32 apart */
static oclshade_field field_of(const void *packed, int rows, size_t row_bytes, int pitched)
{
    if (!pitched) return oclshade_field_of(buffer((size_t)rows * row_bytes, packed));
    const size_t pitch = row_bytes + 32, offset = 48;
    unsigned char *host = (unsigned char *)xmalloc(offset + (size_t)rows * pitch);
    memset(host, 0xAB, offset + (size_t)rows * pitch);
    for (int r = 0; r < rows; ++r)
        memcpy(host + offset + (size_t)r * pitch, (const unsigned char *)packed + (size_t)r * row_bytes, row_bytes);
    oclshade_field f = {buffer(offset + (size_t)rows * pitch, host), offset, pitch};
    free(host);
    return f;
}

static void *read_field(const oclshade_field *f, int rows, size_t row_bytes)
{
    unsigned char *out = (unsigned char *)xmalloc((size_t)rows * row_bytes);
    const size_t pitch = f->row_pitch ? f->row_pitch : row_bytes;
    for (int r = 0; r < rows; ++r)
        CLCHECK(clEnqueueReadBuffer(queue, f->buffer, CL_TRUE, f->offset + (size_t)r * pitch, row_bytes,
                                    out + (size_t)r * row_bytes, 0, NULL, NULL));
    return out;
}

/* The camera line: width height ortho fov ortho_height near far position(3) look_at(3). */
static void read_camera(FILE *f, oclshade_camera *cam)
{
    int w, h, ortho;
    double fov, oh, nr, fr, pos[3], at[3];
    if (fscanf(f, "%d %d %d %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf", &w, &h, &ortho, &fov, &oh, &nr, &fr, &pos[0],
               &pos[1], &pos[2], &at[0], &at[1], &at[2]) != 13)
        fail("camera line");
    CHECK(oclshade_camera_look_at(pos, at, NULL, w, h, ortho ? OCLSHADE_ORTHOGRAPHIC : OCLSHADE_PERSPECTIVE, fov, oh, nr,
                                  fr, cam));
}

static oclshade_shadow_volume_frame read_frame(const char *dir, const char *name)
{
    char path[4096], error[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    oclshade_shadow_volume_frame fr;
    if (oclshade_shadow_volume_frame_read(path, &fr, error, sizeof error) != OCLSHADE_OK) fail(error);
    return fr;
}

/* The frame's tables uploaded into p, with buffers for the tiles and planes. */
static void upload_frame(const oclshade_shadow_volume_frame *fr, oclshade_shadow_volume_params *p, int tiles)
{
    p->ntri = fr->ntri;
    p->vertices = fr->vertices;
    p->verts = buffer(16 * (size_t)fr->vertices, fr->verts);
    p->tris = buffer(16 * (size_t)fr->faces, fr->tris);
    p->max_depth = fr->max_depth;
    p->start_count = fr->start_count;
    p->start_height = fr->start_height;
    p->counts = buffer(4 * (size_t)tiles, NULL);
    p->offsets = buffer(4 * (size_t)tiles + 4, NULL);
    p->planes = buffer(64 * (size_t)fr->faces, NULL);
}

static void release_frame(oclshade_shadow_volume_params *p)
{
    cl_mem m[6] = {p->verts, p->tris, p->counts, p->offsets, p->planes, p->list};
    for (int i = 0; i < 6; ++i) release(m[i]);
}

/* ------------------------------------------------------------------ volumes */

static void run_volumes(int argc, char **argv)
{
    if (argc != 1) fail("usage: host_shadow_volumes volumes OUTDIR INDIR");
    const char *in = argv[0];
    char path[4096];
    snprintf(path, sizeof path, "%s/scene.txt", in);
    FILE *f = fopen(path, "r");
    if (f == NULL) fail(path);
    oclshade_shadow_volume_params p;
    oclshade_shadow_volume_params_init(&p);
    if (p.tile != 16) fail("params init: tile 16");
    read_camera(f, &p.camera);
    if (fscanf(f, "%lf %lf %lf %d", &p.elevation, &p.k_dark, &p.k_bright, &p.tile) != 4) fail("light line");
    fclose(f);
    const int W = p.camera.width, H = p.camera.height, n = W * H;
    const int tw = (W + p.tile - 1) / p.tile, th = (H + p.tile - 1) / p.tile, tiles = tw * th;
    oclshade_shadow_volume_frame fr = read_frame(in, "frame.bin");
    void *position = read_file(in, "position.f32", 16 * (size_t)n), *coef = read_file(in, "coef.f32", 4 * (size_t)n);
    cl_int *counts = (cl_int *)xmalloc(4 * (size_t)tiles), *offsets = (cl_int *)xmalloc(4 * (size_t)tiles + 4);
    void *first[2] = {NULL, NULL};
    for (int pitched = 0; pitched < 2; ++pitched) {
        upload_frame(&fr, &p, tiles);
        void *zero = xmalloc((size_t)n);
        memset(zero, 0x5A, (size_t)n);   /* every pixel must be written */
        p.mask = field_of(zero, H, (size_t)W, pitched);
        free(zero);
        p.position = field_of(position, H, 16 * (size_t)W, pitched);
        p.coefficient = field_of(coef, H, 4 * (size_t)W, pitched);
        cl_event ev[3];
        CHECK(oclshade_enqueue_shadow_volume_bin(lib, queue, &p, 0, NULL, &ev[0]));
        CLCHECK(clEnqueueReadBuffer(queue, p.counts, CL_TRUE, 0, 4 * (size_t)tiles, counts, 1, &ev[0], NULL));
        if (!pitched) write_file("counts.out", counts, 4 * (size_t)tiles);
        CHECK(oclshade_shadow_volume_offsets(counts, tiles, offsets));
        p.entries = offsets[tiles];
        p.list = buffer(4 * (size_t)(p.entries > 0 ? p.entries : 1), NULL);
        CLCHECK(clEnqueueWriteBuffer(queue, p.offsets, CL_TRUE, 0, 4 * (size_t)tiles + 4, offsets, 0, NULL, NULL));
        size_t bytes = 0;
        CHECK(oclshade_shadow_volume_scratch_size(lib, &p, &bytes));
        if ((bytes != 0) != pitched) fail("volumes: scratch only for pitched fields");
        p.scratch = bytes ? buffer(bytes, NULL) : NULL;
        CHECK(oclshade_enqueue_shadow_volume_mask(lib, queue, &p, 0, NULL, &ev[1]));
        CHECK(oclshade_enqueue_shadow_volume_apply(lib, queue, &p, 1, &ev[1], &ev[2]));
        CLCHECK(clWaitForEvents(1, &ev[2]));
        for (int e = 0; e < 3; ++e) clReleaseEvent(ev[e]);
        void *out[2] = {read_field(&p.mask, H, (size_t)W), read_field(&p.coefficient, H, 4 * (size_t)W)};
        for (int i = 0; i < 2; ++i) {
            if (!pitched) {
                first[i] = out[i];
            } else {
                if (memcmp(out[i], first[i], (i ? 4 : 1) * (size_t)n) != 0) fail("volumes: pitched fields give other bits");
                free(out[i]);
            }
        }
        release(p.mask.buffer); release(p.position.buffer); release(p.coefficient.buffer); release(p.scratch);
        release_frame(&p);
    }
    write_file("mask.out", first[0], (size_t)n);
    write_file("coef.out", first[1], 4 * (size_t)n);
    free(first[0]); free(first[1]); free(counts); free(offsets); free(position); free(coef);
    oclshade_shadow_volume_frame_free(&fr);
}

/* ------------------------------------------------------------------ argument and contract checks */

static int failures;

static void expect(int cond, const char *what)
{
    printf("%s %s\n", cond ? "ok" : "FAIL", what);
    failures += !cond;
}

/* st must be `want` and the calling thread's message must contain `needle` */
static void expect_status(oclshade_status st, oclshade_status want, const char *needle, const char *what)
{
    const char *msg = oclshade_last_error(lib);
    if (st == want && strstr(msg, needle) != NULL) {
        printf("ok %s\n", what);
    } else {
        printf("FAIL %s: got %s, want %s with \"%s\"; message: %.600s\n", what, oclshade_status_name(st),
               oclshade_status_name(want), needle, msg);
        ++failures;
    }
}

/* The reader fails on a damaged file with a message holding needle, the frame cleared. */
static void expect_read_error(const char *dir, const char *name, const char *needle)
{
    char path[4096], error[512], what[256];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    oclshade_shadow_volume_frame fr;
    memset(&fr, 0x5A, sizeof fr);
    const oclshade_status st = oclshade_shadow_volume_frame_read(path, &fr, error, sizeof error);
    snprintf(what, sizeof what, "read %s: \"%s\"", name, needle);
    const int cleared = fr.verts == NULL && fr.tris == NULL && fr.vertices == 0;
    if (st == OCLSHADE_INVALID_ARGUMENT && strstr(error, needle) != NULL && cleared) {
        printf("ok %s\n", what);
    } else {
        printf("FAIL %s: got %s, frame %s; message: %s\n", what, oclshade_status_name(st),
               cleared ? "cleared" : "not cleared", error);
        ++failures;
    }
}

static void run_errors(int argc, char **argv)
{
    if (argc != 1) fail("usage: host_shadow_volumes errors OUTDIR INDIR");
    const char *in = argv[0];
    expect_read_error(in, "missing.bin", "cannot be opened");
    expect_read_error(in, "magic.bin", "not a shadow volume frame file");
    expect_read_error(in, "short.bin", "shorter than its counts say");
    expect_read_error(in, "long.bin", "longer than its counts say");
    expect_read_error(in, "counts.bin", "must be >= 1");
    expect_read_error(in, "index.bin", "vertex index");
    expect_read_error(in, "kind.bin", "kind 2 must be 0 (side) or 1 (cap)");
    expect(oclshade_shadow_volume_frame_read(NULL, NULL, NULL, 0) == OCLSHADE_INVALID_ARGUMENT, "read: NULL out");
    oclshade_shadow_volume_frame_free(NULL);
    oclshade_shadow_volume_frame empty = read_frame(in, "empty.bin");
    expect(empty.ntri == 0 && empty.faces == 1, "read: a frame without volumes has ntri 0");
    oclshade_shadow_volume_frame_free(&empty);

    /* the offsets helper */
    const cl_int counts[3] = {2, 0, 5}, negative[2] = {1, -1}, huge[2] = {0x7fffffff, 1};
    cl_int offsets[4];
    expect(oclshade_shadow_volume_offsets(counts, 3, offsets) == OCLSHADE_OK && offsets[0] == 0 && offsets[1] == 2 &&
           offsets[2] == 2 && offsets[3] == 7, "offsets: exclusive prefix sums and the total");
    expect(oclshade_shadow_volume_offsets(negative, 2, offsets) == OCLSHADE_INVALID_ARGUMENT, "offsets: negative count");
    expect(oclshade_shadow_volume_offsets(huge, 2, offsets) == OCLSHADE_INVALID_ARGUMENT, "offsets: total over INT_MAX");
    expect(oclshade_shadow_volume_offsets(counts, 0, offsets) == OCLSHADE_INVALID_ARGUMENT, "offsets: no tile");
    expect(oclshade_shadow_volume_offsets(NULL, 3, offsets) == OCLSHADE_INVALID_ARGUMENT, "offsets: NULL counts");

    /* the calls */
    oclshade_shadow_volume_frame fr = read_frame(in, "frame.bin");
    const int W = 40, H = 24, n = W * H;
    oclshade_shadow_volume_params p;
    oclshade_shadow_volume_params_init(&p);
    const double eye[3] = {0, 0, 10}, at[3] = {0, 1, 0};
    CHECK(oclshade_camera_look_at(eye, at, NULL, W, H, OCLSHADE_PERSPECTIVE, 50.0, 10.0, 0.1, 1000.0, &p.camera));
    const int tiles = 3 * 2;
    upload_frame(&fr, &p, tiles);
    p.entries = 4;
    p.list = buffer(16, NULL);
    p.position = oclshade_field_of(buffer(16 * (size_t)n, NULL));
    p.mask = oclshade_field_of(buffer((size_t)n, NULL));
    p.coefficient = oclshade_field_of(buffer(4 * (size_t)n, NULL));
    size_t bytes = 1;
    expect_status(oclshade_shadow_volume_scratch_size(lib, &p, &bytes), OCLSHADE_OK, "", "scratch: packed fields");
    expect(bytes == 0, "scratch: none for packed fields");
    expect_status(oclshade_shadow_volume_scratch_size(lib, &p, NULL), OCLSHADE_INVALID_ARGUMENT, "bytes must not be NULL",
                  "scratch: NULL bytes");
    expect_status(oclshade_enqueue_shadow_volume_bin(lib, queue, NULL, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "params must point to oclshade_shadow_volume_params", "bin: NULL params");
    oclshade_shadow_volume_params q = p;
    q.camera.width = 0;
    expect_status(oclshade_enqueue_shadow_volume_mask(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "camera.width", "mask: width 0");
    q = p; q.tile = 0;
    expect_status(oclshade_enqueue_shadow_volume_bin(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "tile must be a tile side in pixels, 1..32768, got 0", "bin: tile 0");
    q = p; q.ntri = -1;
    expect_status(oclshade_enqueue_shadow_volume_bin(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "ntri must be >= 0", "bin: ntri -1");
    q = p; q.max_depth = NAN;
    expect_status(oclshade_enqueue_shadow_volume_bin(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "max_depth must be finite and >= 0", "bin: max_depth NaN");
    q = p; q.camera.sx = 0.0;
    expect_status(oclshade_enqueue_shadow_volume_bin(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "camera must come from oclshade_camera_look_at", "bin: camera sx 0");
    q = p; q.entries = -1;
    expect_status(oclshade_enqueue_shadow_volume_mask(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "entries must be offsets[TW * TH]", "mask: entries -1");
    q = p; q.start_height = INFINITY;
    expect_status(oclshade_enqueue_shadow_volume_mask(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "start_height must be finite", "mask: start_height inf");
    q = p; q.elevation = 95.0;
    expect_status(oclshade_enqueue_shadow_volume_apply(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "elevation in [-90, 90]", "apply: elevation 95");
    q = p; q.k_dark = 1.5;
    expect_status(oclshade_enqueue_shadow_volume_apply(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "k_dark and k_bright must be in [0, 1]", "apply: k_dark 1.5");
    /* buffers */
    cl_mem small = buffer(8, NULL);
    q = p; q.verts = small;
    expect_status(oclshade_enqueue_shadow_volume_bin(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "verts", "bin: verts too small");
    q = p; q.tris = NULL;
    expect_status(oclshade_enqueue_shadow_volume_bin(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "tris", "bin: tris NULL");
    q = p; q.counts = small;
    expect_status(oclshade_enqueue_shadow_volume_bin(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "counts", "bin: counts too small");
    q = p; q.offsets = small;
    expect_status(oclshade_enqueue_shadow_volume_mask(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "offsets", "mask: offsets too small");
    q = p; q.list = small;
    expect_status(oclshade_enqueue_shadow_volume_mask(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "list", "mask: list shorter than entries");
    q = p; q.planes = small;
    expect_status(oclshade_enqueue_shadow_volume_mask(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "planes", "mask: planes too small");
    q = p; q.mask.buffer = small;
    expect_status(oclshade_enqueue_shadow_volume_mask(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "mask", "mask: mask too small");
    q = p; q.position.row_pitch = 8;
    expect_status(oclshade_enqueue_shadow_volume_mask(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "position row_pitch", "mask: position pitch below a row");
    q = p; q.coefficient.buffer = small;
    expect_status(oclshade_enqueue_shadow_volume_apply(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "coefficient", "apply: coefficient too small");
    q = p; q.list = q.planes;
    expect_status(oclshade_enqueue_shadow_volume_mask(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "overlap", "mask: list and planes the same buffer");
    cl_mem wide = buffer((size_t)(W + 8) * H, NULL);
    q = p; q.mask = (oclshade_field){wide, 0, (size_t)W + 8};
    expect_status(oclshade_enqueue_shadow_volume_mask(lib, queue, &q, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "scratch", "mask: pitched mask without scratch");
    expect_status(oclshade_enqueue_shadow_volume_bin(lib, NULL, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "queue", "bin: NULL queue");
    expect_status(oclshade_enqueue_shadow_volume_bin(lib, queue, &p, 1, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "wait", "bin: wait list NULL with 1 event");
    /* good calls pass */
    cl_event ev;
    expect_status(oclshade_enqueue_shadow_volume_bin(lib, queue, &p, 0, NULL, &ev), OCLSHADE_OK, "", "bin: good call");
    CLCHECK(clWaitForEvents(1, &ev));
    clReleaseEvent(ev);
    p.ntri = 0;
    p.entries = 0;
    CLCHECK(clEnqueueFillBuffer(queue, p.offsets, &p.entries, 4, 0, 4 * (size_t)tiles + 4, 0, NULL, NULL));
    expect_status(oclshade_enqueue_shadow_volume_mask(lib, queue, &p, 0, NULL, &ev), OCLSHADE_OK, "",
                  "mask: no volume face");
    CLCHECK(clWaitForEvents(1, &ev));
    clReleaseEvent(ev);
    release(small); release(wide);
    release(p.position.buffer); release(p.mask.buffer); release(p.coefficient.buffer);
    release_frame(&p);
    oclshade_shadow_volume_frame_free(&fr);
}

int main(int argc, char **argv)
{
    if (argc < 3) fail("usage: host_shadow_volumes COMMAND OUTDIR ARGS...");
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
    if (strcmp(argv[1], "volumes") == 0) run_volumes(argc - 3, argv + 3);
    else if (strcmp(argv[1], "errors") == 0) run_errors(argc - 3, argv + 3);
    else fail("unknown command");
    oclshade_destroy(lib);
    clReleaseCommandQueue(queue);
    clReleaseContext(ctx);
    if (failures) {
        printf("%d failure(s)\n", failures);
        return 1;
    }
    printf("ok\n");
    return 0;
}
