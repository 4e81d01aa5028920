/* host_threads — one handle shared by threads, for tests/test_host_api.py (which also runs
 * it built with -fsanitize=thread: no data race may be reported in the library).
 *
 * usage: host_threads [THREADS]
 * Each thread has its own queue and buffers and, ROUNDS times: makes a failing call whose
 * message names a value of its own and checks that oclshade_last_error gives it that
 * message (not another thread's); enqueues the extrema pyramid and an exact shadow pass of
 * a small map (building variants concurrently: the mask-only and the coefficient variant
 * alternate) and compares the mask with the serial one; sets knobs (thread 0 switches the
 * shadow group and lanes); and checks that a successful call leaves its message empty.
 * Prints "ok" and exits 0 on success. */
#include "oclshade.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define ROWS 23
#define COLS 31
#define ROUNDS 6

static oclshade *lib;
static cl_context ctx;
static cl_device_id device;
static float heights[ROWS * COLS];
static unsigned char serial[ROWS * COLS];

/* Pyramid + exact mask of the map on q; returns "" or what went wrong. */
static const char *shade(cl_command_queue q, int with_coefficient, unsigned char *mask)
{
    cl_int err;
    oclshade_pyramid_layout lay;
    oclshade_pyramid_layout_for(ROWS, COLS, &lay);
    cl_mem h = clCreateBuffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof heights, heights, &err);
    cl_mem pyr = clCreateBuffer(ctx, CL_MEM_READ_WRITE, lay.pyramid_bytes, NULL, &err);
    cl_mem offs = clCreateBuffer(ctx, CL_MEM_READ_WRITE, lay.offsets_bytes, NULL, &err);
    cl_mem m = clCreateBuffer(ctx, CL_MEM_READ_WRITE, ROWS * COLS, NULL, &err);
    cl_mem coef = clCreateBuffer(ctx, CL_MEM_READ_WRITE, 4 * ROWS * COLS, NULL, &err);
    const oclshade_field hf = oclshade_field_of(h);
    const char *result = "";
    oclshade_shadow_params p;
    oclshade_shadow_params_init(&p);
    p.heights = hf; p.rows = ROWS; p.cols = COLS; p.dx = 10.0; p.dy = 10.0;
    p.pyramid = pyr; p.offsets = offs; p.azimuth = 200.0; p.elevation = 12.0;
    p.mask = oclshade_field_of(m);
    if (with_coefficient) p.coefficient = oclshade_field_of(coef);
    size_t bytes = 0;
    cl_mem scratch = NULL;
    if (oclshade_shadows_scratch_size(lib, &p, &bytes) != OCLSHADE_OK) result = "shadows_scratch_size failed";
    else scratch = clCreateBuffer(ctx, CL_MEM_READ_WRITE, bytes, NULL, &err);
    p.scratch = scratch;
    if (*result == '\0' &&
        (oclshade_enqueue_extrema_pyramid(lib, q, &hf, ROWS, COLS, pyr, offs, NULL, 0, NULL, NULL) != OCLSHADE_OK ||
         oclshade_enqueue_shadows(lib, q, &p, 0, NULL, NULL) != OCLSHADE_OK))
        result = "enqueue failed";
    else if (*result == '\0' && oclshade_last_error(lib)[0] != '\0')
        result = "a successful call left a message";
    if (*result == '\0' && clEnqueueReadBuffer(q, m, CL_TRUE, 0, ROWS * COLS, mask, 0, NULL, NULL) != CL_SUCCESS)
        result = "read failed";
    clReleaseMemObject(h); clReleaseMemObject(pyr); clReleaseMemObject(offs); clReleaseMemObject(m);
    clReleaseMemObject(coef);
    if (scratch) clReleaseMemObject(scratch);
    return result;
}

static void *thread_main(void *arg)
{
    const int index = (int)(size_t)arg;
    cl_int err;
    cl_command_queue q = clCreateCommandQueue(ctx, device, 0, &err);
    if (err != CL_SUCCESS) return (void *)"clCreateCommandQueue failed";
    unsigned char mask[ROWS * COLS];
    const char *result = "";
    for (int round = 0; round < ROUNDS && *result == '\0'; ++round) {
        /* a failure naming this thread's own value */
        oclshade_shadow_params bad;
        oclshade_shadow_params_init(&bad);
        bad.rows = ROWS; bad.cols = COLS;
        bad.elevation = 91.0 + index;
        char want[64];
        snprintf(want, sizeof want, "got %g", bad.elevation);
        if (oclshade_enqueue_shadows(lib, q, &bad, 0, NULL, NULL) != OCLSHADE_INVALID_ARGUMENT ||
            strstr(oclshade_last_error(lib), want) == NULL)
            result = "a thread read another thread's message";
        if (*result == '\0' && index == 0) {
            oclshade_tuning t;
            oclshade_get_tuning(lib, &t);
            t.group = round % 2 ? 64 : 16;
            t.packet_lanes = round % 2 ? 0 : 4;
            t.packet_run = 64;
            if (oclshade_set_tuning(lib, &t) != OCLSHADE_OK) result = "set_tuning failed";
        }
        if (*result == '\0' && index == 1 && oclshade_set_knob(lib, "pyramid", "base_lanes", round % 2 ? 1 : 4) != OCLSHADE_OK)
            result = "set_knob failed";
        if (*result == '\0') result = shade(q, (round + index) % 2, mask);
        if (*result == '\0' && memcmp(mask, serial, sizeof mask) != 0) result = "mask differs from the serial one";
    }
    clReleaseCommandQueue(q);
    return (void *)result;
}

int main(int argc, char **argv)
{
    const int nthreads = argc > 1 ? atoi(argv[1]) : 4;
    if (nthreads < 1 || nthreads > 64) { fprintf(stderr, "usage: %s [THREADS 1..64]\n", argv[0]); return 2; }
    cl_platform_id platform;
    cl_int err;
    if (clGetPlatformIDs(1, &platform, NULL) != CL_SUCCESS ||
        clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &device, NULL) != CL_SUCCESS) {
        fprintf(stderr, "no OpenCL device\n");
        return 1;
    }
    ctx = clCreateContext(NULL, 1, &device, NULL, NULL, &err);
    cl_command_queue q = clCreateCommandQueue(ctx, device, 0, &err);
    if (oclshade_create(ctx, device, NULL, &lib) != OCLSHADE_OK) {
        fprintf(stderr, "create: %s\n", oclshade_last_error(lib));
        return 1;
    }
    for (int r = 0; r < ROWS; ++r)
        for (int c = 0; c < COLS; ++c) heights[r * COLS + c] = (float)(((r * 7 + c * 13) % 17) * 3 - (r == 5 ? 40 : 0));
    const char *serial_result = shade(q, 0, serial);
    if (*serial_result) { fprintf(stderr, "serial: %s: %s\n", serial_result, oclshade_last_error(lib)); return 1; }
    pthread_t threads[64];
    for (int t = 0; t < nthreads; ++t)
        if (pthread_create(&threads[t], NULL, thread_main, (void *)(size_t)t) != 0) { fprintf(stderr, "pthread_create\n"); return 1; }
    int failures = 0;
    for (int t = 0; t < nthreads; ++t) {
        void *res;
        pthread_join(threads[t], &res);
        if (*(const char *)res) { fprintf(stderr, "thread %d: %s\n", t, (const char *)res); ++failures; }
    }
    oclshade_destroy(lib);
    clReleaseCommandQueue(q);
    clReleaseContext(ctx);
    if (failures) return 1;
    printf("%d threads sharing one handle: own messages, same masks\nok\n", nthreads);
    return 0;
}
