/* host_shadows — drives the C host API for tests/test_host_api.py.
 *
 * usage: host_shadows KERNELS HEIGHTS ROWS COLS DX DY OUTDIR [--origin=R,C] AZ,EL [AZ,EL ...]
 *   KERNELS  a kernel directory, or "-" for the copy built into the library
 *   HEIGHTS  raw float64 heights, ROWS x COLS, row-major, NaN = nodata
 *   R,C      the map's origin in a larger map (oclshade_shadow_params origin_row / _col; default 0,0)
 * On the first OpenCL device (OCL_ICD_VENDORS picks the driver) it writes to OUTDIR:
 *   pyramid.cl, shadow.cl, ...      oclshade_program_source of every program (includes expanded)
 *   relative.f32, offset.f64        oclshade_relative_heights
 *   pyramid.f32, offsets.i32        the pyramid buffer and offset table read back
 *   sun<k>.bin                      oclshade_sun_for: ray[4], vector[4] float32, mode int32
 *   <method>_<k>.{mask,self,coef}   all three outputs of each method for sun k
 * with the handle's initial tuning (oclshade_default_tuning of the device),
 * and checks itself that a mask-only build gives the same exact mask, that
 * an out-of-order queue chained by events gives the same pyramid and mask,
 * (POSIX) that two threads sharing the handle, each on its own queue, give the
 * same masks while building a new variant concurrently and while one of them
 * switches the handle's work-group size, and that every method gives the same three
 * outputs, bit for bit, under the other tunings of ALT_TUNINGS.
 * Prints "ok" and exits 0 on success. */
#include "oclshade.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#if !defined(_WIN32)
#include <pthread.h>
#endif

static oclshade *lib;

/* Tunings other than a CPU's or a GPU's default, each output compared with the
 * default's: 4 lanes in runs of 16 cells and groups of 16; one ray per
 * work-item in groups of 256 (packet_run unused). */
static const oclshade_tuning ALT_TUNINGS[] = {{4, 16, 16}, {0, 1024, 256}};
#define N_ALT_TUNINGS (sizeof ALT_TUNINGS / sizeof ALT_TUNINGS[0])

static const char *outdir;

#include "host_test_util.h"

static cl_mem buffer(cl_context ctx, cl_mem_flags flags, size_t n, void *host)
{
    cl_int err;
    cl_mem m = clCreateBuffer(ctx, flags, n, host, &err);
    CLCHECK(err);
    return m;
}

/* A scratch buffer for the shadow passes of these parameters (certificates); NULL if none is needed. */
static cl_mem shadow_scratch(cl_context ctx, const oclshade_shadow_params *p)
{
    size_t bytes = 0;
    CHECK(oclshade_shadows_scratch_size(lib, p, &bytes));
    return bytes ? buffer(ctx, CL_MEM_READ_WRITE, bytes, NULL) : NULL;
}

static void read_buffer(cl_command_queue q, cl_mem m, size_t n, void *out, cl_uint nwait, const cl_event *wait)
{
    CLCHECK(clEnqueueReadBuffer(q, m, CL_TRUE, 0, n, out, nwait, wait, NULL));
}

/* Shared by the threads: the map, its pyramid and the serial results. */
typedef struct shared {
    cl_context ctx;
    cl_device_id device;
    oclshade_shadow_params base;   /* heights, pyramid, offsets, size, cell */
    int nsuns;
    double *az, *el;
    unsigned char *exact, *maxmip; /* nsuns * n serial masks */
    size_t n;
    oclshade_tuning initial;       /* the handle's tuning before the threads */
    oclshade_tuning regrouped;     /* the same with another work-group size */
} shared;

typedef struct thread_arg {
    const shared *sh;
    int index;
} thread_arg;

#if !defined(_WIN32)
/* Each thread: its own queue and output buffers, the shared handle; every sun
 * with exact (mask only, built) and maxmip (mask + coefficient, a variant
 * first built here, by both threads at once).  Thread 1 sets the handle's
 * tuning before each round (another work-group size, then the initial one),
 * dropping the variants the other thread uses (rebuilt with the same options:
 * the driver's binary cache, if any, keeps this quick).  Returns "" or what
 * differed. */
