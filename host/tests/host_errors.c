/* host_errors — error paths of the C host API, for tests/test_host_api.py.
 *
 * usage: host_errors KERNEL_DIR
 * Each check prints "ok <what>" or "FAIL <what>: <details>"; the exit status
 * is the number of failures.  Also prints one line per shadow program variant,
 * "options <method> <outputs> <build options>", the same for a handle on the
 * first device ("handle_options ..."), the handle's initial tuning
 * ("tuning <packet_lanes> <packet_run> <group>", oclshade_default_tuning of
 * the device) and the device's name ("device_name <CL_DEVICE_NAME>"), and
 * after oclshade_set_tuning with other values "tuned_tuning ..." and
 * "tuned_options ...", and every knob's rule value ("default_knob <family> <knob>
 * <value>"), which the Python test compares with the Python host's options and
 * tuning rule.  Covers the contract checks of every entry point (sizes, pitches,
 * read-only outputs, aliasing, scratch) and the camera's. */
#include "oclshade.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures;

static void expect(int cond, const char *what, const char *details)
{
    if (cond) {
        printf("ok %s\n", what);
    } else {
        printf("FAIL %s: %s\n", what, details);
        ++failures;
    }
}

/* st must be `want` and the message must contain `needle`. */
static void expect_status(oclshade *lib, oclshade_status st, oclshade_status want, const char *needle, const char *what)
{
    const char *msg = oclshade_last_error(lib);
    char details[1024];
    snprintf(details, sizeof details, "got %s, want %s; message: %.800s", oclshade_status_name(st),
             oclshade_status_name(want), msg);
    expect(st == want && strstr(msg, needle) != NULL, what, details);
}

static char *read_text(const char *dir, const char *name)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "rb");
    if (f == NULL) { fprintf(stderr, "cannot read %s\n", path); exit(100); }
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *text = (char *)malloc((size_t)n + 1);
    if (text == NULL || fread(text, 1, (size_t)n, f) != (size_t)n) exit(100);
    text[n] = '\0';
    fclose(f);
    return text;
}

/* "<prefix> <method> <outputs> <options>" for every shadow variant of the handle */
static void print_handle_options(const oclshade *lib, const char *prefix)
{
    char opts[256];
    for (int m = OCLSHADE_EXACT; m <= OCLSHADE_DDA; ++m) {
        for (unsigned o = 1; o < 8; ++o) {
            size_t need = oclshade_shadow_build_options_for(lib, (oclshade_method)m, o, opts, sizeof opts);
            printf("%s %d %u %s\n", prefix, m, o, need ? opts : "(none)");
        }
    }
}

static cl_mem buffer(cl_context ctx, size_t n);

/* q's scratch: a buffer of oclshade_horizon_scratch_size (blocks of row scales need their tables),
 * in place of the one *held */
static void size_horizon_scratch(oclshade *lib, cl_context ctx, oclshade_horizon_params *q, cl_mem *held)
{
    size_t bytes = 0;
    if (oclshade_horizon_scratch_size(lib, q, &bytes) != OCLSHADE_OK) return;   /* (the call names it) */
    if (*held) clReleaseMemObject(*held);
    *held = buffer(ctx, bytes);
    q->scratch = *held;
}

static cl_mem buffer(cl_context ctx, size_t n)
{
    cl_int err;
    cl_mem m = clCreateBuffer(ctx, CL_MEM_READ_WRITE, n, NULL, &err);
    if (err != CL_SUCCESS) { fprintf(stderr, "clCreateBuffer: %d\n", (int)err); exit(100); }
    return m;
}

