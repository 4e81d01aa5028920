/* host_meshes.c — the C host's mesh entry points on inputs a Python test writes
 * (tests/test_host_meshes.py compares every output with the Python host's, bit for bit).
 *
 *   host_meshes meshes OUTDIR INDIR
 *       INDIR/scene.txt (camera, terrain, sun, light: see run_meshes), tables.bin (written by
 *       oclshade.meshes.tables.write_mesh_tables), heights.f64 (when the terrain has rows),
 *       the G-buffer to merge into (dst_*.bin), shading.f32, coef.f32: the camera and light
 *       tables (mf.f32, light.f32), the cast (obj_*.bin), the merged G-buffer (mrg_*.bin),
 *       the shading normals (shading.out), the coefficients after the terrain's shadows on
 *       mesh pixels (coef_terrain.out), the shadow rays (hidden.out) and the coefficients
 *       after mesh_shadow_apply (coef.out).  Checks itself that pitched fields at offsets
 *       give the same bits.
 *   host_meshes errors OUTDIR INDIR
 *       INDIR/tables.bin and damaged copies of it (short.bin, magic.bin, index.bin, deep.bin):
 *       the argument and contract checks of the mesh entry points, host helpers and the
 *       tables reader: "ok WHAT" or "FAIL WHAT: ..." per check; fails when one fails.
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
static void read_camera(FILE *f, oclshade_camera *cam, double pos[3])
{
    int w, h, ortho;
    double fov, oh, nr, fr, at[3];
    if (fscanf(f, "%d %d %d %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf", &w, &h, &ortho, &fov, &oh, &nr, &fr, &pos[0],
               &pos[1], &pos[2], &at[0], &at[1], &at[2]) != 13)
        fail("camera line");
    CHECK(oclshade_camera_look_at(pos, at, NULL, w, h, ortho ? OCLSHADE_ORTHOGRAPHIC : OCLSHADE_PERSPECTIVE, fov, oh, nr,
                                  fr, cam));
}

static const size_t GB[7] = {16, 16, 8, 16, 4, 16, 4};
static const char *const GB_NAME[7] = {"position", "normal", "uv", "uv_grad", "depth", "albedo", "object"};

static oclshade_field *gb_at(oclshade_object_gbuffer *g, int i)
{
    oclshade_field *f[7] = {&g->position, &g->normal, &g->uv, &g->uv_grad, &g->depth, &g->albedo, &g->object};
    return f[i];
}

/* The tables uploaded into p (and their sizes). */
static void upload_tables(const oclshade_mesh_tables *t, oclshade_mesh_params *p)
{
    p->count = t->meshes; p->nodes = t->nodes; p->slots = t->slots; p->vertices = t->vertices; p->texels = t->texels;
    p->mi = buffer(48 * (size_t)t->meshes, t->mi);
    p->box = buffer(32 * (size_t)t->nodes, t->box);
    p->info = buffer(8 * (size_t)t->nodes, t->info);
    p->tri = buffer(48 * (size_t)t->slots, t->tri);
    p->tvtx = buffer(16 * (size_t)t->slots, t->tvtx);
    p->tangent = buffer(16 * (size_t)t->slots, t->tangent);
    p->vnrm = buffer(16 * (size_t)t->vertices, t->vnrm);
    p->vuv = buffer(8 * (size_t)t->vertices, t->vuv);
    p->texel = buffer(16 * (size_t)t->texels, t->texel);
}

static void release_tables(oclshade_mesh_params *p)
{
    cl_mem m[11] = {p->mf, p->mi, p->box, p->info, p->tri, p->tvtx, p->tangent, p->vnrm, p->vuv, p->texel, p->light};
    for (int i = 0; i < 11; ++i) release(m[i]);
}