static void *thread_main(void *arg)
{
    const shared *sh = ((const thread_arg *)arg)->sh;
    const int index = ((const thread_arg *)arg)->index;
    cl_int err;
    cl_command_queue q = clCreateCommandQueue(sh->ctx, sh->device, 0, &err);
    if (err != CL_SUCCESS) return "thread: clCreateCommandQueue failed";
    cl_mem d_mask = clCreateBuffer(sh->ctx, CL_MEM_WRITE_ONLY, sh->n, NULL, &err);
    cl_mem d_coef = clCreateBuffer(sh->ctx, CL_MEM_WRITE_ONLY, 4 * sh->n, NULL, &err);
    unsigned char *got = (unsigned char *)xmalloc(sh->n);
    const char *result = "";
    oclshade_shadow_params sized = sh->base;   /* exact and maxmip: the same certificates */
    sized.method = OCLSHADE_EXACT;
    sized.mask = oclshade_field_of(d_mask);
    cl_mem scratch = shadow_scratch(sh->ctx, &sized);   /* each thread its own: the passes overlap */
    for (int rep = 0; rep < 3 && *result == '\0'; ++rep) {
        if (index == 1 && oclshade_set_tuning(lib, rep % 2 ? &sh->initial : &sh->regrouped) != OCLSHADE_OK)
            result = "thread: set_tuning failed";
        for (int k = 0; k < sh->nsuns && *result == '\0'; ++k) {
            oclshade_shadow_params p = sh->base;
            p.azimuth = sh->az[k]; p.elevation = sh->el[k];
            p.mask = oclshade_field_of(d_mask);
            p.self_shadow = oclshade_field_of(NULL);
            p.method = rep % 2 ? OCLSHADE_EXACT : OCLSHADE_MAXMIP;
            p.coefficient = oclshade_field_of(p.method == OCLSHADE_MAXMIP ? d_coef : NULL);
            p.scratch = scratch;
            if (oclshade_enqueue_shadows(lib, q, &p, 0, NULL, NULL) != OCLSHADE_OK ||
                clEnqueueReadBuffer(q, d_mask, CL_TRUE, 0, sh->n, got, 0, NULL, NULL) != CL_SUCCESS)
                result = "thread: enqueue failed";
            else if (memcmp(got, (p.method == OCLSHADE_EXACT ? sh->exact : sh->maxmip) + (size_t)k * sh->n, sh->n) != 0)
                result = "thread: mask differs from the serial one";
        }
    }
    clReleaseMemObject(d_mask); clReleaseMemObject(d_coef);
    if (scratch) clReleaseMemObject(scratch);
    clReleaseCommandQueue(q);
    free(got);
    return (void *)result;
}
#endif

/* A sun field (oclshade.sun.SunField) from a file: int32 count, then per block int32 row0, row1,
 * col0, col1 and float64 azimuth, elevation. */
typedef struct field_block { int r0, r1, c0, c1; double az, el; } field_block;

static field_block *read_field(const char *path, int *count)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL || fread(count, sizeof *count, 1, f) != 1 || *count < 1) { fprintf(stderr, "cannot read %s\n", path); exit(1); }
    field_block *blocks = (field_block *)xmalloc((size_t)*count * sizeof *blocks);
    for (int b = 0; b < *count; ++b) {
        int ints[4];
        double angles[2];
        if (fread(ints, sizeof *ints, 4, f) != 4 || fread(angles, sizeof *angles, 2, f) != 2) {
            fprintf(stderr, "cannot read block %d of %s\n", b, path);
            exit(1);
        }
        blocks[b].r0 = ints[0]; blocks[b].r1 = ints[1]; blocks[b].c0 = ints[2]; blocks[b].c1 = ints[3];
        blocks[b].az = angles[0]; blocks[b].el = angles[1];
    }
    fclose(f);
    return blocks;
}

