/* consumer — an OpenCL 3.0 program that embeds oclshade: builds with
 * CL_TARGET_OPENCL_VERSION=300 (the oclshade header leaves it alone), uses a 3.0 call of
 * its own (clCreateBufferWithProperties, where the driver has it) and one oclshade pass.
 * Prints the library version and "ok". */
#include <CL/cl.h>
#include <stdio.h>
#include <string.h>

#include "oclshade.h"

#if CL_TARGET_OPENCL_VERSION != 300 || !defined(CL_VERSION_3_0)
#error "the consumer's CL_TARGET_OPENCL_VERSION=300 must reach the OpenCL headers"
#endif

int main(void)
{
    cl_platform_id platform;
    cl_device_id device;
    cl_int err;
    if (clGetPlatformIDs(1, &platform, NULL) != CL_SUCCESS ||
        clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &device, NULL) != CL_SUCCESS) {
        fprintf(stderr, "no OpenCL device\n");
        return 1;
    }
    cl_context ctx = clCreateContext(NULL, 1, &device, NULL, NULL, &err);
    cl_command_queue queue = clCreateCommandQueueWithProperties(ctx, device, NULL, &err);   /* OpenCL 2.0+ */
    char version[128] = "";
    clGetDeviceInfo(device, CL_DEVICE_VERSION, sizeof version - 1, version, NULL);
    float heights[6 * 5];
    for (int i = 0; i < 30; ++i) heights[i] = (float)((i * 7) % 11);
    cl_mem h = strncmp(version, "OpenCL 3", 8) == 0
                   ? clCreateBufferWithProperties(ctx, NULL, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof heights,
                                                  heights, &err)
                   : clCreateBuffer(ctx, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof heights, heights, &err);
    oclshade *lib = NULL;
    oclshade_pyramid_layout lay;
    oclshade_status st = oclshade_create(ctx, device, NULL, &lib);
    if (st == OCLSHADE_OK) st = oclshade_pyramid_layout_for(6, 5, &lay);
    cl_mem pyr = clCreateBuffer(ctx, CL_MEM_READ_WRITE, lay.pyramid_bytes, NULL, &err);
    cl_mem offs = clCreateBuffer(ctx, CL_MEM_READ_WRITE, lay.offsets_bytes, NULL, &err);
    const oclshade_field f = oclshade_field_of(h);
    if (st == OCLSHADE_OK) st = oclshade_enqueue_extrema_pyramid(lib, queue, &f, 6, 5, pyr, offs, NULL, 0, NULL, NULL);
    float top[2] = {0, 0};
    if (st == OCLSHADE_OK)
        err = clEnqueueReadBuffer(queue, pyr, CL_TRUE, lay.pyramid_bytes - 8, 8, top, 0, NULL, NULL);
    if (st != OCLSHADE_OK || err != CL_SUCCESS || top[0] != 10.0f || top[1] != 0.0f) {
        fprintf(stderr, "consumer: %s %s (top texel %g %g)\n", oclshade_status_name(st), oclshade_last_error(lib),
                top[0], top[1]);
        return 1;
    }
    printf("oclshade %s (header %d.%d)\nok\n", oclshade_version(), OCLSHADE_VERSION_MAJOR, OCLSHADE_VERSION_MINOR);
    oclshade_destroy(lib);
    clReleaseMemObject(h); clReleaseMemObject(pyr); clReleaseMemObject(offs);
    clReleaseCommandQueue(queue);
    clReleaseContext(ctx);
    return 0;
}
