/* shadow_mask — the C host API end to end: a raw float32 heightmap in, a
 * cast-shadow mask out (uint8: 1 shadow, 0 lit, 255 nodata).
 *
 * usage: shadow_mask IN.f32 ROWS COLS CELLSIZE AZIMUTH ELEVATION OUT.u8
 *   IN.f32: ROWS x COLS float32, row-major, row 0 north; NaN = nodata.
 * Uses the first device of the first OpenCL platform. */
#include "oclshade.h"

#include <stdio.h>
#include <stdlib.h>

#define TRY(call)                                                                                 \
    do {                                                                                          \
        oclshade_status st_ = (call);                                                             \
        if (st_ != OCLSHADE_OK) {                                                                 \
            fprintf(stderr, "%s: %s\n", oclshade_status_name(st_), oclshade_last_error(lib));     \
            return 1;                                                                             \
        }                                                                                         \
    } while (0)

int main(int argc, char **argv)
{
    if (argc != 8) {
        fprintf(stderr, "usage: %s IN.f32 ROWS COLS CELLSIZE AZIMUTH ELEVATION OUT.u8\n", argv[0]);
        return 2;
    }
    const int rows = atoi(argv[2]), cols = atoi(argv[3]);
    const double cell = atof(argv[4]);
    if (rows < 1 || cols < 1) { fprintf(stderr, "ROWS and COLS must be >= 1\n"); return 2; }
    const size_t n = (size_t)rows * (size_t)cols;

    /* heights: float32 file -> float64 -> relative float32 (what the kernels read) */
    float *raw = malloc(n * sizeof *raw);
    double *heights = malloc(n * sizeof *heights);
    unsigned char *mask = malloc(n);
    FILE *f = fopen(argv[1], "rb");
    if (!raw || !heights || !mask || !f || fread(raw, sizeof *raw, n, f) != n) {
        fprintf(stderr, "cannot read %zu float32 values from %s\n", n, argv[1]);
        return 1;
    }
    fclose(f);
    for (size_t i = 0; i < n; ++i) heights[i] = raw[i];

    cl_platform_id platform;
    cl_device_id device;
    cl_int err;
    if (clGetPlatformIDs(1, &platform, NULL) != CL_SUCCESS ||
        clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &device, NULL) != CL_SUCCESS) {
        fprintf(stderr, "no OpenCL device\n");
        return 1;
    }
    cl_context ctx = clCreateContext(NULL, 1, &device, NULL, NULL, &err);
    cl_command_queue queue = clCreateCommandQueue(ctx, device, 0, &err);

    oclshade *lib = NULL;
    TRY(oclshade_create(ctx, device, NULL, &lib));
    TRY(oclshade_relative_heights(heights, n, raw, NULL));

    oclshade_pyramid_layout lay;
    TRY(oclshade_pyramid_layout_for(rows, cols, &lay));
    cl_mem d_heights = clCreateBuffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * sizeof *raw, raw, &err);
    cl_mem d_pyramid = clCreateBuffer(ctx, CL_MEM_READ_WRITE, lay.pyramid_bytes, NULL, &err);
    cl_mem d_offsets = clCreateBuffer(ctx, CL_MEM_READ_WRITE, lay.offsets_bytes, NULL, &err);
    cl_mem d_mask = clCreateBuffer(ctx, CL_MEM_WRITE_ONLY, n, NULL, &err);
    if (err != CL_SUCCESS) { fprintf(stderr, "clCreateBuffer failed: %d\n", (int)err); return 1; }

    const oclshade_field heights_field = oclshade_field_of(d_heights);   /* packed at offset 0: no scratch */
    TRY(oclshade_enqueue_extrema_pyramid(lib, queue, &heights_field, rows, cols, d_pyramid, d_offsets, NULL, 0, NULL, NULL));
    oclshade_shadow_params p;
    oclshade_shadow_params_init(&p);
    p.heights = heights_field; p.rows = rows; p.cols = cols; p.dx = p.dy = cell;
    p.pyramid = d_pyramid; p.offsets = d_offsets;
    p.azimuth = atof(argv[5]); p.elevation = atof(argv[6]);
    p.mask = oclshade_field_of(d_mask);
    size_t scratch_bytes = 0;                 /* the exact method's far-field certificates */
    TRY(oclshade_shadows_scratch_size(lib, &p, &scratch_bytes));
    cl_mem d_scratch = scratch_bytes ? clCreateBuffer(ctx, CL_MEM_READ_WRITE, scratch_bytes, NULL, &err) : NULL;
    if (err != CL_SUCCESS) { fprintf(stderr, "clCreateBuffer failed: %d\n", (int)err); return 1; }
    p.scratch = d_scratch;
    TRY(oclshade_enqueue_shadows(lib, queue, &p, 0, NULL, NULL));
    err = clEnqueueReadBuffer(queue, d_mask, CL_TRUE, 0, n, mask, 0, NULL, NULL);
    if (err != CL_SUCCESS) { fprintf(stderr, "clEnqueueReadBuffer failed: %d\n", (int)err); return 1; }

    f = fopen(argv[7], "wb");
    if (!f || fwrite(mask, 1, n, f) != n || fclose(f) != 0) { fprintf(stderr, "cannot write %s\n", argv[7]); return 1; }
    size_t shadowed = 0;
    for (size_t i = 0; i < n; ++i) shadowed += mask[i] == 1;
    printf("%s: %zu of %zu cells in cast shadow\n", argv[7], shadowed, n);

    oclshade_destroy(lib);
    clReleaseMemObject(d_heights); clReleaseMemObject(d_pyramid);
    clReleaseMemObject(d_offsets); clReleaseMemObject(d_mask);
    if (d_scratch) clReleaseMemObject(d_scratch);
    clReleaseCommandQueue(queue);
    clReleaseContext(ctx);
    free(raw); free(heights); free(mask);
    return 0;
}