/* A sun field traced (all outputs, EXACT), then the outputs read back: each block with its own
 * sun through the block window of oclshade_shadow_params, or with one_launch the whole field in
 * one launch of the sun-table kernels (field_row_blocks ..., the blocks a grid in raster order). */
static void trace_field(oclshade *lib, cl_command_queue queue, cl_context ctx, oclshade_shadow_params p,
                        const field_block *blocks, int count, int one_launch, cl_mem d_mask, cl_mem d_self,
                        cl_mem d_coef, size_t n, unsigned char *mask, unsigned char *self, float *coef)
{
    p.method = OCLSHADE_EXACT;
    p.mask = oclshade_field_of(d_mask); p.self_shadow = oclshade_field_of(d_self);
    p.coefficient = oclshade_field_of(d_coef);
    if (!one_launch) {
        for (int b = 0; b < count; ++b) {
            p.block_row0 = blocks[b].r0; p.block_rows = blocks[b].r1 - blocks[b].r0;
            p.block_col0 = blocks[b].c0; p.block_cols = blocks[b].c1 - blocks[b].c0;
            p.azimuth = blocks[b].az; p.elevation = blocks[b].el;
            CHECK(oclshade_enqueue_shadows(lib, queue, &p, 0, NULL, NULL));
        }
    } else {
        int ncb = 0;
        while (ncb < count && blocks[ncb].r0 == blocks[0].r0) ++ncb;
        const int nrb = count / ncb;
        int *row_edges = (int *)xmalloc(sizeof(int) * (size_t)(nrb + 1));
        int *col_edges = (int *)xmalloc(sizeof(int) * (size_t)(ncb + 1));
        double *suns = (double *)xmalloc(sizeof(double) * 2 * (size_t)count);
        for (int a = 0; a < nrb; ++a) row_edges[a] = blocks[a * ncb].r0;
        row_edges[nrb] = blocks[count - 1].r1;
        for (int b = 0; b < ncb; ++b) col_edges[b] = blocks[b].c0;
        col_edges[ncb] = blocks[ncb - 1].c1;
        for (int k = 0; k < count; ++k) { suns[2 * k] = blocks[k].az; suns[2 * k + 1] = blocks[k].el; }
        p.field_row_blocks = nrb; p.field_col_blocks = ncb;
        p.field_row_edges = row_edges; p.field_col_edges = col_edges; p.field_suns = suns;
        size_t need = 0;
        CHECK(oclshade_shadows_scratch_size(lib, &p, &need));
        cl_mem scratch = need ? buffer(ctx, CL_MEM_READ_WRITE, need, NULL) : NULL;
        p.scratch = scratch;
        CHECK(oclshade_enqueue_shadows(lib, queue, &p, 0, NULL, NULL));
        clFinish(queue);
        if (scratch) clReleaseMemObject(scratch);
        free(row_edges); free(col_edges); free(suns);
    }
    read_buffer(queue, d_mask, n, mask, 0, NULL);
    read_buffer(queue, d_self, n, self, 0, NULL);
    read_buffer(queue, d_coef, 4 * n, coef, 0, NULL);
}

