/* host_objects.c — the C host's quadric and reflection entry points and its @IF specialiser on
 * inputs a Python test writes (tests/test_host_objects.py compares every output with the
 * Python host's, bit for bit).
 *
 *   host_objects specialize OUTDIR NV VECTOR... SOURCE...
 *       NV condition vectors, then source files ("-": reflect.cl as the library holds it,
 *       oclshade_program_source): source S specialised for vector V into OUTDIR/spec_S_V.cl,
 *       or its error message into OUTDIR/spec_S_V.err.
 *   host_objects quadrics OUTDIR INDIR
 *       INDIR/scene.txt (camera, terrain, sun, quadrics: see read_scene), heights.f64, the
 *       G-buffer to merge into (dst_*.bin), shading.f32, coef.f32: the tables (qf.f32,
 *       qi.i32), the cast (obj_*.bin), the merged G-buffer (mrg_*.bin), the shading normals
 *       (shading.out) and the coefficients (coef.out).  Checks itself that pitched fields at
 *       offsets give the same bits.
 *   host_objects point OUTDIR INDIR
 *       the inputs of quadrics (no shading.f32 needed) with a point light line in scene.txt
 *       ("X Y Z TERRAIN"; TERRAIN 0: no heights): cast and merge into dst_*.bin, then the
 *       terrain's point-light shadows (tps.out: coef.f32 overwritten) and the quadrics'
 *       (pps.out).  Checks itself that pitched fields at offsets give the same bits and that
 *       the bytes between a pitched coefficient field's rows stay untouched.
 *   host_objects expand OUTDIR REFLECT FILE...
 *       a handle from sources: REFLECT as reflect.cl, the FILEs (the other kernel files and
 *       includes of a test's own) by their base names; the library's expansion of
 *       reflect.cl into OUTDIR/expanded.cl.
 *   host_objects errors OUTDIR
 *       the argument and contract checks of every new entry point and host helper: prints
 *       "ok WHAT" or "FAIL WHAT: ..." per check and fails when one fails.
 *   host_objects reflect OUTDIR INDIR
 *       INDIR/reflect.txt (frame, camera, environment, materials), position.f32, normal.f32,
 *       albedo.f32, object.i32, cube.f32, frame.u8: the material table (table.f32), weighted
 *       albedo (weighted.out), acc (acc.out), the final image (image.out).
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

static char *read_text(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL) fail(path);
    fseek(f, 0, SEEK_END);
    const long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *text = (char *)xmalloc((size_t)n + 1);
    if (fread(text, 1, (size_t)n, f) != (size_t)n) fail(path);
    fclose(f);
    return text;
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
    for (int r = 0; r < rows; ++r) memcpy(host + offset + (size_t)r * pitch, (const unsigned char *)packed + (size_t)r * row_bytes, row_bytes);
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

/* ------------------------------------------------------------------ specialize */

static void run_specialize(int argc, char **argv)
{
    const int nv = argc > 0 ? atoi(argv[0]) : -1;
    if (nv < 1 || argc < nv + 2) fail("usage: host_objects specialize OUTDIR NV VECTOR... SOURCE...");
    for (int s = nv + 1; s < argc; ++s) {
        char *source = strcmp(argv[s], "-") == 0 ? NULL : read_text(argv[s]);
        const char *text = source ? source : oclshade_program_source(lib, "reflect.cl");
        if (text == NULL) fail("reflect.cl is not among the library's sources");
        for (int v = 1; v <= nv; ++v) {
            size_t n = 0;
            char error[512], name[64];
            oclshade_status st = oclshade_specialize(text, argv[v], NULL, 0, &n, error, sizeof error);
            if (st != OCLSHADE_OK) {
                snprintf(name, sizeof name, "spec_%d_%d.err", s - nv - 1, v - 1);
                write_file(name, error, strlen(error));
                continue;
            }
            char *out = (char *)xmalloc(n);
            size_t again = 0;
            CHECK(oclshade_specialize(text, argv[v], out, n, &again, NULL, 0));
            if (again != n || strlen(out) + 1 != n) fail("specialize: sizes differ between the two calls");
            /* a buffer too small gets a NUL-terminated prefix and the same size */
            char small[8];
            CHECK(oclshade_specialize(text, argv[v], small, sizeof small, &again, NULL, 0));
            if (again != n || strlen(small) != (n - 1 < 7 ? n - 1 : 7) || strncmp(small, out, strlen(small)) != 0)
                fail("specialize: a small buffer is not the text's prefix");
            snprintf(name, sizeof name, "spec_%d_%d.cl", s - nv - 1, v - 1);
            write_file(name, out, n - 1);
            free(out);
        }
        free(source);
    }
}

/* ------------------------------------------------------------------ include expansion */

/* The library's expansion of a reflect.cl of our own (REFLECT) beside the files FILE...
 * (every other kernel file and includes of our own, named by their base names), into
 * OUTDIR/expanded.cl. */