static oclshade_mesh_tables read_tables(const char *dir, const char *name)
{
    char path[4096], error[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    oclshade_mesh_tables t;
    if (oclshade_mesh_tables_read(path, &t, error, sizeof error) != OCLSHADE_OK) fail(error);
    return t;
}

/* ------------------------------------------------------------------ meshes */

static void run_meshes(int argc, char **argv)
{
    if (argc != 1) fail("usage: host_meshes meshes OUTDIR INDIR");
    const char *in = argv[0];
    char path[4096];
    snprintf(path, sizeof path, "%s/scene.txt", in);
    FILE *f = fopen(path, "r");
    if (f == NULL) fail(path);
    oclshade_mesh_params p;
    oclshade_mesh_params_init(&p);
    double eye[3];
    read_camera(f, &p.camera, eye);
    int rows, cols;
    double dx, dy;
    oclshade_mesh_light light;
    if (fscanf(f, "%d %d %lf %lf", &rows, &cols, &dx, &dy) != 4) fail("terrain line");
    if (fscanf(f, "%lf %lf %lf %lf", &p.azimuth, &p.elevation, &p.k_dark, &p.k_bright) != 4) fail("sun line");
    if (fscanf(f, "%d %lf %lf %lf", &light.point, &light.position[0], &light.position[1], &light.position[2]) != 4)
        fail("light line");
    fclose(f);
    light.azimuth = p.azimuth;
    light.elevation = p.elevation;
    const int W = p.camera.width, H = p.camera.height, n = W * H;
    /* tables */
    oclshade_mesh_tables t = read_tables(in, "tables.bin");
    cl_float4 *mf = (cl_float4 *)xmalloc(48 * (size_t)t.meshes), *lt = (cl_float4 *)xmalloc(16 * (size_t)t.meshes);
    if (oclshade_mesh_camera_table(&t, &p.camera, eye, mf) != OCLSHADE_OK) fail("oclshade_mesh_camera_table");
    if (oclshade_mesh_light_table(&t, &light, lt) != OCLSHADE_OK) fail("oclshade_mesh_light_table");
    write_file("mf.f32", mf, 48 * (size_t)t.meshes);
    write_file("light.f32", lt, 16 * (size_t)t.meshes);
    upload_tables(&t, &p);
    p.mf = buffer(48 * (size_t)t.meshes, mf);
    p.light = buffer(16 * (size_t)t.meshes, lt);
    /* the terrain (rows 0: none) */
    double *heights = NULL;
    float *rel = NULL;
    if (rows > 0) {
        heights = (double *)read_file(in, "heights.f64", 8 * (size_t)rows * cols);
        rel = (float *)xmalloc(4 * (size_t)rows * cols);
        float lo, hi;
        CHECK(oclshade_relative_heights(heights, (size_t)rows * cols, rel, &p.offset));
        if (oclshade_height_range(rel, (size_t)rows * cols, &lo, &hi) != OCLSHADE_OK) hi = 0.0f;
        p.hmax = hi;
        p.rows = rows; p.cols = cols; p.dx = dx; p.dy = dy;
    }
    void *dst[7];
    for (int i = 0; i < 7; ++i) {
        snprintf(path, sizeof path, "dst_%s.bin", GB_NAME[i]);
        dst[i] = read_file(in, path, GB[i] * (size_t)n);
    }
    void *shading = read_file(in, "shading.f32", 16 * (size_t)n), *coef = read_file(in, "coef.f32", 4 * (size_t)n);
    enum { NOUT = 11 };   /* 7 merged fields, shading, terrain coefficients, hidden, final coefficients */
    static const size_t OUT_BYTES[NOUT - 7] = {16, 4, 4, 4};
    void *first[NOUT] = {NULL};
    for (int pitched = 0; pitched < 2; ++pitched) {
        oclshade_quadric_params q;   /* the merge and object normals: the generic object calls */
        oclshade_quadric_params_init(&q);
        q.camera = p.camera;
        p.heights = rows > 0 ? field_of(rel, rows, 4 * (size_t)cols, pitched) : oclshade_field_of(NULL);
        for (int i = 0; i < 7; ++i) {
            void *zero = xmalloc(GB[i] * (size_t)n);
            *gb_at(&p.objects, i) = field_of(zero, H, GB[i] * (size_t)W, pitched);
            *gb_at(&p.gbuffer, i) = field_of(dst[i], H, GB[i] * (size_t)W, pitched);
            free(zero);
        }
        q.objects = p.objects;
        q.gbuffer = p.gbuffer;
        q.shading = field_of(shading, H, 16 * (size_t)W, pitched);
        p.coefficient = field_of(coef, H, 4 * (size_t)W, pitched);
        void *zero = xmalloc(4 * (size_t)n);
        p.hidden = field_of(zero, H, 4 * (size_t)W, pitched);
        free(zero);
        size_t bytes = 0, qbytes = 0;
        CHECK(oclshade_mesh_scratch_size(lib, &p, &bytes));
        CHECK(oclshade_quadric_scratch_size(lib, &q, &qbytes));
        if ((bytes != 0) != pitched) fail("meshes: scratch only for pitched fields");
        p.scratch = bytes ? buffer(bytes, NULL) : NULL;
        q.scratch = qbytes ? buffer(qbytes, NULL) : NULL;
        cl_event ev[6];
        void *out[NOUT];
        CHECK(oclshade_enqueue_mesh_cast(lib, queue, &p, 0, NULL, &ev[0]));
        if (!pitched)
            for (int i = 0; i < 7; ++i) {
                void *o = read_field(gb_at(&p.objects, i), H, GB[i] * (size_t)W);
                snprintf(path, sizeof path, "obj_%s.bin", GB_NAME[i]);
                write_file(path, o, GB[i] * (size_t)n);
                free(o);
            }
        CHECK(oclshade_enqueue_gbuffer_merge(lib, queue, &q, 1, &ev[0], &ev[1]));
        CHECK(oclshade_enqueue_object_normals(lib, queue, &q, 1, &ev[1], &ev[2]));
        CHECK(oclshade_enqueue_mesh_terrain_shadow(lib, queue, &p, 1, &ev[2], &ev[3]));
        CLCHECK(clWaitForEvents(1, &ev[3]));
        out[8] = read_field(&p.coefficient, H, 4 * (size_t)W);
        CHECK(oclshade_enqueue_mesh_shadow_rays(lib, queue, &p, 1, &ev[3], &ev[4]));
        CHECK(oclshade_enqueue_mesh_shadow_apply(lib, queue, &p, 1, &ev[4], &ev[5]));
        CLCHECK(clWaitForEvents(1, &ev[5]));
        for (int e = 0; e < 6; ++e) clReleaseEvent(ev[e]);
        for (int i = 0; i < 7; ++i) out[i] = read_field(gb_at(&p.gbuffer, i), H, GB[i] * (size_t)W);
        out[7] = read_field(&q.shading, H, 16 * (size_t)W);
        out[9] = read_field(&p.hidden, H, 4 * (size_t)W);
        out[10] = read_field(&p.coefficient, H, 4 * (size_t)W);
        for (int i = 0; i < NOUT; ++i) {
            const size_t nb = (i < 7 ? GB[i] : OUT_BYTES[i - 7]) * (size_t)n;
            if (!pitched) {
                first[i] = out[i];
            } else {
                if (memcmp(out[i], first[i], nb) != 0) fail("meshes: pitched fields give other bits");
                free(out[i]);
            }
        }
        release(p.heights.buffer); release(q.shading.buffer); release(p.coefficient.buffer); release(p.hidden.buffer);
        release(p.scratch); release(q.scratch);
        for (int i = 0; i < 7; ++i) { release(gb_at(&p.objects, i)->buffer); release(gb_at(&p.gbuffer, i)->buffer); }
    }
    for (int i = 0; i < 7; ++i) {
        snprintf(path, sizeof path, "mrg_%s.bin", GB_NAME[i]);
        write_file(path, first[i], GB[i] * (size_t)n);
    }
    static const char *const OUT_NAME[NOUT - 7] = {"shading.out", "coef_terrain.out", "hidden.out", "coef.out"};
    for (int i = 7; i < NOUT; ++i) write_file(OUT_NAME[i - 7], first[i], OUT_BYTES[i - 7] * (size_t)n);
    for (int i = 0; i < NOUT; ++i) free(first[i]);
    for (int i = 0; i < 7; ++i) free(dst[i]);
    release_tables(&p);
    oclshade_mesh_tables_free(&t);
    free(mf); free(lt); free(heights); free(rel); free(shading); free(coef);
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

/* The reader fails on a damaged file with a message holding needle. */
static void expect_read_error(const char *dir, const char *name, const char *needle)
{
    char path[4096], error[512], what[256];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    oclshade_mesh_tables t;
    memset(&t, 0x5A, sizeof t);
    const oclshade_status st = oclshade_mesh_tables_read(path, &t, error, sizeof error);
    snprintf(what, sizeof what, "read %s: \"%s\"", name, needle);
    const int cleared = t.mi == NULL && t.box == NULL && t.meshes == 0;
    if (st == OCLSHADE_INVALID_ARGUMENT && strstr(error, needle) != NULL && cleared) {
        printf("ok %s\n", what);
    } else {
        printf("FAIL %s: got %s, tables %s; message: %s\n", what, oclshade_status_name(st),
               cleared ? "cleared" : "not cleared", error);
        ++failures;
    }
}

static void run_errors(int argc, char **argv)
{
    if (argc != 1) fail("usage: host_meshes errors OUTDIR INDIR");
    const char *in = argv[0];
    /* the reader */
    expect_read_error(in, "missing.bin", "cannot be opened");
    expect_read_error(in, "magic.bin", "not a mesh tables file");
    expect_read_error(in, "short.bin", "shorter than its counts say");
    expect_read_error(in, "long.bin", "longer than its counts say");
    expect_read_error(in, "counts.bin", "must be >= 1");
    expect_read_error(in, "index.bin", "vertex index");
    expect_read_error(in, "child.bin", "must be later nodes");
    expect_read_error(in, "leaf.bin", "must lie within the");
    expect_read_error(in, "root.bin", "root");
    expect_read_error(in, "texture.bin", "texture");
    expect_read_error(in, "deep.bin", "exceeds the traversal stack 64");
    expect(oclshade_mesh_tables_read(NULL, NULL, NULL, 0) == OCLSHADE_INVALID_ARGUMENT, "read: NULL out");
    oclshade_mesh_tables_free(NULL);

    oclshade_mesh_tables t = read_tables(in, "tables.bin");
    const int W = 8, H = 6, n = W * H;
    oclshade_mesh_params p;
    oclshade_mesh_params_init(&p);
    expect(p.own_builtins == 1, "params init: own_builtins on");
    const double pos[3] = {t.origin[0], t.origin[1] - 30.0, t.origin[2] + 10.0};
    CHECK(oclshade_camera_look_at(pos, t.origin, NULL, W, H, OCLSHADE_PERSPECTIVE, 50.0, 1.0, 1.0, 1000.0, &p.camera));
    cl_float4 *mf = (cl_float4 *)xmalloc(48 * (size_t)t.meshes), *lt = (cl_float4 *)xmalloc(16 * (size_t)t.meshes);
    const double off[3] = {pos[0] + 1.0, pos[1], pos[2]};
    expect(oclshade_mesh_camera_table(&t, &p.camera, off, mf) == OCLSHADE_INVALID_ARGUMENT,
           "camera table: a position the view does not map to its origin");
    expect(oclshade_mesh_camera_table(NULL, &p.camera, pos, mf) == OCLSHADE_INVALID_ARGUMENT, "camera table: NULL tables");
    CHECK(oclshade_mesh_camera_table(&t, &p.camera, pos, mf));
    oclshade_mesh_light light = {0, 135.0, 95.0, {0.0, 0.0, 0.0}};
    expect(oclshade_mesh_light_table(&t, &light, lt) == OCLSHADE_INVALID_ARGUMENT, "light table: elevation 95");
    light.point = 2;
    expect(oclshade_mesh_light_table(&t, &light, lt) == OCLSHADE_INVALID_ARGUMENT, "light table: point 2");
    light.point = 1;
    light.position[1] = NAN;
    expect(oclshade_mesh_light_table(&t, &light, lt) == OCLSHADE_INVALID_ARGUMENT, "light table: a NaN position");
    light.point = 0;
    light.elevation = 30.0;
    CHECK(oclshade_mesh_light_table(&t, &light, lt));

    upload_tables(&t, &p);
    p.mf = buffer(48 * (size_t)t.meshes, mf);
    p.light = buffer(16 * (size_t)t.meshes, lt);
    for (int i = 0; i < 7; ++i) *gb_at(&p.objects, i) = oclshade_field_of(buffer(GB[i] * (size_t)n, NULL));
    void *zeros = xmalloc(16 * (size_t)n);
    for (int i = 0; i < 7; ++i) *gb_at(&p.gbuffer, i) = oclshade_field_of(buffer(GB[i] * (size_t)n, zeros));
    p.coefficient = oclshade_field_of(buffer(4 * (size_t)n, NULL));
    p.hidden = oclshade_field_of(buffer(4 * (size_t)n, NULL));
    CHECK(oclshade_enqueue_mesh_cast(lib, queue, &p, 0, NULL, NULL));
    expect_status(oclshade_enqueue_mesh_cast(lib, queue, NULL, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT, "params",
                  "cast: NULL params");
    expect_status(oclshade_enqueue_mesh_cast(lib, NULL, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT, "queue",
                  "cast: NULL queue");
    expect_status(oclshade_enqueue_mesh_cast(lib, queue, &p, 1, NULL, NULL), OCLSHADE_INVALID_ARGUMENT, "wait",
                  "cast: a wait list count without a list");
    p.count = 0;
    expect_status(oclshade_enqueue_mesh_cast(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "count must be the number of meshes", "cast: count 0");
    p.count = t.meshes + 1;
    expect_status(oclshade_enqueue_mesh_cast(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "mf must hold at least", "cast: a camera table too small for count");
    p.count = t.meshes;
    p.nodes = 0;
    expect_status(oclshade_enqueue_mesh_shadow_rays(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "nodes, slots, vertices, texels", "rays: nodes 0");
    p.nodes = t.nodes + 1;
    expect_status(oclshade_enqueue_mesh_shadow_rays(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "box must hold at least", "rays: a box table too small for nodes");
    p.nodes = t.nodes;
    p.vertices = t.vertices + 1;
    expect_status(oclshade_enqueue_mesh_cast(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "vnrm must hold at least", "cast: a normal table too small for vertices");
    p.vertices = t.vertices;
    const cl_mem lsave = p.light;
    p.light = NULL;
    expect_status(oclshade_enqueue_mesh_shadow_rays(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT, "light",
                  "rays: no light table");
    p.light = lsave;
    const oclshade_field depth = p.objects.depth;
    p.objects.depth = oclshade_field_of(buffer(4 * (size_t)n - 4, NULL));
    expect_status(oclshade_enqueue_mesh_cast(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "objects.depth", "cast: an output field too small");
    release(p.objects.depth.buffer);
    p.objects.depth = depth;
    const oclshade_field albedo = p.objects.albedo;
    p.objects.albedo = oclshade_field_of(buffer((16 * (size_t)W + 16) * (size_t)H, NULL));
    p.objects.albedo.row_pitch = 16 * (size_t)W + 16;
    expect_status(oclshade_enqueue_mesh_cast(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT, "scratch",
                  "cast: a pitched field needs scratch");
    release(p.objects.albedo.buffer);
    p.objects.albedo = albedo;
    const oclshade_field uv = p.objects.uv;
    p.objects.uv = p.objects.albedo;
    expect_status(oclshade_enqueue_mesh_cast(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT, "overlap",
                  "cast: two outputs alias");
    p.objects.uv = uv;
    p.objects.depth = oclshade_field_of(p.tri);
    expect_status(oclshade_enqueue_mesh_cast(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT, "overlap",
                  "cast: an output aliases a table");
    p.objects.depth = depth;
    cl_int err;
    const oclshade_field hidden = p.hidden;
    p.hidden = oclshade_field_of(clCreateBuffer(ctx, CL_MEM_READ_ONLY, 4 * (size_t)n, NULL, &err));
    CLCHECK(err);
    expect_status(oclshade_enqueue_mesh_shadow_rays(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "hidden is written by the kernels but was created CL_MEM_READ_ONLY", "rays: read-only hidden");
    CHECK(oclshade_enqueue_mesh_shadow_apply(lib, queue, &p, 0, NULL, NULL));   /* apply only reads it */
    release(p.hidden.buffer);
    p.hidden = hidden;
    CHECK(oclshade_enqueue_mesh_shadow_rays(lib, queue, &p, 0, NULL, NULL));
    p.elevation = 95.0;
    expect_status(oclshade_enqueue_mesh_terrain_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "elevation in [-90, 90]", "terrain shadow: elevation 95");
    p.elevation = 30.0;
    p.k_bright = -0.5;
    expect_status(oclshade_enqueue_mesh_shadow_apply(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "k_dark and k_bright must be in [0, 1]", "apply: k_bright -0.5");
    p.k_bright = 0.5;
    p.heights = oclshade_field_of(buffer(4 * 12, NULL));
    p.rows = 3; p.cols = 4; p.dx = 0.0; p.dy = 1.0;
    expect_status(oclshade_enqueue_mesh_terrain_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "dx, dy must be positive finite", "terrain shadow: dx 0");
    p.dx = 1.0;
    p.rows = 4;
    expect_status(oclshade_enqueue_mesh_terrain_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "heights", "terrain shadow: heights too small for rows x cols");
    p.rows = 3;
    p.hmax = NAN;
    expect_status(oclshade_enqueue_mesh_terrain_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "hmax must be finite", "terrain shadow: hmax NaN");
    p.hmax = 0.0f;
    CHECK(oclshade_enqueue_mesh_terrain_shadow(lib, queue, &p, 0, NULL, NULL));
    size_t bytes = 1;
    CHECK(oclshade_mesh_scratch_size(lib, &p, &bytes));
    expect(bytes == 0, "meshes: no scratch for packed fields");
    expect_status(oclshade_mesh_scratch_size(lib, &p, NULL), OCLSHADE_INVALID_ARGUMENT, "bytes", "scratch size: NULL bytes");
    CLCHECK(clFinish(queue));
    release(p.heights.buffer); release(p.coefficient.buffer); release(p.hidden.buffer);
    for (int i = 0; i < 7; ++i) { release(gb_at(&p.objects, i)->buffer); release(gb_at(&p.gbuffer, i)->buffer); }
    release_tables(&p);
    oclshade_mesh_tables_free(&t);
    free(mf); free(lt); free(zeros);
}

int main(int argc, char **argv)
{
    if (argc < 3) fail("usage: host_meshes COMMAND OUTDIR ARGS...");
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
    if (strcmp(argv[1], "meshes") == 0) run_meshes(argc - 3, argv + 3);
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