int main(int argc, char **argv)
{
    int first_sun = 8, origin_row = 0, origin_col = 0;
    const char *field_path = NULL;
    for (; argc > first_sun && strncmp(argv[first_sun], "--", 2) == 0; ++first_sun) {
        if (strncmp(argv[first_sun], "--origin=", 9) == 0) {
            if (sscanf(argv[first_sun] + 9, "%d,%d", &origin_row, &origin_col) != 2) {
                fprintf(stderr, "bad %s\n", argv[first_sun]);
                return 2;
            }
        } else if (strncmp(argv[first_sun], "--field=", 8) == 0) {
            field_path = argv[first_sun] + 8;
        } else {
            fprintf(stderr, "bad option %s\n", argv[first_sun]);
            return 2;
        }
    }
    if (argc <= first_sun) {
        fprintf(stderr, "usage: %s KERNELS HEIGHTS ROWS COLS DX DY OUTDIR [--origin=R,C] [--field=FILE] AZ,EL "
                "[AZ,EL ...]\n", argv[0]);
        return 2;
    }
    const char *kernels = strcmp(argv[1], "-") == 0 ? NULL : argv[1];
    const int rows = atoi(argv[3]), cols = atoi(argv[4]);
    const double dx = strtod(argv[5], NULL), dy = strtod(argv[6], NULL);
    outdir = argv[7];
    const size_t n = (size_t)rows * (size_t)cols;

    double *heights = (double *)xmalloc(n * sizeof *heights);
    FILE *f = fopen(argv[2], "rb");
    if (f == NULL || fread(heights, sizeof *heights, n, f) != n) { fprintf(stderr, "cannot read %s\n", argv[2]); return 1; }
    fclose(f);

    cl_platform_id platform;
    cl_device_id device;
    cl_int err;
    CLCHECK(clGetPlatformIDs(1, &platform, NULL));
    CLCHECK(clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &device, NULL));
    cl_context ctx = clCreateContext(NULL, 1, &device, NULL, NULL, &err);
    CLCHECK(err);
    cl_command_queue queue = clCreateCommandQueue(ctx, device, 0, &err);
    CLCHECK(err);
    CHECK(oclshade_create(ctx, device, kernels, &lib));
    static const char *const programs[] = {"pyramid.cl", "shadow.cl", "terrain.cl", "ssao.cl", "compose.cl",
                                           "sunshine.cl", "horizon.cl", "envmap.cl", "quadric.cl", "reflect.cl",
                                           "mesh.cl", "shadow_volume.cl"};
    for (int i = 0; i < 12; ++i)
        write_file(programs[i], oclshade_program_source(lib, programs[i]), strlen(oclshade_program_source(lib, programs[i])));

    float *rel = (float *)xmalloc(n * sizeof *rel);
    double offset;
    CHECK(oclshade_relative_heights(heights, n, rel, &offset));
    write_file("relative.f32", rel, n * sizeof *rel);
    write_file("offset.f64", &offset, sizeof offset);

    oclshade_pyramid_layout lay;
    CHECK(oclshade_pyramid_layout_for(rows, cols, &lay));
    cl_mem d_heights = buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * sizeof *rel, rel);
    cl_mem d_pyramid = buffer(ctx, CL_MEM_READ_WRITE, lay.pyramid_bytes, NULL);
    cl_mem d_offsets = buffer(ctx, CL_MEM_READ_WRITE, lay.offsets_bytes, NULL);
    const oclshade_field f_heights = oclshade_field_of(d_heights);
    CHECK(oclshade_enqueue_extrema_pyramid(lib, queue, &f_heights, rows, cols, d_pyramid, d_offsets, NULL, 0, NULL, NULL));
    float *pyramid = (float *)xmalloc(lay.pyramid_bytes);
    int *offsets = (int *)xmalloc(lay.offsets_bytes);
    read_buffer(queue, d_pyramid, lay.pyramid_bytes, pyramid, 0, NULL);
    read_buffer(queue, d_offsets, lay.offsets_bytes, offsets, 0, NULL);
    write_file("pyramid.f32", pyramid, lay.pyramid_bytes);
    write_file("offsets.i32", offsets, lay.offsets_bytes);

    cl_mem scratch = NULL;   /* the certificates of exact and maxmip, sized at the first sun */
    cl_mem d_mask = buffer(ctx, CL_MEM_WRITE_ONLY, n, NULL);
    cl_mem d_self = buffer(ctx, CL_MEM_WRITE_ONLY, n, NULL);
    cl_mem d_coef = buffer(ctx, CL_MEM_WRITE_ONLY, 4 * n, NULL);
    unsigned char *mask = (unsigned char *)xmalloc(n), *self = (unsigned char *)xmalloc(n);
    unsigned char *exact_mask = (unsigned char *)xmalloc(n), *other = (unsigned char *)xmalloc(n);
    float *coef = (float *)xmalloc(4 * n);
    static const char *const method_names[] = {"exact", "paper", "maxmip", "dda"};
    static const oclshade_method methods[] = {OCLSHADE_EXACT, OCLSHADE_PAPER, OCLSHADE_MAXMIP, OCLSHADE_DDA};
    CHECK(oclshade_prepare(lib, OCLSHADE_EXACT, OCLSHADE_OUT_MASK));
    shared sh;
    sh.ctx = ctx; sh.device = device; sh.n = n; sh.nsuns = argc - first_sun;
    CHECK(oclshade_get_tuning(lib, &sh.initial));
    sh.regrouped = sh.initial;
    sh.regrouped.group = sh.initial.group == 16 ? 64 : 16;
    /* every output of every method and sun under the initial tuning: 6 bytes a cell */
    unsigned char *outputs = (unsigned char *)xmalloc((size_t)sh.nsuns * 4 * 6 * n);
    sh.az = (double *)xmalloc(sh.nsuns * sizeof(double));
    sh.el = (double *)xmalloc(sh.nsuns * sizeof(double));
    sh.exact = (unsigned char *)xmalloc(sh.nsuns * n);
    sh.maxmip = (unsigned char *)xmalloc(sh.nsuns * n);

    for (int k = first_sun; k < argc; ++k) {
        double az, el;
        if (sscanf(argv[k], "%lf,%lf", &az, &el) != 2) { fprintf(stderr, "bad sun %s\n", argv[k]); return 2; }
        const int sun_index = k - first_sun;
        char name[64];
        oclshade_sun sun;
        CHECK(oclshade_sun_for(az, el, dx, dy, &sun));
        unsigned char sun_bytes[36];
        memcpy(sun_bytes, sun.ray, 16);
        memcpy(sun_bytes + 16, sun.vector, 16);
        const int mode = sun.mode;
        memcpy(sun_bytes + 32, &mode, 4);
        snprintf(name, sizeof name, "sun%d.bin", sun_index);
        write_file(name, sun_bytes, sizeof sun_bytes);

        oclshade_shadow_params p;
        oclshade_shadow_params_init(&p);
        p.heights = f_heights; p.rows = rows; p.cols = cols; p.dx = dx; p.dy = dy;
        p.pyramid = d_pyramid; p.offsets = d_offsets; p.azimuth = az; p.elevation = el;
        p.origin_row = origin_row; p.origin_col = origin_col;
        p.method = OCLSHADE_EXACT; p.mask = oclshade_field_of(d_mask);
        if (scratch == NULL) scratch = shadow_scratch(ctx, &p);
        p.scratch = scratch;
        p.k_dark = 0.2; p.k_bright = 0.7;
        for (int m = 0; m < 4; ++m) {
            p.method = methods[m];
            p.mask = oclshade_field_of(d_mask); p.self_shadow = oclshade_field_of(d_self);
            p.coefficient = oclshade_field_of(d_coef);
            CHECK(oclshade_enqueue_shadows(lib, queue, &p, 0, NULL, NULL));
            read_buffer(queue, d_mask, n, mask, 0, NULL);
            read_buffer(queue, d_self, n, self, 0, NULL);
            read_buffer(queue, d_coef, 4 * n, coef, 0, NULL);
            snprintf(name, sizeof name, "%s_%d.mask", method_names[m], sun_index);
            write_file(name, mask, n);
            snprintf(name, sizeof name, "%s_%d.self", method_names[m], sun_index);
            write_file(name, self, n);
            snprintf(name, sizeof name, "%s_%d.coef", method_names[m], sun_index);
            write_file(name, coef, 4 * n);
            unsigned char *kept = outputs + ((size_t)sun_index * 4 + (size_t)m) * 6 * n;
            memcpy(kept, mask, n);
            memcpy(kept + n, self, n);
            memcpy(kept + 2 * n, coef, 4 * n);
            if (methods[m] == OCLSHADE_EXACT) memcpy(exact_mask, mask, n);
            if (methods[m] == OCLSHADE_EXACT) memcpy(sh.exact + (size_t)sun_index * n, mask, n);
            if (methods[m] == OCLSHADE_MAXMIP) memcpy(sh.maxmip + (size_t)sun_index * n, mask, n);
        }
        sh.az[sun_index] = az;
        sh.el[sun_index] = el;
        sh.base = p;
        /* the mask-only variant (no self / coefficient code compiled) agrees */
        p.method = OCLSHADE_EXACT;
        p.self_shadow = oclshade_field_of(NULL); p.coefficient = oclshade_field_of(NULL);
        CHECK(oclshade_enqueue_shadows(lib, queue, &p, 0, NULL, NULL));
        read_buffer(queue, d_mask, n, other, 0, NULL);
        if (memcmp(other, exact_mask, n) != 0) { fprintf(stderr, "sun %d: mask-only build differs\n", sun_index); return 1; }
    }

    /* An out-of-order queue, the pyramid and one shadow pass ordered by events. */
    cl_command_queue_properties props = 0;
    CLCHECK(clGetDeviceInfo(device, CL_DEVICE_QUEUE_PROPERTIES, sizeof props, &props, NULL));
    if (props & CL_QUEUE_OUT_OF_ORDER_EXEC_MODE_ENABLE) {
        cl_command_queue ooo = clCreateCommandQueue(ctx, device, CL_QUEUE_OUT_OF_ORDER_EXEC_MODE_ENABLE, &err);
        CLCHECK(err);
        cl_mem pyr2 = buffer(ctx, CL_MEM_READ_WRITE, lay.pyramid_bytes, NULL);
        cl_mem off2 = buffer(ctx, CL_MEM_READ_WRITE, lay.offsets_bytes, NULL);
        cl_mem mask2 = buffer(ctx, CL_MEM_WRITE_ONLY, n, NULL);
        cl_event built, shaded;
        CHECK(oclshade_enqueue_extrema_pyramid(lib, ooo, &f_heights, rows, cols, pyr2, off2, NULL, 0, NULL, &built));
        oclshade_shadow_params p;
        oclshade_shadow_params_init(&p);
        p.heights = f_heights; p.rows = rows; p.cols = cols; p.dx = dx; p.dy = dy;
        p.pyramid = pyr2; p.offsets = off2; p.mask = oclshade_field_of(mask2);
        p.origin_row = origin_row; p.origin_col = origin_col;
        cl_mem scratch2 = shadow_scratch(ctx, &p);   /* the first queue's commands may still use `scratch` */
        p.scratch = scratch2;
        double az, el;
        sscanf(argv[argc - 1], "%lf,%lf", &az, &el);
        p.azimuth = az; p.elevation = el;
        CHECK(oclshade_enqueue_shadows(lib, ooo, &p, 1, &built, &shaded));
        float *pyramid2 = (float *)xmalloc(lay.pyramid_bytes);
        read_buffer(ooo, pyr2, lay.pyramid_bytes, pyramid2, 1, &built);
        read_buffer(ooo, mask2, n, other, 1, &shaded);
        if (memcmp(pyramid2, pyramid, lay.pyramid_bytes) != 0 || memcmp(other, exact_mask, n) != 0) {
            fprintf(stderr, "out-of-order queue: results differ\n");
            return 1;
        }
        printf("out-of-order queue: same pyramid and mask\n");
        clReleaseEvent(built); clReleaseEvent(shaded);
        clReleaseMemObject(pyr2); clReleaseMemObject(off2); clReleaseMemObject(mask2);
        if (scratch2) clReleaseMemObject(scratch2);
        clReleaseCommandQueue(ooo);
        free(pyramid2);
    } else {
        printf("out-of-order queue: not supported by the device, skipped\n");
    }