int main(int argc, char **argv)
{
    if (argc != 2) { fprintf(stderr, "usage: %s KERNEL_DIR\n", argv[0]); return 100; }
    const char *dir = argv[1];
    cl_platform_id platform;
    cl_device_id device;
    cl_int err;
    if (clGetPlatformIDs(1, &platform, NULL) != CL_SUCCESS ||
        clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &device, NULL) != CL_SUCCESS) {
        fprintf(stderr, "no OpenCL device\n");
        return 100;
    }
    cl_context ctx = clCreateContext(NULL, 1, &device, NULL, NULL, &err);
    cl_context other_ctx = clCreateContext(NULL, 1, &device, NULL, NULL, &err);
    cl_command_queue queue = clCreateCommandQueue(ctx, device, 0, &err);
    cl_command_queue other_queue = clCreateCommandQueue(other_ctx, device, 0, &err);
    oclshade_status st;

    /* ---- pure host functions */
    char opts[192];
    for (int m = OCLSHADE_EXACT; m <= OCLSHADE_DDA; ++m) {
        for (unsigned o = 1; o < 8; ++o) {
            size_t need = oclshade_shadow_build_options((oclshade_method)m, o, opts, sizeof opts);
            printf("options %d %u %s\n", m, o, need ? opts : "(none)");
        }
    }
    expect(oclshade_shadow_build_options(OCLSHADE_EXACT, 0, opts, sizeof opts) == 0, "build options: empty outputs", "");
    expect(oclshade_shadow_build_options((oclshade_method)5, 1, opts, sizeof opts) == 0, "build options: bad method", "");
    size_t need = oclshade_shadow_build_options(OCLSHADE_EXACT, 7, opts, 4);
    expect(need == strlen("-DOCLS_CERT=16 -DOCLS_CERT_K=6 -DOCLS_METHOD=1 -DOCLS_OUT_COEF -DOCLS_OUT_MASK -DOCLS_OUT_SELF -cl-std=CL1.2") + 1 &&
           strlen(opts) == 3, "build options: truncation reports the size needed", opts);

    oclshade_pyramid_layout lay;
    expect(oclshade_pyramid_layout_for(0, 5, &lay) == OCLSHADE_INVALID_ARGUMENT, "layout: rows 0", "");
    expect(oclshade_pyramid_layout_for(65536, 32768, &lay) == OCLSHADE_INVALID_ARGUMENT, "layout: 2^31 cells", "");
    expect(oclshade_pyramid_layout_for(1, 1, &lay) == OCLSHADE_OK && lay.levels == 2 && lay.texels == 1 &&
           lay.offsets[0] == -1 && lay.offsets[1] == 0, "layout: 1 x 1 map has one 1 x 1 level", "");
    oclshade_sun sun;
    expect(oclshade_sun_for(0, 90.5, 1, 1, &sun) == OCLSHADE_INVALID_ARGUMENT, "sun: elevation > 90", "");
    expect(oclshade_sun_for(NAN, 10, 1, 1, &sun) == OCLSHADE_INVALID_ARGUMENT, "sun: NaN azimuth", "");
    expect(oclshade_sun_for(0, 10, 0, 1, &sun) == OCLSHADE_INVALID_ARGUMENT, "sun: dx 0", "");
    double hs[3] = {1.0, INFINITY, 2.0}, offset = -1;
    float rel[3];
    expect(oclshade_relative_heights(hs, 3, rel, NULL) == OCLSHADE_INVALID_ARGUMENT, "relative heights: inf", "");
    hs[0] = hs[1] = hs[2] = NAN;
    expect(oclshade_relative_heights(hs, 3, rel, &offset) == OCLSHADE_OK && offset == 0.0 && isnan(rel[1]),
           "relative heights: all NaN gives offset 0 and NaN", "");

    /* ---- creation failures */
    oclshade *lib = NULL;
    st = oclshade_create(ctx, device, "/nonexistent/oclshade-kernels", &lib);
    expect_status(lib, st, OCLSHADE_SOURCE_ERROR, "/nonexistent/oclshade-kernels/pyramid.cl", "create: missing kernel dir");
    expect(lib != NULL, "create: a failed handle is returned", "");
    st = oclshade_prepare(lib, OCLSHADE_EXACT, OCLSHADE_OUT_MASK);
    expect_status(lib, st, OCLSHADE_SOURCE_ERROR, "nonexistent", "failed handle: calls report the creation failure");
    oclshade_tuning safe = {0, 1024, 64};
    expect(oclshade_set_tuning(lib, &safe) == OCLSHADE_SOURCE_ERROR && oclshade_get_tuning(lib, &safe) == OCLSHADE_SOURCE_ERROR,
           "failed handle: tuning calls report the creation failure", "");
    oclshade_destroy(lib);

    st = oclshade_create(NULL, device, dir, &lib);
    expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "context", "create: NULL context");
    oclshade_destroy(lib);
    expect(oclshade_create(ctx, device, dir, NULL) == OCLSHADE_INVALID_ARGUMENT, "create: NULL out", "");

    char *common = read_text(dir, "common.h"), *pyramid = read_text(dir, "pyramid.cl");
    char *terrain = read_text(dir, "terrain.cl"), *ssao = read_text(dir, "ssao.cl"), *compose = read_text(dir, "compose.cl");
    char *sunshine = read_text(dir, "sunshine.cl"), *horizon = read_text(dir, "horizon.cl");
    char *cubemap = read_text(dir, "cubemap.h"), *envmap = read_text(dir, "envmap.cl");
    char *quadric = read_text(dir, "quadric.cl"), *reflect = read_text(dir, "reflect.cl");
    char *terrain_ray = read_text(dir, "terrain_ray.h"), *mesh = read_text(dir, "mesh.cl");
    char *shadow_volume = read_text(dir, "shadow_volume.cl");
    oclshade_source missing[2] = {{"common.h", common}, {"pyramid.cl", pyramid}};
    st = oclshade_create_from_sources(ctx, device, missing, 2, &lib);
    expect_status(lib, st, OCLSHADE_SOURCE_ERROR, "shadow.cl", "create_from_sources: shadow.cl missing");
    oclshade_destroy(lib);

    /* ---- a build failure carries the compiler log */
    const char *broken = "#include \"common.h\"\n"
                         "__kernel void shadow_cells(__global float *h) { h[0] = oclshade_no_such_name; }\n";
    oclshade_source sources[15] = {{"common.h", common}, {"pyramid.cl", pyramid}, {"shadow.cl", broken},
                                  {"terrain.cl", terrain}, {"ssao.cl", ssao}, {"compose.cl", compose},
                                  {"sunshine.cl", sunshine}, {"horizon.cl", horizon},
                                   {"cubemap.h", cubemap}, {"envmap.cl", envmap},
                                   {"quadric.cl", quadric}, {"terrain_ray.h", terrain_ray}, {"reflect.cl", reflect},
                                   {"mesh.cl", mesh}, {"shadow_volume.cl", shadow_volume}};
    st = oclshade_create_from_sources(ctx, device, sources, 15, &lib);
    expect_status(lib, st, OCLSHADE_OK, "", "create_from_sources: broken shadow.cl is read");
    st = oclshade_prepare(lib, OCLSHADE_PAPER, OCLSHADE_OUT_MASK | OCLSHADE_OUT_SELF);
    expect_status(lib, st, OCLSHADE_BUILD_FAILED, "oclshade_no_such_name", "build failure: the log names the error");
    expect_status(lib, st, OCLSHADE_BUILD_FAILED, "-DOCLS_METHOD=2 -DOCLS_OUT_MASK -DOCLS_OUT_SELF",
                  "build failure: the message gives the options");
    expect(oclshade_last_cl_error(lib) == CL_BUILD_PROGRAM_FAILURE, "build failure: CL error code", "");
    oclshade_destroy(lib);

    /* ---- argument checks on a working handle */
    st = oclshade_create(ctx, device, dir, &lib);
    expect_status(lib, st, OCLSHADE_OK, "", "create from the kernel dir");
    oclshade_tuning tuning, def;
    st = oclshade_get_tuning(lib, &tuning);
    expect(st == OCLSHADE_OK, "get_tuning", oclshade_status_name(st));
    expect(oclshade_default_tuning(device, &def) == OCLSHADE_OK && def.packet_lanes == tuning.packet_lanes &&
           def.packet_run == tuning.packet_run && def.group == tuning.group,
           "a new handle starts with oclshade_default_tuning(device)", "");
    printf("tuning %d %d %d\n", tuning.packet_lanes, tuning.packet_run, tuning.group);
    char device_name[256] = "";
    clGetDeviceInfo(device, CL_DEVICE_NAME, sizeof device_name - 1, device_name, NULL);
    printf("device_name %s\n", device_name);
    print_handle_options(lib, "handle_options");
    const int rows = 5, cols = 7, n = rows * cols;
    oclshade_pyramid_layout_for(rows, cols, &lay);
    cl_mem heights = buffer(ctx, 4 * n), pyr = buffer(ctx, lay.pyramid_bytes), offs = buffer(ctx, lay.offsets_bytes);
    cl_mem small = buffer(ctx, 4), mask = buffer(ctx, n), foreign = clCreateBuffer(other_ctx, CL_MEM_READ_WRITE, 4 * n, NULL, &err);
    float zeros[35] = {0};
    clEnqueueWriteBuffer(queue, heights, CL_TRUE, 0, sizeof zeros, zeros, 0, NULL, NULL);

    const oclshade_field fh = oclshade_field_of(heights), ff = oclshade_field_of(foreign);
    st = oclshade_enqueue_extrema_pyramid(lib, queue, &fh, rows, cols, small, offs, NULL, 0, NULL, NULL);
    expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "pyramid must hold at least", "pyramid: buffer too small");
    st = oclshade_enqueue_extrema_pyramid(lib, queue, &ff, rows, cols, pyr, offs, NULL, 0, NULL, NULL);
    expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "heights must be a buffer", "pyramid: buffer of another context");
    st = oclshade_enqueue_extrema_pyramid(lib, other_queue, &fh, rows, cols, pyr, offs, NULL, 0, NULL, NULL);
    expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "queue must belong", "pyramid: queue of another context");
    st = oclshade_enqueue_extrema_pyramid(lib, queue, &fh, rows, cols, pyr, offs, NULL, 1, NULL, NULL);
    expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "event_wait_list", "pyramid: inconsistent wait list");
    st = oclshade_enqueue_extrema_pyramid(lib, queue, &fh, rows, cols, pyr, pyr, NULL, 0, NULL, NULL);
    expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "pyramid and offsets overlap", "pyramid: offsets alias the pyramid");
    st = oclshade_enqueue_extrema_pyramid(lib, queue, &fh, rows, cols, heights, offs, NULL, 0, NULL, NULL);
    expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "heights and pyramid overlap", "pyramid: output aliases the input");
    {
        cl_mem ro = clCreateBuffer(ctx, CL_MEM_READ_ONLY, lay.pyramid_bytes, NULL, &err);
        st = oclshade_enqueue_extrema_pyramid(lib, queue, &fh, rows, cols, ro, offs, NULL, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "pyramid is written by the kernels but was created CL_MEM_READ_ONLY",
                      "pyramid: a read-only buffer as output");
        cl_mem wo = clCreateBuffer(ctx, CL_MEM_WRITE_ONLY, 4 * n, NULL, &err);
        const oclshade_field fwo = oclshade_field_of(wo);
        st = oclshade_enqueue_extrema_pyramid(lib, queue, &fwo, rows, cols, pyr, offs, NULL, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "heights is read by the kernels but was created CL_MEM_WRITE_ONLY",
                      "pyramid: a write-only buffer as input");
        /* sub-buffers of one buffer: overlapping ranges are caught, disjoint ones pass */
        cl_mem big = clCreateBuffer(ctx, CL_MEM_READ_WRITE, 4096, NULL, &err);
        cl_buffer_region r0 = {0, 1024}, r1 = {0, 512}, r2 = {2048, 1024};
        cl_mem s0 = clCreateSubBuffer(big, 0, CL_BUFFER_CREATE_TYPE_REGION, &r0, &err);
        cl_mem s1 = clCreateSubBuffer(big, 0, CL_BUFFER_CREATE_TYPE_REGION, &r1, &err);
        cl_mem s2 = clCreateSubBuffer(big, 0, CL_BUFFER_CREATE_TYPE_REGION, &r2, &err);
        st = oclshade_enqueue_extrema_pyramid(lib, queue, &fh, rows, cols, s0, s1, NULL, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "pyramid and offsets overlap (bytes 0..",
                      "pyramid: overlapping sub-buffers of one buffer");
        st = oclshade_enqueue_extrema_pyramid(lib, queue, &fh, rows, cols, s0, s2, NULL, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "pyramid: disjoint sub-buffers of one buffer");
        clFinish(queue);
        /* a field at an offset, rows padded: copied into the scratch, which must then be given */
        cl_mem padded = clCreateBuffer(ctx, CL_MEM_READ_WRITE, 64 + 40 * rows, NULL, &err);
        const oclshade_field fp = {padded, 64, 40};
        size_t need = 0;
        st = oclshade_extrema_pyramid_scratch_size(lib, &fp, rows, cols, &need);
        expect(st == OCLSHADE_OK && need >= 4u * n, "pyramid: a pitched field needs scratch for its packed copy", "");
        size_t none = 1;
        st = oclshade_extrema_pyramid_scratch_size(lib, &fh, rows, cols, &none);
        expect(st == OCLSHADE_OK && none == 0, "pyramid: a packed field needs no scratch", "");
        st = oclshade_enqueue_extrema_pyramid(lib, queue, &fp, rows, cols, pyr, offs, NULL, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "scratch must be a buffer of at least", "pyramid: scratch missing");
        cl_mem sc = clCreateBuffer(ctx, CL_MEM_READ_WRITE, need, NULL, &err);
        st = oclshade_enqueue_extrema_pyramid(lib, queue, &fp, rows, cols, pyr, offs, small, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "scratch must hold at least", "pyramid: scratch too small");
        st = oclshade_enqueue_extrema_pyramid(lib, queue, &fp, rows, cols, pyr, offs, padded, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "overlap", "pyramid: scratch aliases an input");
        const oclshade_field narrow = {padded, 0, 12};
        st = oclshade_enqueue_extrema_pyramid(lib, queue, &narrow, rows, cols, pyr, offs, sc, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "row_pitch must be 0 (packed) or >= 28", "pyramid: pitch below a row");
        const oclshade_field beyond = {padded, 128, 40};
        st = oclshade_enqueue_extrema_pyramid(lib, queue, &beyond, rows, cols, pyr, offs, sc, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "heights must hold at least 316 bytes",
                      "pyramid: offset + rows past the buffer's end");
        st = oclshade_enqueue_extrema_pyramid(lib, queue, &fp, rows, cols, pyr, offs, sc, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "pyramid: a pitched field with scratch");
        clFinish(queue);
        clReleaseMemObject(sc); clReleaseMemObject(padded);
        clReleaseMemObject(s0); clReleaseMemObject(s1); clReleaseMemObject(s2); clReleaseMemObject(big);
        clReleaseMemObject(ro); clReleaseMemObject(wo);
    }
    st = oclshade_enqueue_extrema_pyramid(lib, queue, &fh, rows, cols, pyr, offs, NULL, 0, NULL, NULL);
    expect_status(lib, st, OCLSHADE_OK, "", "pyramid: success clears the message");
    expect(oclshade_last_error(lib)[0] == '\0', "pyramid: empty message after success", oclshade_last_error(lib));

    oclshade_shadow_params p;
    oclshade_shadow_params_init(&p);
    p.heights = fh; p.rows = rows; p.cols = cols; p.pyramid = pyr; p.offsets = offs; p.mask = oclshade_field_of(mask);
    st = oclshade_enqueue_shadows(lib, queue, &p, 0, NULL, NULL);
    expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "scratch must be a buffer of at least",
                  "shadows: exact needs scratch for its certificates");
    size_t cert_bytes = 0;
    st = oclshade_shadows_scratch_size(lib, &p, &cert_bytes);
    expect(st == OCLSHADE_OK && cert_bytes == 6 * 4, "shadows: scratch size = one tile's 6 certificates", "");
    cl_mem cert = buffer(ctx, cert_bytes);
    p.scratch = cert;
    st = oclshade_enqueue_shadows(lib, queue, &p, 0, NULL, NULL);
    expect_status(lib, st, OCLSHADE_OK, "", "shadows: valid parameters");
    {
        oclshade_shadow_params dda = p;
        dda.method = OCLSHADE_DDA;
        dda.scratch = NULL;
        size_t zero = 1;
        expect(oclshade_shadows_scratch_size(lib, &dda, &zero) == OCLSHADE_OK && zero == 0, "shadows: dda needs no scratch", "");
        st = oclshade_enqueue_shadows(lib, queue, &dda, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "shadows: dda without scratch");
        oclshade_shadow_params alias = p;
        alias.coefficient = oclshade_field_of(heights);
        st = oclshade_enqueue_shadows(lib, queue, &alias, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "heights and coefficient overlap", "shadows: output aliases heights");
        alias = p;
        alias.self_shadow = oclshade_field_of(mask);
        st = oclshade_enqueue_shadows(lib, queue, &alias, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "mask and self_shadow overlap", "shadows: two outputs alias");
        alias = p;
        alias.scratch = pyr;
        st = oclshade_enqueue_shadows(lib, queue, &alias, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "pyramid and scratch overlap", "shadows: scratch aliases the pyramid");
    }
    clFinish(queue);
    clFinish(queue);

    struct { const char *what, *needle; oclshade_shadow_params q; } bad[14];
    for (int i = 0; i < 14; ++i) bad[i].q = p;
    bad[0].what = "shadows: rows 0"; bad[0].needle = "rows and cols"; bad[0].q.rows = 0;
    bad[1].what = "shadows: dx negative"; bad[1].needle = "dx and dy"; bad[1].q.dx = -1;
    bad[2].what = "shadows: elevation 91"; bad[2].needle = "elevation must be in [-90, 90]"; bad[2].q.elevation = 91;
    bad[3].what = "shadows: azimuth inf"; bad[3].needle = "azimuth"; bad[3].q.azimuth = INFINITY;
    bad[4].what = "shadows: k_bright 2"; bad[4].needle = "k_dark and k_bright"; bad[4].q.k_bright = 2;
    bad[5].what = "shadows: no output"; bad[5].needle = "at least one of mask"; bad[5].q.mask.buffer = NULL;
    bad[6].what = "shadows: method 9"; bad[6].needle = "method must be"; bad[6].q.method = (oclshade_method)9;
    bad[7].what = "shadows: mask too small"; bad[7].needle = "mask must hold at least 35 bytes"; bad[7].q.mask.buffer = small;
    bad[8].what = "shadows: heights NULL"; bad[8].needle = "heights must be"; bad[8].q.heights.buffer = NULL;
    bad[9].what = "shadows: offsets too small"; bad[9].needle = "offsets must hold"; bad[9].q.offsets = small;
    bad[10].what = "shadows: coefficient too small"; bad[10].needle = "coefficient must hold"; bad[10].q.coefficient.buffer = mask;
    bad[11].what = "shadows: scratch too small"; bad[11].needle = "scratch must hold at least 24 bytes"; bad[11].q.scratch = small;
    bad[12].what = "shadows: origin_row -1"; bad[12].needle = "origin_row and origin_col must be >= 0";
    bad[12].q.origin_row = -1;
    bad[13].what = "shadows: origin_col 2^30"; bad[13].needle = "origin + size <= 2^30, got origin (0, 1073741824)";
    bad[13].q.origin_col = 1 << 30;
    for (int i = 0; i < 14; ++i) {
        st = oclshade_enqueue_shadows(lib, queue, &bad[i].q, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, bad[i].needle, bad[i].what);
    }
    {   /* a sun field in one launch: its blocks checked by name */
        const int rows_e[3] = {0, 2, p.rows}, cols_e[2] = {0, p.cols}, back[3] = {0, 3, 2};
        double suns[4] = {120.0, 30.0, 200.0, 91.0};
        oclshade_shadow_params f = p;
        f.field_row_blocks = 2; f.field_col_blocks = 0;
        st = oclshade_enqueue_shadows(lib, queue, &f, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "field_row_blocks and field_col_blocks must both be 0 (one "
                      "sun) or both >= 1, got 2, 0", "shadows: a field of 2 x 0 blocks");
        f.field_col_blocks = 1;
        st = oclshade_enqueue_shadows(lib, queue, &f, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "field_row_edges must point to 2 + 1 edges, got NULL",
                      "shadows: a field without edges");
        f.field_row_edges = back; f.field_col_edges = cols_e;
        st = oclshade_enqueue_shadows(lib, queue, &f, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "field_row_edges must run from 0 to", "shadows: a field's "
                      "rows not reaching the map's end");
        f.field_row_edges = rows_e;
        st = oclshade_enqueue_shadows(lib, queue, &f, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "field_suns must point to 2 x 2 degrees, got NULL",
                      "shadows: a field without suns");
        f.field_suns = suns;
        st = oclshade_enqueue_shadows(lib, queue, &f, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "field_suns of block 1 must be a finite azimuth and an "
                      "elevation in [-90, 90] degrees, got 200, 91", "shadows: a field's sun at 91 degrees");
        f.block_rows = 1; f.block_cols = 1;
        st = oclshade_enqueue_shadows(lib, queue, &f, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "a sun field (field_row_blocks 2) is the whole map's: "
                      "block_rows and block_cols must be 0", "shadows: a field in a block window");
        f.block_rows = f.block_cols = 0;
        suns[3] = 20.0;
        size_t need = 0;
        st = oclshade_shadows_scratch_size(lib, &f, &need);
        expect_status(lib, st, OCLSHADE_OK, "", "shadows: a field's scratch size");
        expect(need >= (size_t)(p.rows + p.cols) * 4 + 2 * 32 + 2 * 4, "shadows: a field's scratch holds its table", "");
    }
    st = oclshade_enqueue_shadows(lib, queue, NULL, 0, NULL, NULL);
    expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "params", "shadows: NULL params");
    st = oclshade_enqueue_shadows(lib, NULL, &p, 0, NULL, NULL);
    expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "queue", "shadows: NULL queue");
    st = oclshade_prepare(lib, OCLSHADE_DDA, 0);
    expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "outputs must be", "prepare: no outputs");

    /* ---- tuning */
    expect(oclshade_default_tuning(NULL, &def) == OCLSHADE_INVALID_ARGUMENT && def.packet_lanes == 0 &&
           def.packet_run == 1024 && def.group == 64, "default_tuning: NULL device gives the safe values", "");
    expect(oclshade_default_tuning(device, NULL) == OCLSHADE_INVALID_ARGUMENT, "default_tuning: NULL out", "");
    expect(oclshade_get_tuning(NULL, &tuning) == OCLSHADE_INVALID_ARGUMENT &&
           oclshade_get_tuning(lib, NULL) == OCLSHADE_INVALID_ARGUMENT, "get_tuning: NULL arguments", "");
    st = oclshade_set_tuning(lib, NULL);
    expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "tuning must point", "set_tuning: NULL");
    struct { const char *what, *needle; oclshade_tuning t; } bad_tuning[6] = {
        {"set_tuning: lanes 5", "packet_lanes must be 0, 4, 8 or 16", {5, 1024, 64}},
        {"set_tuning: lanes 32", "got 32", {32, 1024, 64}},
        {"set_tuning: run 100", "packet_run must be 16, 64, 256 or 1024", {0, 100, 64}},
        {"set_tuning: run 0", "got 0", {4, 0, 64}},
        {"set_tuning: group 0", "group must be 16, 64 or 256", {0, 1024, 0}},
        {"set_tuning: group 128", "group must be 16, 64 or 256", {8, 1024, 128}},
    };
    for (int i = 0; i < 6; ++i) {
        st = oclshade_set_tuning(lib, &bad_tuning[i].t);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, bad_tuning[i].needle, bad_tuning[i].what);
    }
    oclshade_tuning now;
    expect(oclshade_get_tuning(lib, &now) == OCLSHADE_OK && now.packet_lanes == tuning.packet_lanes &&
           now.packet_run == tuning.packet_run && now.group == tuning.group,
           "set_tuning: rejected values leave the tuning unchanged", "");
    const oclshade_tuning lanes4 = {4, 16, 16};
    st = oclshade_set_tuning(lib, &lanes4);
    expect_status(lib, st, OCLSHADE_OK, "", "set_tuning: lanes 4, run 16, group 16");
    expect(oclshade_get_tuning(lib, &now) == OCLSHADE_OK && now.packet_lanes == 4 && now.packet_run == 16 &&
           now.group == 16, "get_tuning returns the values set", "");
    oclshade_shadow_build_options_for(lib, OCLSHADE_EXACT, OCLSHADE_OUT_MASK, opts, sizeof opts);
    expect(strstr(opts, "-DOCLS_LANES=4 ") != NULL && strstr(opts, "-DOCLS_PACKET=16 ") != NULL,
           "set_tuning: the handle's exact options have -DOCLS_LANES=4 -DOCLS_PACKET=16", opts);
    printf("tuned_tuning %d %d %d\n", now.packet_lanes, now.packet_run, now.group);
    print_handle_options(lib, "tuned_options");
    /* the variant built before is rebuilt with the new knobs, and still works */
    st = oclshade_enqueue_shadows(lib, queue, &p, 0, NULL, NULL);
    expect_status(lib, st, OCLSHADE_OK, "", "shadows: after set_tuning");
    unsigned char got[35];
    memset(got, 7, sizeof got);
    clEnqueueReadBuffer(queue, mask, CL_TRUE, 0, sizeof got, got, 0, NULL, NULL);
    int lit = 1;
    for (int i = 0; i < n; ++i) lit &= got[i] == 0;
    expect(lit, "shadows: a flat map is lit after set_tuning", "");
    const oclshade_tuning scalar = {0, 1024, 256};
    st = oclshade_set_tuning(lib, &scalar);
    expect_status(lib, st, OCLSHADE_OK, "", "set_tuning: lanes 0");
    /* the rule inlines built-ins on PoCL 3.0 (-DOCLS_OWN_BUILTINS), which the plain options do not have */
    expect(oclshade_set_knob(lib, "shadow", "own_builtins", 0) == OCLSHADE_OK, "set_knob shadow own_builtins 0", "");
    char plain[256];
    oclshade_shadow_build_options_for(lib, OCLSHADE_MAXMIP, 7, opts, sizeof opts);
    oclshade_shadow_build_options(OCLSHADE_MAXMIP, 7, plain, sizeof plain);
    expect(strcmp(opts, plain) == 0, "set_tuning: lanes 0 gives oclshade_shadow_build_options", opts);
    expect(strcmp(oclshade_version(), "0.3.0") == 0 && OCLSHADE_VERSION_MINOR == 3, "version 0.3.0", oclshade_version());
    expect(strcmp(oclshade_status_name(OCLSHADE_BUILD_FAILED), "OCLSHADE_BUILD_FAILED") == 0, "status names", "");

    /* ---- the other families' argument checks */
    {
        cl_mem f4 = buffer(ctx, 16 * n), f4b = buffer(ctx, 16 * n), f1 = buffer(ctx, 4 * n), f2 = buffer(ctx, 8 * n);
        const float zero = 0.0f;   /* empty pixels everywhere: the valid calls below run on defined data */
        clEnqueueFillBuffer(queue, f4, &zero, 4, 0, 16 * n, 0, NULL, NULL);
        clEnqueueFillBuffer(queue, f4b, &zero, 4, 0, 16 * n, 0, NULL, NULL);
        clEnqueueFillBuffer(queue, f2, &zero, 4, 0, 8 * n, 0, NULL, NULL);
        oclshade_mip_layout ml;
        expect(oclshade_mip_layout_for(lib, rows, cols, &ml) == OCLSHADE_OK && ml.levels == 4 && ml.level_rows[1] == 3 &&
               ml.level_cols[3] == 1 && ml.offsets[2] % 16 == 0, "mip layout: 5 x 7 has 4 levels, aligned", "");
        st = oclshade_enqueue_mip_pyramid(lib, queue, &fh, rows, cols, small, NULL, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "mip must hold at least", "mip: buffer too small");

        oclshade_camera cam, cam2;
        double pos[3] = {0, -50, 40}, at[3] = {0, -50, 40};
        expect(oclshade_camera_look_at(pos, at, NULL, 7, 5, OCLSHADE_PERSPECTIVE, 45, 1, 1, 100, &cam) ==
               OCLSHADE_INVALID_ARGUMENT, "camera: target at the position", "");
        at[1] = 0; at[2] = 0;
        expect(oclshade_camera_look_at(pos, at, NULL, 7, 5, OCLSHADE_PERSPECTIVE, 180, 1, 1, 100, &cam) ==
               OCLSHADE_INVALID_ARGUMENT, "camera: fov 180", "");
        expect(oclshade_camera_look_at(pos, at, NULL, 7, 5, OCLSHADE_PERSPECTIVE, 45, 1, 0, 100, &cam) ==
               OCLSHADE_INVALID_ARGUMENT, "camera: perspective near 0", "");
        expect(oclshade_camera_look_at(pos, at, NULL, 0, 5, OCLSHADE_PERSPECTIVE, 45, 1, 1, 100, &cam) ==
               OCLSHADE_INVALID_ARGUMENT, "camera: width 0", "");
        expect(oclshade_camera_look_at(pos, at, NULL, 7, 5, OCLSHADE_PERSPECTIVE, 45, 1, 1, 100, &cam) == OCLSHADE_OK &&
               oclshade_camera_from_matrices(cam.view, cam.projection_matrix, 7, 5, &cam2) == OCLSHADE_OK &&
               fabs(cam2.sx - cam.sx) < 1e-15 && fabs(cam2.near_depth - 1) < 1e-12 && fabs(cam2.far_depth - 100) < 1e-9,
               "camera: from its own matrices", "");
        double skewed[16], shifted[16];
        memcpy(skewed, cam.view, sizeof skewed);
        memcpy(shifted, cam.projection_matrix, sizeof shifted);
        skewed[0] *= 2.0;
        shifted[2] = 0.1;
        expect(oclshade_camera_from_matrices(skewed, cam.projection_matrix, 7, 5, &cam2) == OCLSHADE_INVALID_ARGUMENT,
               "camera: a scaled view is not rigid", "");
        expect(oclshade_camera_from_matrices(cam.view, shifted, 7, 5, &cam2) == OCLSHADE_INVALID_ARGUMENT,
               "camera: an off-centre projection", "");

        oclshade_ssao_params sp;
        oclshade_ssao_params_init(&sp);
        sp.position = oclshade_field_of(f4); sp.normal = oclshade_field_of(f4b); sp.ao = oclshade_field_of(f1);
        sp.width = cols; sp.height = rows; sp.radius = 10.0;
        memcpy(sp.projection, cam.projection_matrix, sizeof sp.projection);
        size_t need = 0;
        expect(oclshade_ssao_scratch_size(lib, &sp, &need) == OCLSHADE_OK && need >= 32u * (size_t)n + 64 + 12 * 8,
               "ssao: scratch for depth, normals, AO, box sums, projection rows and table", "");
        cl_mem ssao_scratch = buffer(ctx, need);
        sp.scratch = ssao_scratch;
        struct { const char *what, *needle; oclshade_ssao_params q; } bad_ssao[8];
        for (int i = 0; i < 8; ++i) bad_ssao[i].q = sp;
        bad_ssao[0].what = "ssao: radius 0"; bad_ssao[0].needle = "radius must be positive"; bad_ssao[0].q.radius = 0;
        bad_ssao[1].what = "ssao: m 3"; bad_ssao[1].needle = "m must be an integer in 4..256"; bad_ssao[1].q.m = 3;
        bad_ssao[2].what = "ssao: normal map without tangents"; bad_ssao[2].needle = "normal_map and tangent go together";
        bad_ssao[2].q.normal_map = oclshade_field_of(f4);
        bad_ssao[3].what = "ssao: blur size 4"; bad_ssao[3].needle = "blur_size must be an odd integer >= 3";
        bad_ssao[3].q.blur_size = 4;
        bad_ssao[4].what = "ssao: projection of rank 2"; bad_ssao[4].needle = "must have rank 3";
        memset(bad_ssao[4].q.projection, 0, sizeof bad_ssao[4].q.projection);
        bad_ssao[5].what = "ssao: output aliases the positions"; bad_ssao[5].needle = "position and ao overlap";
        bad_ssao[5].q.ao = oclshade_field_of(f4);
        bad_ssao[6].what = "ssao: no scratch"; bad_ssao[6].needle = "scratch must be a buffer of at least";
        bad_ssao[6].q.scratch = NULL;
        bad_ssao[7].what = "ssao: positions too small"; bad_ssao[7].needle = "position must hold at least 560 bytes";
        bad_ssao[7].q.position = oclshade_field_of(f1);
        for (int i = 0; i < 8; ++i) {
            st = oclshade_enqueue_ssao(lib, queue, &bad_ssao[i].q, 0, NULL, NULL);
            expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, bad_ssao[i].needle, bad_ssao[i].what);
        }

        oclshade_pixel_shadow_params pp;
        oclshade_pixel_shadow_params_init(&pp);
        oclshade_coarse_layout cl;
        oclshade_coarse_layout_for(rows, cols, &cl);
        cl_mem coarse = buffer(ctx, cl.grids_bytes), coarse_off = buffer(ctx, cl.offsets_bytes), flag = buffer(ctx, n);
        clEnqueueFillBuffer(queue, coarse, &zero, 4, 0, cl.grids_bytes, 0, NULL, NULL);
        clEnqueueWriteBuffer(queue, coarse_off, CL_TRUE, 0, cl.offsets_bytes, cl.offsets, 0, NULL, NULL);
        pp.heights = fh; pp.rows = rows; pp.cols = cols; pp.pyramid = pyr; pp.offsets = offs;
        pp.coarse = coarse; pp.coarse_offsets = coarse_off;
        pp.position = oclshade_field_of(f4); pp.uv = oclshade_field_of(f2); pp.uv_grad = oclshade_field_of(f4b);
        pp.width = cols; pp.height = rows; pp.flag = oclshade_field_of(flag);
        oclshade_pixel_shadow_params q = pp;
        q.force_q = 9;
        st = oclshade_enqueue_pixel_shadows(lib, queue, &q, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "force_q must be -1 (Algo 1) or a level in [0, 3]",
                      "pixels: force_q above the top level");
        q = pp;
        q.flag = oclshade_field_of(NULL);
        st = oclshade_enqueue_pixel_shadows(lib, queue, &q, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "at least one of flag, coefficient, lod", "pixels: no output");
        q = pp;
        q.coarse = small;
        st = oclshade_enqueue_pixel_shadows(lib, queue, &q, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "coarse must hold at least", "pixels: coarse grids too small");
        q = pp;
        q.flag = oclshade_field_of(f2);   /* aliases uv */
        st = oclshade_enqueue_pixel_shadows(lib, queue, &q, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "uv and flag overlap", "pixels: output aliases an input");
        size_t none = 1;
        expect(oclshade_pixel_shadows_scratch_size(lib, &pp, &none) == OCLSHADE_OK && none == 0,
               "pixels: packed fields need no scratch", "");
        st = oclshade_enqueue_pixel_shadows(lib, queue, &pp, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "pixels: valid parameters");

        oclshade_compose_params cp;
        oclshade_compose_params_init(&cp);
        cp.position = oclshade_field_of(f4); cp.normal = oclshade_field_of(f4b); cp.albedo = oclshade_field_of(f4b);
        cp.image = oclshade_field_of(f1); cp.width = cols; cp.height = rows;
        oclshade_compose_params cq = cp;
        cq.ssaa = 9;
        st = oclshade_enqueue_compose(lib, queue, &cq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "ssaa must be an integer in 1..8", "compose: ssaa 9");
        cq = cp;
        cq.ssaa = 2;
        st = oclshade_enqueue_compose(lib, queue, &cq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "position must hold at least 2240 bytes",
                      "compose: ssaa 2 reads 4 samples a pixel");
        cq = cp;
        cq.elevation = 95;
        st = oclshade_enqueue_compose(lib, queue, &cq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "elevation in [-90, 90]", "compose: sun below -90 / above 90");
        st = oclshade_enqueue_compose(lib, queue, &cp, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "compose: valid (normal and albedo may share a buffer: both read)");
        cq = cp;
        cq.point_light = 2;
        st = oclshade_enqueue_compose(lib, queue, &cq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "point_light must be 0 (the sun: azimuth, elevation) or 1",
                      "compose: point_light 2");
        cq.point_light = 1;
        cq.elevation = 95;   /* the sun is not read with a point light */
        cq.light_position[2] = INFINITY;
        st = oclshade_enqueue_compose(lib, queue, &cq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "light_position and translation must be finite",
                      "compose: a point light at infinity");
        cq.light_position[2] = 100.0;
        cq.translation[0] = NAN;
        st = oclshade_enqueue_compose(lib, queue, &cq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "translation[0] nan", "compose: a NaN view translation");
        cq.translation[0] = 0.0;
        cq.light_distance = -1.0;
        st = oclshade_enqueue_compose(lib, queue, &cq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "light_distance must be the falloff's reference distance, "
                      "> 0 metres, or 0 for no falloff, got -1", "compose: light_distance -1");
        cq.light_distance = 50.0;
        st = oclshade_enqueue_compose(lib, queue, &cq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "compose: a valid point light (the sun's elevation unread)");

        oclshade_terrain_params tp;
        oclshade_terrain_params_init(&tp);
        tp.heights = fh; tp.rows = rows; tp.cols = cols; tp.pyramid = pyr; tp.offsets = offs;
        oclshade_terrain_params tq = tp;
        tq.method = (oclshade_caster)7;
        st = oclshade_enqueue_terrain(lib, queue, &tq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "method must be OCLSHADE_CAST_BISECT", "terrain: method 7");
        tq = tp;
        tq.texture = f4;
        st = oclshade_enqueue_terrain(lib, queue, &tq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "texture and texture_levels go together", "terrain: texture alone");
        tq = tp;
        tq.hmin = 2; tq.hmax = 1;
        st = oclshade_enqueue_terrain(lib, queue, &tq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "hmin and hmax must be finite with hmin <= hmax", "terrain: hmin > hmax");
        st = oclshade_enqueue_terrain(lib, queue, &tp, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "dilated must be a cl_mem buffer", "terrain: bisect needs the dilated levels");
        clFinish(queue);
        clReleaseMemObject(f4); clReleaseMemObject(f4b); clReleaseMemObject(f1); clReleaseMemObject(f2);
        clReleaseMemObject(coarse); clReleaseMemObject(coarse_off); clReleaseMemObject(flag);
        clReleaseMemObject(ssao_scratch);
    }

    /* ---- sunshine, horizons, zeroing: bad values named, the cast-flag source, sizes, aliasing */
    {
        cl_mem sums = buffer(ctx, 8 * n), sums2 = buffer(ctx, 4 * n), angles = buffer(ctx, 4 * n);
        oclshade_sunshine_params sp, sq;
        oclshade_sunshine_params_init(&sp);
        sp.heights = fh;
        sp.rows = rows; sp.cols = cols;
        sp.mask = oclshade_field_of(mask);
        sp.sun = sums2;
        st = oclshade_enqueue_sunshine(lib, queue, &sp, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "sunshine: a valid call");
        sq = sp; sq.elevation = 0.0;
        st = oclshade_enqueue_sunshine(lib, queue, &sq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "elevation in (0, 90] degrees (daylight suns only), got 0, 0",
                      "sunshine: a night sun");
        sq = sp; sq.seconds = 0;
        st = oclshade_enqueue_sunshine(lib, queue, &sq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "seconds must be >= 1", "sunshine: weight 0");
        sq = sp; sq.sun = NULL;
        st = oclshade_enqueue_sunshine(lib, queue, &sq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "at least one of sun, cast, beam", "sunshine: no sums");
        sq = sp; sq.low = oclshade_field_of(angles);
        st = oclshade_enqueue_sunshine(lib, queue, &sq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "give either mask", "sunshine: mask and low");
        sq = sp; sq.mask.buffer = NULL; sq.low = sq.high = oclshade_field_of(angles); sq.fraction = 1.5;
        st = oclshade_enqueue_sunshine(lib, queue, &sq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "fraction must be in [0, 1]", "sunshine: fraction 1.5");
        sq = sp; sq.beam = sums2;
        st = oclshade_enqueue_sunshine(lib, queue, &sq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "beam must hold at least 280 bytes", "sunshine: beam too small");
        sq = sp; sq.cast = sums2;
        st = oclshade_enqueue_sunshine(lib, queue, &sq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "sun and cast overlap", "sunshine: sun and cast alias");
        sq = sp; sq.dx = -1.0;
        st = oclshade_enqueue_sunshine(lib, queue, &sq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "dx and dy must be positive", "sunshine: dx -1");
        oclshade_horizon_params hp, hq;
        oclshade_horizon_params_init(&hp);
        hp.heights = fh;
        hp.rows = rows; hp.cols = cols;
        hp.pyramid = pyr; hp.offsets = offs;
        hp.svf = sums;
        st = oclshade_enqueue_horizon(lib, queue, &hp, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "scratch must be a buffer of at least",
                      "horizon: no scratch for the seeds");
        size_t horizon_bytes = 0;
        st = oclshade_horizon_scratch_size(lib, &hp, &horizon_bytes);
        expect_status(lib, st, OCLSHADE_OK, "", "horizon: the scratch size");
        cl_mem horizon_scratch = buffer(ctx, horizon_bytes);
        hp.scratch = horizon_scratch;
        st = oclshade_enqueue_horizon(lib, queue, &hp, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "horizon: a valid call");
        hq = hp; hq.svf = NULL;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "at least one of angle, svf", "horizon: no output");
        hq = hp; hq.svf_definition = (oclshade_svf_definition)3;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "svf_definition must be OCLSHADE_SVF_COSINE (1) or "
                      "OCLSHADE_SVF_SOLID_ANGLE (2), got 3", "horizon: definition 3");
        hq = hp; hq.curvature = -1e-7;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "curvature must be a finite drop per square metre >= 0",
                      "horizon: negative curvature");
        hq = hp; hq.azimuth = NAN;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "azimuth must be finite", "horizon: azimuth NaN");
        hq = hp; hq.svf = sums2;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "svf must hold at least 280 bytes", "horizon: svf too small");
        hq = hp; hq.angle = fh;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "heights and angle overlap", "horizon: angle aliases the heights");
        /* a geographic grid's row scales: each named where it is not a positive finite scale */
        double *scales = (double *)calloc(4 * (size_t)rows, sizeof *scales);   /* room for 4 columns */
        for (int k = 0; k < 2 * rows; ++k) scales[k] = 1.0 + 0.01 * k;
        cl_mem scaled_scratch = NULL;
        hq = hp; hq.row_scales = scales;
        size_horizon_scratch(lib, ctx, &hq, &scaled_scratch);
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "horizon: row scales");
        scales[3] = 0.0;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "row_scales[3] (row 1, column band 0, north) must be a "
                      "positive finite scale, got 0", "horizon: a row scale 0");
        scales[3] = NAN;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "row_scales[3] (row 1, column band 0, north)",
                      "horizon: a row scale NaN");
        scales[3] = 1.03;
        hq.row_scale_bands = 2;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "row_scale_bands must be 0 (one scale per row) or 1 to 1 "
                      "(column bands of a map", "horizon: 2 column bands on a narrow map");
        hq.row_scale_bands = 1;        /* (rows x 1 x 2: the same doubles, read as one column band) */
        size_horizon_scratch(lib, ctx, &hq, &scaled_scratch);
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "horizon: row scales in one column band");
        hq.row_scale_bands = 0;
        hq.row_scale_columns = 3;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "row_scale_columns must be 2 (east, north) or 4 (east, "
                      "north, p, q), got 3", "horizon: 3 row scale columns");
        hq.row_scale_columns = 4;      /* (the rows' first half read as rows of 4: east != north, p, q not 0) */
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "row_scales row 0 column band 0's stretch (p, q) = (1.02, "
                      "1.03) must "
                      "have p^2 + q^2 < 1", "horizon: a row's stretch of 1.4");
        for (int r = 0; r < rows; ++r) {           /* east = north, a small stretch: fine */
            scales[4 * r] = scales[4 * r + 1] = 1.0 + 0.001 * r;
            scales[4 * r + 2] = 0.003;
            scales[4 * r + 3] = -0.002;
        }
        size_horizon_scratch(lib, ctx, &hq, &scaled_scratch);
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "horizon: row scales with a stretch by direction");
        scales[4] = 1.5;                            /* row 1: east != north with a stretch */
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "row_scales row 1 column band 0's stretch (p, q) = (0.003, "
                      "-0.002) must "
                      "have p^2 + q^2 < 1, and be 0 where its east and north scales differ", "horizon: a stretch off");
        free(scales);
        clReleaseMemObject(scaled_scratch);
        /* several azimuths in one call */
        double two[2] = {10.0, 200.0}, bad[2] = {10.0, NAN};
        hq = hp; hq.n_azimuths = -1;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "n_azimuths must be >= 0 (0: the one azimuth), got -1",
                      "horizon: n_azimuths -1");
        hq = hp; hq.n_azimuths = 2;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "azimuths must point to n_azimuths (2) degrees, got NULL",
                      "horizon: azimuths NULL");
        hq.azimuths = bad;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "azimuths[1] must be finite degrees, got nan",
                      "horizon: azimuths[1] NaN");
        hq.azimuths = two; hq.max_distance = 100.0;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "are the whole map's walk: max_distance must be 0, got 100",
                      "horizon: several azimuths within a radius");
        hq.max_distance = 0.0;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "scratch must hold at least",
                      "horizon: two azimuths in the scratch of one");
        hq.angle = oclshade_field_of(angles);
        st = oclshade_horizon_scratch_size(lib, &hq, &horizon_bytes);
        expect_status(lib, st, OCLSHADE_OK, "", "horizon: the scratch size of two azimuths");
        cl_mem two_scratch = buffer(ctx, horizon_bytes);
        hq.scratch = two_scratch;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "angle must hold at least", "horizon: one band for two azimuths");
        hq.angle.buffer = NULL;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "horizon: two azimuths' sums in one call");
        clReleaseMemObject(two_scratch);
        /* clamped angles (a strip of the sun's disc) and the soft shadows */
        hq = hp; hq.svf = NULL; hq.angle = oclshade_field_of(angles); hq.clamped = 1;
        hq.clamp_bounds[0] = 0.2; hq.clamp_bounds[1] = 0.1;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "clamp_bounds must be finite tangents lo < hi, got 0.2, 0.1",
                      "horizon: clamp bounds the wrong way round");
        hq.clamp_bounds[1] = 0.3;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "horizon: clamped angles");
        hq.svf = sums;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "clamped angles (a strip of the sun's disc) are one azimuth's "
                      "angle alone", "horizon: clamped with svf");
        hq.svf = NULL; hq.clamped = 2;
        st = oclshade_enqueue_horizon(lib, queue, &hq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "clamped must be 0 or 1, got 2", "horizon: clamped 2");
        double strip_az[4], strip_c[4], strip_b[4][2];
        expect(oclshade_sun_disc_strips(10.0, 89.8, 0.2666, 4, strip_az, strip_c, strip_b) == OCLSHADE_INVALID_ARGUMENT,
               "sun_disc_strips: the disc past the zenith", "OCLSHADE_INVALID_ARGUMENT expected");
        expect(oclshade_sun_disc_strips(10.0, 30.0, 0.2666, 0, strip_az, strip_c, strip_b) == OCLSHADE_INVALID_ARGUMENT,
               "sun_disc_strips: 0 strips", "OCLSHADE_INVALID_ARGUMENT expected");
        expect(oclshade_sun_disc_strips(359.99, 30.0, 0.2666, 4, strip_az, strip_c, strip_b) == OCLSHADE_OK &&
               strip_az[0] > 359.0 && strip_az[3] < 1.0 && strip_b[0][0] < strip_b[0][1],
               "sun_disc_strips: strips across north wrap to [0, 360)", "azimuths in [0, 360) expected");
        oclshade_sun_disc_params dp;
        oclshade_sun_disc_params_init(&dp);
        dp.heights = fh; dp.rows = rows; dp.cols = cols; dp.pyramid = pyr; dp.offsets = offs;
        dp.azimuth = 135.0; dp.elevation = 20.0;
        dp.angle = oclshade_field_of(angles);
        float *fraction = (float *)calloc((size_t)n, sizeof *fraction);
        double *work = (double *)calloc((size_t)n, sizeof *work);
        size_t disc_bytes = 0;
        st = oclshade_sun_disc_scratch_size(lib, &dp, &disc_bytes);
        expect_status(lib, st, OCLSHADE_OK, "", "sun_disc: the scratch size");
        cl_mem disc_scratch = disc_bytes ? buffer(ctx, disc_bytes) : NULL;
        dp.scratch = disc_scratch;
        st = oclshade_sun_disc(lib, queue, &dp, fraction);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "fraction and work must point to rows x cols floats and "
                      "doubles of host memory, got work NULL", "sun_disc: no work");
        dp.work = work;
        st = oclshade_sun_disc(lib, queue, &dp, fraction);
        expect_status(lib, st, OCLSHADE_OK, "", "sun_disc: a valid call");
        dp.angle = oclshade_field_of(sums2);
        dp.angle.offset = 4;
        st = oclshade_sun_disc(lib, queue, &dp, fraction);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "angle must hold at least", "sun_disc: angle too small");
        dp.angle = oclshade_field_of(angles);
        dp.radius = 6.0;
        st = oclshade_sun_disc(lib, queue, &dp, fraction);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "radius (the sun disc's angular radius) must be in (0, 5] "
                      "degrees (0: 0.2666), got 6", "sun_disc: radius 6");
        dp.radius = 0.0; dp.columns = 2000;
        st = oclshade_sun_disc(lib, queue, &dp, fraction);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "columns (strips across the sun's disc) must be in 1..1024 "
                      "(0: 16), got 2000", "sun_disc: 2000 strips");
        dp.columns = 0; dp.elevation = 89.9;
        st = oclshade_sun_disc(lib, queue, &dp, fraction);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "elevation must leave the whole disc between the nadir and "
                      "the zenith (|elevation| < 89.7334 degrees), got 89.9", "sun_disc: the disc past the zenith");
        dp.elevation = 20.0;
        st = oclshade_sun_disc(lib, queue, &dp, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "got fraction NULL", "sun_disc: no output");
        st = oclshade_sun_disc(lib, queue, NULL, fraction);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "params must point to oclshade_sun_disc_params, got NULL",
                      "sun_disc: no params");
        if (disc_scratch) clReleaseMemObject(disc_scratch);
        free(fraction); free(work);
        st = oclshade_enqueue_zero(lib, queue, sums, 0, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "bytes must be >= 1", "zero: 0 bytes");
        st = oclshade_enqueue_zero(lib, queue, sums2, 8 * n, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "buffer must hold at least 280 bytes", "zero: buffer too small");
        clFinish(queue);
        clReleaseMemObject(sums); clReleaseMemObject(sums2); clReleaseMemObject(angles);
        clReleaseMemObject(horizon_scratch);
    }

    /* ---- environment maps: face and lat-long sizes, the cube's size */
    {
        cl_mem cube = buffer(ctx, 16 * 6 * 9), ll = buffer(ctx, 16 * 8);
        oclshade_envmap_params ep, eq;
        oclshade_envmap_params_init(&ep);
        ep.cube = cube; ep.face = 1;
        ep.latlong = oclshade_field_of(ll); ep.height = 2; ep.width = 4;
        st = oclshade_enqueue_latlong_to_cube(lib, queue, &ep, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_OK, "", "envmap: a valid call");
        eq = ep; eq.face = 0;
        st = oclshade_enqueue_cube_border(lib, queue, &eq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "face must be the cube face size in 1..8192, got 0", "envmap: face 0");
        eq = ep; eq.width = 1;
        st = oclshade_enqueue_latlong_to_cube(lib, queue, &eq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "must be in 1..32768 and 2..32768, got 2, 1",
                      "envmap: a lat-long map of one column");
        eq = ep; eq.face = 2;
        st = oclshade_enqueue_cube_to_latlong(lib, queue, &eq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "cube must hold at least 1536 bytes", "envmap: cube too small");
        eq = ep; eq.latlong = oclshade_field_of(cube);
        st = oclshade_enqueue_cube_to_latlong(lib, queue, &eq, 0, NULL, NULL);
        expect_status(lib, st, OCLSHADE_INVALID_ARGUMENT, "overlap", "envmap: lat-long output aliases the cube");
        clFinish(queue);
        clReleaseMemObject(cube); clReleaseMemObject(ll);
    }

    /* ---- knobs: the rule's values (compared with the Python host's by the test), errors */
    static const char *const knob_names[][2] = {
        {"pyramid", "base_lanes"}, {"pyramid", "own_builtins"}, {"shadow", "lanes"}, {"shadow", "run"},
        {"shadow", "group"}, {"shadow", "cert_tile"}, {"shadow", "own_builtins"}, {"shadow", "gather"}, {"terrain", "descend"},
        {"terrain", "leaf"}, {"terrain", "group"}, {"terrain", "own_builtins"}, {"screen_shadows", "group"},
        {"screen_shadows", "own_builtins"}, {"ssao", "lanes"}, {"ssao", "group"}, {"ssao", "own_builtins"},
        {"horizon", "group"}, {"horizon", "own_builtins"}, {"horizon", "lanes"}, {"horizon", "sweep_cells"},
        {"horizon", "sweep_far"}, {"horizon", "width"}, {"horizon", "batch"}, {"horizon", "scan"}};
    oclshade *fresh = NULL;
    oclshade_create(ctx, device, dir, &fresh);
    for (size_t i = 0; i < sizeof knob_names / sizeof knob_names[0]; ++i) {
        int rule = -1, have = -2;
        st = oclshade_default_knob(device, knob_names[i][0], knob_names[i][1], &rule);
        expect(st == OCLSHADE_OK && oclshade_get_knob(fresh, knob_names[i][0], knob_names[i][1], &have) == OCLSHADE_OK &&
               have == rule, "a new handle starts with the rule's knob", knob_names[i][1]);
        printf("default_knob %s %s %d\n", knob_names[i][0], knob_names[i][1], rule);
    }
    st = oclshade_set_knob(fresh, "pyramid", "in_place", 1);
    expect_status(fresh, st, OCLSHADE_INVALID_ARGUMENT, "in_place chooses how the Python host", "set_knob: pyramid in_place");
    st = oclshade_set_knob(fresh, "roofline", "lanes", 1);
    expect_status(fresh, st, OCLSHADE_INVALID_ARGUMENT, "family must be one of pyramid, shadow", "set_knob: unknown family");
    int before = 0, value = 0;
    expect(oclshade_get_knob(fresh, "ssao", "lanes", &before) == OCLSHADE_OK, "get_knob ssao lanes", "");
    st = oclshade_set_knob(fresh, "ssao", "lanes", 2);
    expect_status(fresh, st, OCLSHADE_INVALID_ARGUMENT, "knob ssao lanes must be 4, 8 or 16, got 2", "set_knob: bad value");
    expect(oclshade_get_knob(fresh, "ssao", "lanes", &value) == OCLSHADE_OK && value == before,
           "set_knob: a rejected value changes nothing", "");
    expect(oclshade_set_knob(fresh, "terrain", "descend", 5) == OCLSHADE_OK &&
           oclshade_get_knob(fresh, "terrain", "descend", &value) == OCLSHADE_OK && value == 5, "set_knob, get_knob", "");
    expect(oclshade_set_knob(fresh, "shadow", "lanes", 4) == OCLSHADE_OK && oclshade_get_tuning(fresh, &now) == OCLSHADE_OK &&
           now.packet_lanes == 4, "set_knob shadow lanes is the tuning's packet_lanes", "");
    oclshade_destroy(fresh);
    expect(oclshade_last_error(NULL)[0] != '\0', "last_error(NULL) explains", "");

    oclshade_destroy(lib);
    oclshade_destroy(NULL);
    clReleaseMemObject(heights); clReleaseMemObject(pyr); clReleaseMemObject(offs);
    clReleaseMemObject(small); clReleaseMemObject(mask); clReleaseMemObject(foreign); clReleaseMemObject(cert);
    clReleaseCommandQueue(queue); clReleaseCommandQueue(other_queue);
    clReleaseContext(ctx); clReleaseContext(other_ctx);
    free(common); free(pyramid); free(terrain); free(ssao); free(compose); free(sunshine); free(horizon); free(cubemap); free(envmap);
    free(quadric); free(reflect); free(terrain_ray); free(mesh); free(shadow_volume);
    printf("%d failure(s)\n", failures);
    return failures;
}