static void run_expand(int argc, char **argv)
{
    if (argc < 1) fail("usage: host_objects expand OUTDIR REFLECT FILE...");
    oclshade_source *list = (oclshade_source *)xmalloc((size_t)argc * sizeof *list);
    for (int i = 0; i < argc; ++i) {
        const char *base = strrchr(argv[i], '/');
        list[i].name = i == 0 ? "reflect.cl" : base ? base + 1 : argv[i];
        list[i].text = read_text(argv[i]);
    }
    oclshade *own;
    if (oclshade_create_from_sources(ctx, device, list, (size_t)argc, &own) != OCLSHADE_OK) fail(oclshade_last_error(own));
    const char *text = oclshade_program_source(own, "reflect.cl");
    write_file("expanded.cl", text, strlen(text));
    oclshade_destroy(own);
    for (int i = 0; i < argc; ++i) free((void *)list[i].text);
    free(list);
}

/* ------------------------------------------------------------------ quadrics */

static const size_t GB[7] = {16, 16, 8, 16, 4, 16, 4};
static const char *const GB_NAME[7] = {"position", "normal", "uv", "uv_grad", "depth", "albedo", "object"};

static oclshade_field *gb_at(oclshade_object_gbuffer *g, int i)
{
    oclshade_field *f[7] = {&g->position, &g->normal, &g->uv, &g->uv_grad, &g->depth, &g->albedo, &g->object};
    return f[i];
}

/* INDIR/scene.txt: the camera, the terrain's size and cell sizes, the sun, the quadrics, and
 * (with light) a point light line "X Y Z TERRAIN" (TERRAIN 0: the passes without heights). */
static oclshade_quadric *read_quadric_scene(const char *in, oclshade_quadric_params *p, int *rows, int *cols,
                                            double *dx, double *dy, int *terrain)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/scene.txt", in);
    FILE *f = fopen(path, "r");
    if (f == NULL) fail(path);
    oclshade_quadric_params_init(p);
    read_camera(f, &p->camera);
    int count;
    if (fscanf(f, "%d %d %lf %lf", rows, cols, dx, dy) != 4) fail("terrain line");
    if (fscanf(f, "%lf %lf %lf %lf", &p->azimuth, &p->elevation, &p->k_dark, &p->k_bright) != 4) fail("sun line");
    if (fscanf(f, "%d", &count) != 1 || count < 1) fail("count");
    oclshade_quadric *qs = (oclshade_quadric *)xmalloc((size_t)count * sizeof *qs);
    for (int k = 0; k < count; ++k) {
        int kind;
        oclshade_quadric *q = &qs[k];
        if (fscanf(f, "%d %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf", &kind, &q->centre[0], &q->centre[1],
                   &q->centre[2], &q->radii[0], &q->radii[1], &q->radii[2], &q->axis[0], &q->axis[1], &q->axis[2],
                   &q->colour[0], &q->colour[1], &q->colour[2]) != 13)
            fail("quadric line");
        q->kind = (oclshade_quadric_kind)kind;
    }
    if (terrain != NULL && fscanf(f, "%lf %lf %lf %d", &p->light_position[0], &p->light_position[1],
                                  &p->light_position[2], terrain) != 4)
        fail("light line");
    fclose(f);
    p->count = count;
    return qs;
}