#if !defined(_WIN32)
    {
        pthread_t threads[2];
        thread_arg args[2];
        void *results[2];
        for (int t = 0; t < 2; ++t) {
            args[t].sh = &sh;
            args[t].index = t;
            if (pthread_create(&threads[t], NULL, thread_main, &args[t]) != 0) { fprintf(stderr, "pthread_create\n"); return 1; }
        }
        for (int t = 0; t < 2; ++t) pthread_join(threads[t], &results[t]);
        for (int t = 0; t < 2; ++t)
            if (*(const char *)results[t]) { fprintf(stderr, "%s: %s\n", (const char *)results[t], oclshade_last_error(lib)); return 1; }
        printf("two threads sharing the handle, one switching its work-group size: same masks\n");
    }
#endif

    /* A sun field, block by block (written as field.mask / .self / .coef). */
    int nblocks = 0;
    field_block *blocks = field_path != NULL ? read_field(field_path, &nblocks) : NULL;
    unsigned char *field_out = blocks != NULL ? (unsigned char *)xmalloc(6 * n) : NULL;
    if (blocks != NULL) {
        trace_field(lib, queue, ctx, sh.base, blocks, nblocks, 0, d_mask, d_self, d_coef, n, field_out,
                    field_out + n, (float *)(field_out + 2 * n));
        write_file("field.mask", field_out, n);
        write_file("field.self", field_out + n, n);
        write_file("field.coef", field_out + 2 * n, 4 * n);
        /* the same field in one launch of the sun-table kernels: the same bits */
        unsigned char *table_out = (unsigned char *)xmalloc(6 * n);
        trace_field(lib, queue, ctx, sh.base, blocks, nblocks, 1, d_mask, d_self, d_coef, n, table_out,
                    table_out + n, (float *)(table_out + 2 * n));
        if (memcmp(table_out, field_out, 6 * n) != 0) {
            fprintf(stderr, "a sun field in one launch differs from its blocks' launches\n");
            return 1;
        }
        free(table_out);
        printf("field in one launch (sun table): the same outputs\n");
        /* a block outside the map is refused in one line */
        oclshade_shadow_params bad = sh.base;
        bad.block_row0 = rows; bad.block_rows = 1; bad.block_col0 = 0; bad.block_cols = 1;
        if (oclshade_enqueue_shadows(lib, queue, &bad, 0, NULL, NULL) != OCLSHADE_INVALID_ARGUMENT ||
            strstr(oclshade_last_error(lib), "block_row0") == NULL) {
            fprintf(stderr, "a block outside the map was not refused: %s\n", oclshade_last_error(lib));
            return 1;
        }
        /* the mask as a pitched field at an offset (staged by the host): the same cells, and the
           bytes around them untouched */
        const size_t pitch = (size_t)cols + 7, off = 3 * pitch + 5, total = off + (size_t)rows * pitch + 11;
        unsigned char *pitched = (unsigned char *)xmalloc(total);
        memset(pitched, 0x77, total);
        cl_mem d_pitched = buffer(ctx, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, total, pitched);
        oclshade_shadow_params q = sh.base;
        q.method = OCLSHADE_EXACT;
        q.mask = oclshade_field_of(d_pitched);
        q.mask.offset = off;
        q.mask.row_pitch = pitch;
        q.self_shadow = oclshade_field_of(NULL); q.coefficient = oclshade_field_of(NULL);
        size_t need = 0;
        CHECK(oclshade_shadows_scratch_size(lib, &q, &need));
        cl_mem pitched_scratch = need ? buffer(ctx, CL_MEM_READ_WRITE, need, NULL) : NULL;
        q.scratch = pitched_scratch;
        for (int b = 0; b < nblocks; ++b) {
            q.block_row0 = blocks[b].r0; q.block_rows = blocks[b].r1 - blocks[b].r0;
            q.block_col0 = blocks[b].c0; q.block_cols = blocks[b].c1 - blocks[b].c0;
            q.azimuth = blocks[b].az; q.elevation = blocks[b].el;
            if (pitched_scratch) {   /* whatever the scratch held before: the staging must not show */
                const unsigned char junk = 0xAB;
                CLCHECK(clEnqueueFillBuffer(queue, pitched_scratch, &junk, 1, 0, need, 0, NULL, NULL));
            }
            CHECK(oclshade_enqueue_shadows(lib, queue, &q, 0, NULL, NULL));
        }
        read_buffer(queue, d_pitched, total, pitched, 0, NULL);
        for (size_t i = 0; i < total; ++i) {
            const int inside = i >= off && i < off + (size_t)rows * pitch && (i - off) % pitch < (size_t)cols;
            const unsigned char want = inside ? field_out[(i - off) / pitch * (size_t)cols + (i - off) % pitch] : 0x77;
            if (pitched[i] != want) { fprintf(stderr, "pitched field mask: byte %zu differs\n", i); return 1; }
        }
        free(pitched);
        clReleaseMemObject(d_pitched);
        if (pitched_scratch) clReleaseMemObject(pitched_scratch);
        printf("field of %d blocks traced\n", nblocks);
    }

    /* The knobs change how the shadow pass is built and launched, never what it computes. */
    for (size_t a = 0; a < N_ALT_TUNINGS; ++a) {
        const oclshade_tuning *t = &ALT_TUNINGS[a];
        CHECK(oclshade_set_tuning(lib, t));
        for (int k = 0; k < sh.nsuns; ++k) {
            oclshade_shadow_params p = sh.base;
            p.azimuth = sh.az[k]; p.elevation = sh.el[k];
            p.mask = oclshade_field_of(d_mask); p.self_shadow = oclshade_field_of(d_self);
            p.coefficient = oclshade_field_of(d_coef);
            for (int m = 0; m < 4; ++m) {
                p.method = methods[m];
                CHECK(oclshade_enqueue_shadows(lib, queue, &p, 0, NULL, NULL));
                read_buffer(queue, d_mask, n, mask, 0, NULL);
                read_buffer(queue, d_self, n, self, 0, NULL);
                read_buffer(queue, d_coef, 4 * n, coef, 0, NULL);
                const unsigned char *kept = outputs + ((size_t)k * 4 + (size_t)m) * 6 * n;
                if (memcmp(mask, kept, n) != 0 || memcmp(self, kept + n, n) != 0 || memcmp(coef, kept + 2 * n, 4 * n) != 0) {
                    fprintf(stderr, "tuning lanes %d run %d group %d: %s outputs differ at sun %d (%g, %g)\n",
                            t->packet_lanes, t->packet_run, t->group, method_names[m], k, sh.az[k], sh.el[k]);
                    return 1;
                }
            }
        }
        for (int one_launch = 0; blocks != NULL && one_launch < 2; ++one_launch) {
            /* the field too, by blocks and in one launch: packet runs cut to the blocks, or one ray per item */
            trace_field(lib, queue, ctx, sh.base, blocks, nblocks, one_launch, d_mask, d_self, d_coef, n, mask,
                        self, coef);
            if (memcmp(mask, field_out, n) != 0 || memcmp(self, field_out + n, n) != 0 ||
                memcmp(coef, field_out + 2 * n, 4 * n) != 0) {
                fprintf(stderr, "tuning lanes %d run %d group %d: the field's outputs differ%s\n", t->packet_lanes,
                        t->packet_run, t->group, one_launch ? " (one launch)" : "");
                return 1;
            }
        }
        printf("tuning lanes %d run %d group %d: same outputs\n", t->packet_lanes, t->packet_run, t->group);
    }
    free(blocks);
    free(field_out);
    free(outputs);
    free(sh.az); free(sh.el); free(sh.exact); free(sh.maxmip);

    oclshade_destroy(lib);
    clReleaseMemObject(d_heights); clReleaseMemObject(d_pyramid); clReleaseMemObject(d_offsets);
    clReleaseMemObject(d_mask); clReleaseMemObject(d_self); clReleaseMemObject(d_coef);
    if (scratch) clReleaseMemObject(scratch);
    clReleaseCommandQueue(queue);
    clReleaseContext(ctx);
    free(heights); free(rel); free(pyramid); free(offsets); free(mask); free(self); free(exact_mask);
    free(other); free(coef);
    printf("ok\n");
    return 0;
}
