/* Shared by the C test programs host_shadows.c and host_passes.c: status and OpenCL error
 * checks that exit with the failing call, and small file / memory helpers.  The including
 * file defines `static oclshade *lib;` (for the last error) and `static const char *outdir;`
 * (where write_file writes) before including this header. */
#ifndef OCLSHADE_HOST_TEST_UTIL_H
#define OCLSHADE_HOST_TEST_UTIL_H

#include <stdio.h>
#include <stdlib.h>

#define CHECK(call)                                                                                   \
    do {                                                                                              \
        oclshade_status st_ = (call);                                                                 \
        if (st_ != OCLSHADE_OK) {                                                                     \
            fprintf(stderr, "%s:%d: %s -> %s: %s\n", __FILE__, __LINE__, #call,                     \
                    oclshade_status_name(st_), oclshade_last_error(lib));                            \
            exit(1);                                                                                  \
        }                                                                                             \
    } while (0)
#define CLCHECK(call)                                                                                 \
    do {                                                                                              \
        cl_int e_ = (call);                                                                           \
        if (e_ != CL_SUCCESS) {                                                                       \
            fprintf(stderr, "%s:%d: %s -> OpenCL error %d\n", __FILE__, __LINE__, #call, (int)e_);   \
            exit(1);                                                                                  \
        }                                                                                             \
    } while (0)

static inline void fail(const char *what)
{
    fprintf(stderr, "%s\n", what);
    exit(1);
}

/* n zeroed bytes (at least 1); exits when out of memory */
static inline void *xmalloc(size_t n)
{
    void *p = calloc(n ? n : 1, 1);
    if (p == NULL) fail("out of memory");
    return p;
}

/* writes n bytes to outdir/name; exits naming the path on failure */
static inline void write_file(const char *name, const void *data, size_t n)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", outdir, name);
    FILE *f = fopen(path, "wb");
    if (f == NULL || fwrite(data, 1, n, f) != n || fclose(f) != 0) fail(path);
}

#endif