static void run_quadrics(int argc, char **argv)
{
    if (argc != 1) fail("usage: host_objects quadrics OUTDIR INDIR");
    const char *in = argv[0];
    char path[4096];
    oclshade_quadric_params p;
    int rows, cols;
    double dx, dy;
    oclshade_quadric *qs = read_quadric_scene(in, &p, &rows, &cols, &dx, &dy, NULL);
    const int count = p.count;
    const int W = p.camera.width, H = p.camera.height, n = W * H;
    /* tables */
    cl_float4 *qf = (cl_float4 *)xmalloc(80 * (size_t)count);
    cl_int4 *qi = (cl_int4 *)xmalloc(32 * (size_t)count);
    if (oclshade_quadric_tables(qs, count, &p.camera, qf, qi) != OCLSHADE_OK) fail("oclshade_quadric_tables");
    write_file("qf.f32", qf, 80 * (size_t)count);
    write_file("qi.i32", qi, 32 * (size_t)count);
    p.qf = buffer(80 * (size_t)count, qf);
    p.qi = buffer(32 * (size_t)count, qi);
    /* the terrain */
    double *heights = (double *)read_file(in, "heights.f64", 8 * (size_t)rows * cols);
    float *rel = (float *)xmalloc(4 * (size_t)rows * cols);
    float lo, hi;
    CHECK(oclshade_relative_heights(heights, (size_t)rows * cols, rel, &p.offset));
    if (oclshade_height_range(rel, (size_t)rows * cols, &lo, &hi) != OCLSHADE_OK) hi = 0.0f;
    p.hmax = hi;
    p.rows = rows; p.cols = cols; p.dx = dx; p.dy = dy;
    void *dst[7];
    for (int i = 0; i < 7; ++i) {
        snprintf(path, sizeof path, "dst_%s.bin", GB_NAME[i]);
        dst[i] = read_file(in, path, GB[i] * (size_t)n);
    }
    void *shading = read_file(in, "shading.f32", 16 * (size_t)n), *coef = read_file(in, "coef.f32", 4 * (size_t)n);
    void *first[10] = {NULL};   /* the packed run's outputs: 7 merged fields, shading, coef, objects' depth */
    for (int pitched = 0; pitched < 2; ++pitched) {
        p.heights = field_of(rel, rows, 4 * (size_t)cols, pitched);
        for (int i = 0; i < 7; ++i) {
            void *zero = xmalloc(GB[i] * (size_t)n);
            *gb_at(&p.objects, i) = field_of(zero, H, GB[i] * (size_t)W, pitched);
            *gb_at(&p.gbuffer, i) = field_of(dst[i], H, GB[i] * (size_t)W, pitched);
            free(zero);
        }
        p.shading = field_of(shading, H, 16 * (size_t)W, pitched);
        p.coefficient = field_of(coef, H, 4 * (size_t)W, pitched);
        size_t bytes = 0;
        CHECK(oclshade_quadric_scratch_size(lib, &p, &bytes));
        if ((bytes != 0) != pitched) fail("quadrics: scratch only for pitched fields");
        p.scratch = bytes ? buffer(bytes, NULL) : NULL;
        cl_event ev[4];
        CHECK(oclshade_enqueue_quadric_cast(lib, queue, &p, 0, NULL, &ev[0]));
        if (!pitched)
            for (int i = 0; i < 7; ++i) {
                void *o = read_field(gb_at(&p.objects, i), H, GB[i] * (size_t)W);
                snprintf(path, sizeof path, "obj_%s.bin", GB_NAME[i]);
                write_file(path, o, GB[i] * (size_t)n);
                free(o);
            }
        CHECK(oclshade_enqueue_gbuffer_merge(lib, queue, &p, 1, &ev[0], &ev[1]));
        CHECK(oclshade_enqueue_object_normals(lib, queue, &p, 1, &ev[1], &ev[2]));
        CHECK(oclshade_enqueue_quadric_shadow(lib, queue, &p, 1, &ev[2], &ev[3]));
        CLCHECK(clWaitForEvents(1, &ev[3]));
        for (int e = 0; e < 4; ++e) clReleaseEvent(ev[e]);
        void *out[9];
        for (int i = 0; i < 7; ++i) out[i] = read_field(gb_at(&p.gbuffer, i), H, GB[i] * (size_t)W);
        out[7] = read_field(&p.shading, H, 16 * (size_t)W);
        out[8] = read_field(&p.coefficient, H, 4 * (size_t)W);
        for (int i = 0; i < 9; ++i) {
            const size_t nb = (i < 7 ? GB[i] : i == 7 ? 16 : 4) * (size_t)n;
            if (!pitched) {
                first[i] = out[i];
            } else {
                if (memcmp(out[i], first[i], nb) != 0) fail("quadrics: pitched fields give other bits");
                free(out[i]);
            }
        }
        release(p.heights.buffer); release(p.shading.buffer); release(p.coefficient.buffer); release(p.scratch);
        for (int i = 0; i < 7; ++i) { release(gb_at(&p.objects, i)->buffer); release(gb_at(&p.gbuffer, i)->buffer); }
    }
    for (int i = 0; i < 7; ++i) {
        snprintf(path, sizeof path, "mrg_%s.bin", GB_NAME[i]);
        write_file(path, first[i], GB[i] * (size_t)n);
    }
    write_file("shading.out", first[7], 16 * (size_t)n);
    write_file("coef.out", first[8], 4 * (size_t)n);
    for (int i = 0; i < 9; ++i) free(first[i]);
    for (int i = 0; i < 7; ++i) free(dst[i]);
    release(p.qf); release(p.qi);
    free(qf); free(qi); free(qs); free(heights); free(rel); free(shading); free(coef);
}

/* A point light: cast, merge into the given G-buffer, terrain_point_shadow into the
 * coefficients (tps.out), then quadric_point_shadow (pps.out); packed and pitched. */
static void run_point(int argc, char **argv)
{
    if (argc != 1) fail("usage: host_objects point OUTDIR INDIR");
    const char *in = argv[0];
    char path[4096];
    oclshade_quadric_params p;
    int rows, cols, terrain;
    double dx, dy;
    oclshade_quadric *qs = read_quadric_scene(in, &p, &rows, &cols, &dx, &dy, &terrain);
    const int count = p.count, W = p.camera.width, H = p.camera.height, n = W * H;
    cl_float4 *qf = (cl_float4 *)xmalloc(80 * (size_t)count);
    cl_int4 *qi = (cl_int4 *)xmalloc(32 * (size_t)count);
    if (oclshade_quadric_tables(qs, count, &p.camera, qf, qi) != OCLSHADE_OK) fail("oclshade_quadric_tables");
    p.qf = buffer(80 * (size_t)count, qf);
    p.qi = buffer(32 * (size_t)count, qi);
    double *heights = (double *)read_file(in, "heights.f64", 8 * (size_t)rows * cols);
    float *rel = (float *)xmalloc(4 * (size_t)rows * cols);
    float lo, hi;
    CHECK(oclshade_relative_heights(heights, (size_t)rows * cols, rel, &p.offset));
    if (oclshade_height_range(rel, (size_t)rows * cols, &lo, &hi) != OCLSHADE_OK) hi = 0.0f;
    p.hmax = hi;
    p.rows = rows; p.cols = cols; p.dx = dx; p.dy = dy;
    void *dst[7];
    for (int i = 0; i < 7; ++i) {
        snprintf(path, sizeof path, "dst_%s.bin", GB_NAME[i]);
        dst[i] = read_file(in, path, GB[i] * (size_t)n);
    }
    void *coef = read_file(in, "coef.f32", 4 * (size_t)n);
    void *first[2] = {NULL};   /* the packed run's coefficients after each pass */
    for (int pitched = 0; pitched < 2; ++pitched) {
        p.heights = terrain ? field_of(rel, rows, 4 * (size_t)cols, pitched) : oclshade_field_of(NULL);
        for (int i = 0; i < 7; ++i) {
            void *zero = xmalloc(GB[i] * (size_t)n);
            *gb_at(&p.objects, i) = field_of(zero, H, GB[i] * (size_t)W, pitched);
            *gb_at(&p.gbuffer, i) = field_of(dst[i], H, GB[i] * (size_t)W, pitched);
            free(zero);
        }
        p.coefficient = field_of(coef, H, 4 * (size_t)W, pitched);   /* overwritten by the terrain pass */
        size_t bytes = 0;
        CHECK(oclshade_quadric_scratch_size(lib, &p, &bytes));
        if ((bytes != 0) != pitched) fail("point: scratch only for pitched fields");
        p.scratch = bytes ? buffer(bytes, NULL) : NULL;
        cl_event ev[4];
        CHECK(oclshade_enqueue_quadric_cast(lib, queue, &p, 0, NULL, &ev[0]));
        CHECK(oclshade_enqueue_gbuffer_merge(lib, queue, &p, 1, &ev[0], &ev[1]));
        CHECK(oclshade_enqueue_terrain_point_shadow(lib, queue, &p, 1, &ev[1], &ev[2]));
        CLCHECK(clWaitForEvents(1, &ev[2]));
        void *out[2];
        out[0] = read_field(&p.coefficient, H, 4 * (size_t)W);
        CHECK(oclshade_enqueue_quadric_point_shadow(lib, queue, &p, 1, &ev[2], &ev[3]));
        CLCHECK(clWaitForEvents(1, &ev[3]));
        for (int e = 0; e < 4; ++e) clReleaseEvent(ev[e]);
        out[1] = read_field(&p.coefficient, H, 4 * (size_t)W);
        if (pitched) {   /* the bytes between a pitched output's rows are left untouched */
            unsigned char *raw = (unsigned char *)read_back(p.coefficient.buffer, p.coefficient.offset +
                                                            (size_t)H * p.coefficient.row_pitch);
            for (int r = 0; r < H; ++r)
                for (size_t b = 4 * (size_t)W; b < p.coefficient.row_pitch; ++b)
                    if (raw[p.coefficient.offset + (size_t)r * p.coefficient.row_pitch + b] != 0xAB)
                        fail("point: bytes between the coefficient's rows were written");
            free(raw);
        }
        for (int i = 0; i < 2; ++i) {
            if (!pitched) {
                first[i] = out[i];
            } else {
                if (memcmp(out[i], first[i], 4 * (size_t)n) != 0) fail("point: pitched fields give other bits");
                free(out[i]);
            }
        }
        release(p.heights.buffer); release(p.coefficient.buffer); release(p.scratch);
        for (int i = 0; i < 7; ++i) { release(gb_at(&p.objects, i)->buffer); release(gb_at(&p.gbuffer, i)->buffer); }
    }
    write_file("tps.out", first[0], 4 * (size_t)n);
    write_file("pps.out", first[1], 4 * (size_t)n);
    for (int i = 0; i < 2; ++i) free(first[i]);
    for (int i = 0; i < 7; ++i) free(dst[i]);
    release(p.qf); release(p.qi);
    free(qf); free(qi); free(qs); free(heights); free(rel); free(coef);
}

/* ------------------------------------------------------------------ reflections */

static void run_reflect(int argc, char **argv)
{
    if (argc != 1) fail("usage: host_objects reflect OUTDIR INDIR");
    const char *in = argv[0];
    char path[4096];
    snprintf(path, sizeof path, "%s/reflect.txt", in);
    FILE *f = fopen(path, "r");
    if (f == NULL) fail(path);
    oclshade_reflect_params p;
    oclshade_reflect_params_init(&p);
    int count;
    if (fscanf(f, "%d %d %d", &p.width, &p.height, &p.ssaa) != 3) fail("frame line");
    read_camera(f, &p.camera);
    if (fscanf(f, "%d %d %lf %lf %d", &p.face, &p.cubes, &p.rotation, &p.intensity, &p.background) != 5) fail("environment line");
    if (fscanf(f, "%d", &count) != 1 || count < 1) fail("count");
    oclshade_material *ms = (oclshade_material *)xmalloc((size_t)count * sizeof *ms);
    for (int k = 0; k < count; ++k) {
        int kind;
        oclshade_material *m = &ms[k];
        if (fscanf(f, "%d %lf %lf %lf %lf %lf %d", &kind, &m->colour[0], &m->colour[1], &m->colour[2], &m->roughness,
                   &m->fresnel, &m->cube) != 7)
            fail("material line");
        m->kind = (oclshade_material_kind)kind;
    }
    fclose(f);
    cl_float4 *table = (cl_float4 *)xmalloc(48 * (size_t)count);
    if (oclshade_reflect_tables(ms, count, &p.groups, table) != OCLSHADE_OK) fail("oclshade_reflect_tables");
    write_file("table.f32", table, 48 * (size_t)count);
    for (int g = 0; g < p.groups.count; ++g) printf("group %s\n", p.groups.vector[g]);
    p.objects = count;
    p.materials = buffer(48 * (size_t)count, table);
    const int sw = p.width * p.ssaa, sh = p.height * p.ssaa, ns = sw * sh, n = p.width * p.height;
    const size_t cube_bytes = 96 * (size_t)(p.face + 2) * (size_t)(p.face + 2) * (size_t)p.cubes;
    void *pos = read_file(in, "position.f32", 16 * (size_t)ns), *nrm = read_file(in, "normal.f32", 16 * (size_t)ns);
    void *alb = read_file(in, "albedo.f32", 16 * (size_t)ns), *obj = read_file(in, "object.i32", 4 * (size_t)ns);
    void *cube = read_file(in, "cube.f32", cube_bytes), *frame = read_file(in, "frame.u8", 4 * (size_t)n);
    p.cube = buffer(cube_bytes, cube);
    void *first[3] = {NULL};
    for (int pitched = 0; pitched < 2; ++pitched) {
        void *zero = xmalloc(16 * (size_t)ns);
        p.position = field_of(pos, sh, 16 * (size_t)sw, pitched);
        p.normal = field_of(nrm, sh, 16 * (size_t)sw, pitched);
        p.albedo = field_of(alb, sh, 16 * (size_t)sw, pitched);
        p.object = field_of(obj, sh, 4 * (size_t)sw, pitched);
        p.weighted = field_of(zero, sh, 16 * (size_t)sw, pitched);
        p.frame = field_of(frame, p.height, 4 * (size_t)p.width, pitched);
        p.image = field_of(zero, p.height, 4 * (size_t)p.width, pitched);
        free(zero);
        p.acc = buffer(16 * (size_t)n, NULL);
        size_t bytes = 0;
        CHECK(oclshade_reflect_scratch_size(lib, &p, &bytes));
        if ((bytes != 0) != pitched) fail("reflect: scratch only for pitched fields");
        p.scratch = bytes ? buffer(bytes, NULL) : NULL;
        cl_event ev[3];
        CHECK(oclshade_enqueue_reflect_weights(lib, queue, &p, 0, NULL, &ev[0]));
        CHECK(oclshade_enqueue_reflect_apply(lib, queue, &p, 1, &ev[0], &ev[1]));
        CHECK(oclshade_enqueue_reflect_finish(lib, queue, &p, 1, &ev[1], &ev[2]));
        CLCHECK(clWaitForEvents(1, &ev[2]));
        for (int e = 0; e < 3; ++e) clReleaseEvent(ev[e]);
        void *out[3] = {read_field(&p.weighted, sh, 16 * (size_t)sw), read_back(p.acc, 16 * (size_t)n),
                        read_field(&p.image, p.height, 4 * (size_t)p.width)};
        const size_t nb[3] = {16 * (size_t)ns, 16 * (size_t)n, 4 * (size_t)n};
        for (int i = 0; i < 3; ++i) {
            if (!pitched) {
                first[i] = out[i];
            } else {
                if (memcmp(out[i], first[i], nb[i]) != 0) fail("reflect: pitched fields give other bits");
                free(out[i]);
            }
        }
        release(p.position.buffer); release(p.normal.buffer); release(p.albedo.buffer); release(p.object.buffer);
        release(p.weighted.buffer); release(p.frame.buffer); release(p.image.buffer); release(p.acc); release(p.scratch);
    }
    write_file("weighted.out", first[0], 16 * (size_t)ns);
    write_file("acc.out", first[1], 16 * (size_t)n);
    write_file("image.out", first[2], 4 * (size_t)n);
    for (int i = 0; i < 3; ++i) free(first[i]);
    release(p.materials); release(p.cube);
    free(ms); free(table); free(pos); free(nrm); free(alb); free(obj); free(cube); free(frame);
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

static void run_errors(void)
{
    const int W = 8, H = 6, n = W * H;
    oclshade_quadric q = {OCLSHADE_SPHERE, {0.0, 0.0, -20.0}, {2.0, 2.0, 2.0}, {0.0, 0.0, 1.0}, {0.5, 0.5, 0.5}};
    oclshade_quadric_params p;
    oclshade_quadric_params_init(&p);
    const double pos[3] = {0.0, -30.0, 10.0}, at[3] = {0.0, 0.0, -20.0};
    CHECK(oclshade_camera_look_at(pos, at, NULL, W, H, OCLSHADE_PERSPECTIVE, 50.0, 1.0, 1.0, 1000.0, &p.camera));
    cl_float4 qf[5];
    cl_int4 qi[2];
    CHECK(oclshade_quadric_tables(&q, 1, &p.camera, qf, qi));
    oclshade_quadric bad = q;
    bad.radii[2] = 3.0;
    expect_status(oclshade_quadric_tables(&bad, 1, &p.camera, qf, qi), OCLSHADE_INVALID_ARGUMENT, "",
                  "tables: a sphere with unequal radii");
    bad = q;
    bad.axis[0] = bad.axis[1] = bad.axis[2] = 0.0;
    expect_status(oclshade_quadric_tables(&bad, 1, &p.camera, qf, qi), OCLSHADE_INVALID_ARGUMENT, "",
                  "tables: a zero axis");
    p.count = 1;
    p.qf = buffer(80, qf);
    p.qi = buffer(32, qi);
    for (int i = 0; i < 7; ++i) *gb_at(&p.objects, i) = oclshade_field_of(buffer(GB[i] * (size_t)n, NULL));
    void *zeros = xmalloc(16 * (size_t)n);   /* a G-buffer of empty pixels: depth 0 keeps it in the merge */
    for (int i = 0; i < 7; ++i) *gb_at(&p.gbuffer, i) = oclshade_field_of(buffer(GB[i] * (size_t)n, zeros));
    CHECK(oclshade_enqueue_quadric_cast(lib, queue, &p, 0, NULL, NULL));
    expect_status(oclshade_enqueue_quadric_cast(lib, queue, NULL, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT, "params",
                  "cast: NULL params");
    p.count = 0;
    expect_status(oclshade_enqueue_quadric_cast(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "count must be the number of quadrics", "cast: count 0");
    p.count = 2;
    expect_status(oclshade_enqueue_quadric_cast(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "qf must hold at least 160 bytes", "cast: a table too small for count");
    p.count = 1;
    const oclshade_field depth = p.objects.depth;
    p.objects.depth = oclshade_field_of(buffer(4 * (size_t)n - 4, NULL));
    expect_status(oclshade_enqueue_quadric_cast(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "objects.depth", "cast: an output field too small");
    release(p.objects.depth.buffer);
    p.objects.depth = depth;
    const oclshade_field albedo = p.objects.albedo;
    p.objects.albedo = oclshade_field_of(buffer((16 * (size_t)W + 16) * (size_t)H, NULL));
    p.objects.albedo.row_pitch = 16 * (size_t)W + 16;
    expect_status(oclshade_enqueue_quadric_cast(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT, "scratch",
                  "cast: a pitched field needs scratch");
    release(p.objects.albedo.buffer);
    p.objects.albedo = albedo;
    release(p.gbuffer.uv.buffer);
    p.gbuffer.uv = p.objects.uv;
    expect_status(oclshade_enqueue_gbuffer_merge(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT, "overlap",
                  "merge: the source aliases the destination");
    p.gbuffer.uv = oclshade_field_of(buffer(8 * (size_t)n, zeros));
    CHECK(oclshade_enqueue_gbuffer_merge(lib, queue, &p, 0, NULL, NULL));
    cl_int err;
    p.shading = oclshade_field_of(clCreateBuffer(ctx, CL_MEM_READ_ONLY, 16 * (size_t)n, NULL, &err));
    CLCHECK(err);
    expect_status(oclshade_enqueue_object_normals(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "shading is written by the kernels but was created CL_MEM_READ_ONLY", "normals: read-only shading");
    release(p.shading.buffer);
    p.shading = oclshade_field_of(buffer(16 * (size_t)n, NULL));
    CHECK(oclshade_enqueue_object_normals(lib, queue, &p, 0, NULL, NULL));
    p.coefficient = oclshade_field_of(buffer(4 * (size_t)n, NULL));
    p.azimuth = 135.0;
    p.elevation = 95.0;
    expect_status(oclshade_enqueue_quadric_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "elevation in [-90, 90]", "shadow: elevation 95");
    p.elevation = 30.0;
    p.k_dark = 1.5;
    expect_status(oclshade_enqueue_quadric_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "k_dark and k_bright must be in [0, 1]", "shadow: k_dark 1.5");
    p.k_dark = 0.2;
    CHECK(oclshade_enqueue_quadric_shadow(lib, queue, &p, 0, NULL, NULL));
    size_t bytes = 1;
    CHECK(oclshade_quadric_scratch_size(lib, &p, &bytes));
    expect(bytes == 0, "quadrics: no scratch for packed fields");
    /* a point light's passes */
    p.light_position[0] = 1.0; p.light_position[1] = NAN; p.light_position[2] = 5.0;
    expect_status(oclshade_enqueue_terrain_point_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "light_position must be the point light's finite world position (metres), got light_position[1]",
                  "terrain point shadow: a NaN light");
    expect_status(oclshade_enqueue_quadric_point_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "light_position must be", "quadric point shadow: a NaN light");
    p.light_position[1] = -30.0;
    p.k_dark = -0.5;
    expect_status(oclshade_enqueue_terrain_point_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "k_dark must be in [0, 1] (a shadowed pixel's coefficient), got -0.5", "terrain point shadow: k_dark -0.5");
    p.k_dark = 0.2;
    p.heights = oclshade_field_of(buffer(4 * 12, NULL));
    p.rows = 3; p.cols = 4; p.dx = 0.0; p.dy = 1.0;
    expect_status(oclshade_enqueue_terrain_point_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "dx, dy must be positive finite cell sizes", "terrain point shadow: dx 0");
    p.dx = 1.0; p.rows = 4;
    expect_status(oclshade_enqueue_terrain_point_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "heights must hold at least 64 bytes", "terrain point shadow: heights too small for rows x cols");
    p.rows = 3;
    p.hmax = NAN;
    expect_status(oclshade_enqueue_terrain_point_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "hmax must be finite", "terrain point shadow: hmax NaN");
    p.hmax = 0.0f;
    CHECK(oclshade_enqueue_terrain_point_shadow(lib, queue, &p, 0, NULL, NULL));
    release(p.heights.buffer);
    p.heights = oclshade_field_of(NULL);
    const oclshade_field coefficient = p.coefficient;
    p.coefficient = oclshade_field_of(clCreateBuffer(ctx, CL_MEM_READ_ONLY, 4 * (size_t)n, NULL, &err));
    CLCHECK(err);
    expect_status(oclshade_enqueue_terrain_point_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "coefficient is written by the kernels but was created CL_MEM_READ_ONLY",
                  "terrain point shadow: read-only coefficient");
    release(p.coefficient.buffer);
    p.coefficient = p.gbuffer.object;
    expect_status(oclshade_enqueue_quadric_point_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "overlap", "quadric point shadow: coefficient aliases gbuffer.object");
    p.coefficient = coefficient;
    p.count = 0;
    expect_status(oclshade_enqueue_quadric_point_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "count must be the number of quadrics", "quadric point shadow: count 0");
    CHECK(oclshade_enqueue_terrain_point_shadow(lib, queue, &p, 0, NULL, NULL));   /* reads no quadric */
    p.count = 2;
    expect_status(oclshade_enqueue_quadric_point_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "qf must hold at least 160 bytes", "quadric point shadow: a table too small for count");
    p.count = 1;
    const oclshade_field coef_pitched = {coefficient.buffer, 4, 4 * (size_t)W};
    p.coefficient = coef_pitched;
    p.coefficient.buffer = buffer(4 * (size_t)n + 4, NULL);
    expect_status(oclshade_enqueue_terrain_point_shadow(lib, queue, &p, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "scratch", "terrain point shadow: a coefficient at an offset needs scratch");
    release(p.coefficient.buffer);
    p.coefficient = coefficient;
    CHECK(oclshade_enqueue_terrain_point_shadow(lib, queue, &p, 0, NULL, NULL));
    CHECK(oclshade_enqueue_quadric_point_shadow(lib, queue, &p, 0, NULL, NULL));
    bytes = 1;
    CHECK(oclshade_quadric_scratch_size(lib, &p, &bytes));
    expect(bytes == 0, "quadrics with a point light: no scratch for packed fields");

    /* reflections */
    oclshade_material m[2] = {{OCLSHADE_MIRROR, {1.0, 1.0, 1.0}, 0.0, 0.04, 0},
                              {OCLSHADE_DIFFUSE, {0.5, 0.5, 0.5}, 0.2, 0.04, 0}};
    cl_float4 table[6];
    oclshade_reflect_params r;
    oclshade_reflect_params_init(&r);
    expect_status(oclshade_reflect_tables(m, 2, &r.groups, table), OCLSHADE_INVALID_ARGUMENT, "",
                  "reflect tables: a rough diffuse material");
    m[1].roughness = 0.0;
    CHECK(oclshade_reflect_tables(m, 2, &r.groups, table));
    expect(r.groups.count == 1 && strcmp(r.groups.vector[0], "REFLECT") == 0, "reflect tables: one REFLECT group");
    r.width = W; r.height = H; r.camera = p.camera; r.objects = 2;
    r.materials = buffer(sizeof table, table);
    r.position = p.gbuffer.position; r.normal = p.gbuffer.normal; r.albedo = p.gbuffer.albedo; r.object = p.gbuffer.object;
    r.weighted = oclshade_field_of(buffer(16 * (size_t)n, NULL));
    r.face = 2; r.cubes = 1;
    r.cube = buffer(96 * 4 * 4, NULL);
    CHECK(oclshade_enqueue_zero(lib, queue, r.cube, 96 * 4 * 4, 0, NULL, NULL));
    r.acc = buffer(16 * (size_t)n, NULL);
    CHECK(oclshade_enqueue_reflect_weights(lib, queue, &r, 0, NULL, NULL));
    CHECK(oclshade_enqueue_reflect_apply(lib, queue, &r, 0, NULL, NULL));
    r.ssaa = 9;
    expect_status(oclshade_enqueue_reflect_weights(lib, queue, &r, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "ssaa must be in 1..8", "reflect: ssaa 9");
    r.ssaa = 2;
    expect_status(oclshade_enqueue_reflect_apply(lib, queue, &r, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "camera must be the G-buffer's, 16 x 12 samples", "reflect: a camera of the frame, not the samples");
    r.ssaa = 1;
    strcpy(r.groups.vector[0], "REFLECT 2X");
    expect_status(oclshade_enqueue_reflect_weights(lib, queue, &r, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "groups.vector[0]", "reflect: a condition that is not a name");
    strcpy(r.groups.vector[0], "REFLECT");
    r.intensity = -1.0;
    expect_status(oclshade_enqueue_reflect_apply(lib, queue, &r, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "intensity must be a finite number >= 0", "reflect: intensity -1");
    r.intensity = 1.0;
    r.cubes = 2;
    expect_status(oclshade_enqueue_reflect_apply(lib, queue, &r, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT,
                  "cube must hold at least 3072 bytes", "reflect: fewer maps than cubes");
    r.cubes = 1;
    const oclshade_field weighted = r.weighted;
    r.weighted = r.albedo;
    expect_status(oclshade_enqueue_reflect_weights(lib, queue, &r, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT, "overlap",
                  "reflect: weighted aliases albedo");
    expect_status(oclshade_enqueue_reflect_finish(lib, queue, &r, 0, NULL, NULL), OCLSHADE_INVALID_ARGUMENT, "frame",
                  "finish: no frame");

    /* the specialiser's own errors, and a build error naming the vector */
    char message[256];
    size_t need;
    expect(oclshade_specialize("a\n@IF X;\nb\n", "X", NULL, 0, &need, message, sizeof message) == OCLSHADE_SOURCE_ERROR &&
           strstr(message, "line 2: @IF not closed") != NULL, "specialize: an @IF left open names its line");
    expect(oclshade_specialize("x", "A-B", NULL, 0, &need, message, sizeof message) == OCLSHADE_SOURCE_ERROR &&
           strstr(message, "'A-B'") != NULL, "specialize: a bad condition vector is named");
    CLCHECK(clFinish(queue));
    release(p.qf); release(p.qi); release(p.shading.buffer); release(p.coefficient.buffer);
    for (int i = 0; i < 7; ++i) { release(gb_at(&p.objects, i)->buffer); release(gb_at(&p.gbuffer, i)->buffer); }
    release(r.materials); release(weighted.buffer); release(r.cube); release(r.acc);
    free(zeros);
}

/* ------------------------------------------------------------------ main */

int main(int argc, char **argv)
{
    if (argc < 3) fail("usage: host_objects COMMAND OUTDIR ARGS...");
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
    if (strcmp(argv[1], "specialize") == 0) run_specialize(argc - 3, argv + 3);
    else if (strcmp(argv[1], "quadrics") == 0) run_quadrics(argc - 3, argv + 3);
    else if (strcmp(argv[1], "point") == 0) run_point(argc - 3, argv + 3);
    else if (strcmp(argv[1], "reflect") == 0) run_reflect(argc - 3, argv + 3);
    else if (strcmp(argv[1], "errors") == 0) run_errors();
    else if (strcmp(argv[1], "expand") == 0) run_expand(argc - 3, argv + 3);
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
