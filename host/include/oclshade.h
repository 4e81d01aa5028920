/* oclshade.h — C host API of oclshade for embedding its kernels in an
 * existing OpenCL pipeline.
 *
 * The library works on the caller's cl_context, cl_device_id and
 * cl_command_queue and on caller-owned cl_mem buffers; it allocates no device
 * memory.  It builds the kernels of kernels/ with the same -D options as the
 * Python host (oclshade/shadows.py, oclshade/pyramid.py), caches each built
 * variant in the handle, and enqueues:
 *   - the extrema pyramid of a heightmap (kernels/pyramid.cl), all levels in
 *     one buffer plus the level-offset table, exactly as oclshade/pyramid.py;
 *   - the heightmap-space shadow pass (kernels/shadow.cl): methods exact,
 *     paper, maxmip, dda; outputs mask, self-shadow flag, shadow coefficient.
 * Results are bit-identical to the Python host's on the same device (the sun
 * ray is rounded exactly as oclshade/sun.py's Sun.ray).  Conventions
 * (north-up rows, azimuth clockwise from north, output codes) are those of
 * the project README; buffer layouts are in the ABI comments at the top of
 * kernels/pyramid.cl and kernels/shadow.cl.
 *
 * Typical use (error checks omitted; see host/examples/shadow_mask.c):
 *
 *     oclshade *lib;
 *     oclshade_create(context, device, NULL, &lib);     // NULL: built-in kernel copy
 *     oclshade_set_tuning(lib, &measured);              // optional: values `oclshade tune` measured
 *     oclshade_relative_heights(dem, rows * cols, rel, &offset);  // float64 -> relative float32
 *     // heights: rows*cols floats holding rel; layout from oclshade_pyramid_layout_for
 *     oclshade_enqueue_extrema_pyramid(lib, queue, heights, rows, cols, pyr, offs, 0, NULL, NULL);
 *     oclshade_shadow_params p;
 *     oclshade_shadow_params_init(&p);
 *     p.heights = heights; p.rows = rows; p.cols = cols; p.dx = 30; p.dy = 30;
 *     p.pyramid = pyr; p.offsets = offs; p.azimuth = 315; p.elevation = 20;
 *     p.mask = mask;                                  // NULL outputs are not computed
 *     oclshade_enqueue_shadows(lib, queue, &p, 0, NULL, NULL);
 *     ...
 *     oclshade_destroy(lib);
 *
 * Errors.  Every function that can fail returns an oclshade_status;
 * oclshade_last_error() gives the message of the handle's latest failure (the
 * argument at fault and the value expected, or the OpenCL call and its error
 * code, or the compiler log of a failed build).  On failure an enqueue
 * function may already have enqueued some of its commands; its outputs are
 * then undefined and no event is returned.
 *
 * Thread safety.  The pure host functions (layouts, sun parameters, relative
 * heights) are reentrant.  One handle may be used from several threads at
 * once: calls on it serialise on an internal lock (held during a program
 * build, and around setting a kernel's arguments and enqueueing it, as the
 * OpenCL specification requires for a shared cl_kernel).  oclshade_last_error
 * reports the handle's latest failure, whichever thread made it: threads that
 * need their own messages use their own handles (builds are per handle).
 * Functions take no locks across handles; the library has no global state.
 *
 * Kernel sources.  The handle reads them once, at creation: from a directory
 * (the repository's kernels/, or the installed Python package's
 * oclshade/kernels: same files), from caller-provided strings, or from the
 * copy compiled into the library by CMake from kernels/ (the default).  The
 * library expands `#include "name"` lines itself (each file once), as the
 * Python host does, so no -I path is passed to the OpenCL compiler and the
 * cache key is the full source text.
 *
 * Queues may be in-order or out-of-order: the commands of one enqueue call
 * are chained with events, the first waits on the caller's wait list and the
 * returned event completes when all of them have.  The caller orders separate
 * calls (an in-order queue, or the events).
 *
 * Tuning.  How the shadow pass is built and launched (never what it
 * computes: every legal value gives the same results bit for bit) is set by
 * three knobs, oclshade_tuning, the Python host's "shadow" tuning family
 * (oclshade/shadows.py TUNING): packet_lanes (rays per work-item on vector
 * lanes for EXACT and MAXMIP, 0 = one ray per work-item), packet_run (cells
 * per ray-packet work-item) and group (work-group size).  A new handle starts
 * with oclshade_default_tuning(device), the Python host's rule for a device
 * without a measured entry (oclshade/tuning/rules.py: on a CPU device the
 * widest of 4 / 8 / 16 lanes within CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT;
 * elsewhere no packets; runs of 1024, groups of 64).  The values Python's
 * tuner measured for a device are printed by `oclshade devices` (`--json`:
 * tuning.shadow.values) and written by `oclshade tune` into the user entry
 * (JSON under ~/.cache/oclshade/tuning/, families.shadow.values); pass them
 * to oclshade_set_tuning (lanes -> packet_lanes, run -> packet_run, group).
 * Version 0.2 added the tuning (OCLSHADE_VERSION_MINOR 2).
 */
#ifndef OCLSHADE_H
#define OCLSHADE_H

#ifndef CL_TARGET_OPENCL_VERSION
#define CL_TARGET_OPENCL_VERSION 120
#endif
#if defined(__APPLE__)
#include <OpenCL/cl.h>
#else
#include <CL/cl.h>
#endif
#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#define OCLSHADE_VERSION_MAJOR 0
#define OCLSHADE_VERSION_MINOR 2
#define OCLSHADE_VERSION_PATCH 0

/* Status codes.  OCLSHADE_OK is 0.  A failure of a call on a handle leaves
 * its message in oclshade_last_error(); the pure host functions (no handle:
 * layouts, sun parameters, relative heights, build options) only return
 * OCLSHADE_INVALID_ARGUMENT, their arguments being few and documented
 * (oclshade_default_tuning, which queries the device, also OPENCL_ERROR). */
typedef enum oclshade_status {
    OCLSHADE_OK = 0,
    OCLSHADE_INVALID_ARGUMENT = 1,  /* the message names the argument and the expected value */
    OCLSHADE_SOURCE_ERROR = 2,      /* a kernel source file is missing or unreadable */
    OCLSHADE_BUILD_FAILED = 3,      /* program build failed; the message holds the compiler log */
    OCLSHADE_OPENCL_ERROR = 4,      /* an OpenCL call failed; see oclshade_last_cl_error() */
    OCLSHADE_OUT_OF_MEMORY = 5      /* a host allocation failed */
} oclshade_status;

/* Shadow traversal methods (kernels/shadow.cl, -D OCLS_METHOD). */
typedef enum oclshade_method {
    OCLSHADE_EXACT = 1,   /* equals the float64 reference except at float32 ties */
    OCLSHADE_PAPER = 2,   /* paper 000 Algo 3 as printed (approximate, for comparison) */
    OCLSHADE_MAXMIP = 3,  /* exact, without the min early exit */
    OCLSHADE_DDA = 4      /* exact, no hierarchy: every patch along the ray */
} oclshade_method;

/* Output bits for oclshade_prepare (oclshade_enqueue_shadows derives them
 * from which output buffers are non-NULL). */
#define OCLSHADE_OUT_MASK 1u
#define OCLSHADE_OUT_SELF 2u
#define OCLSHADE_OUT_COEFFICIENT 4u

/* Output codes (kernels/shadow.cl). */
#define OCLSHADE_MASK_LIT 0
#define OCLSHADE_MASK_SHADOW 1
#define OCLSHADE_NODATA 255       /* mask and self; the coefficient is NaN */

#define OCLSHADE_DEFAULT_K_DARK 0.25
#define OCLSHADE_DEFAULT_K_BRIGHT 0.65

/* The most pyramid levels a map can have (counting level 0): 2^31 rows. */
#define OCLSHADE_MAX_LEVELS 33

typedef struct oclshade oclshade;   /* opaque library handle */

/* An in-memory kernel source: name as in `#include "name"` and the file list
 * below ("common.h", "pyramid.cl", "shadow.cl"), text NUL-terminated. */
typedef struct oclshade_source {
    const char *name;
    const char *text;
} oclshade_source;

/* ------------------------------------------------------------------ handle */

/* Create a handle for (context, device).  kernel_dir: a directory holding
 * common.h, pyramid.cl and shadow.cl, or NULL for the copy built into the
 * library.  The context and device are retained until oclshade_destroy.
 * Sources are read here; programs are built on first use (or
 * oclshade_prepare).
 *
 * *out is set whenever the handle could be allocated, also on failure: then
 * it is a failed handle whose only uses are oclshade_last_error and
 * oclshade_destroy (like sqlite3_open).  *out is NULL only with
 * OCLSHADE_OUT_OF_MEMORY or a NULL out. */
oclshade_status oclshade_create(cl_context context, cl_device_id device, const char *kernel_dir,
                                oclshade **out);

/* As oclshade_create, with the kernel sources given as strings (copied). */
oclshade_status oclshade_create_from_sources(cl_context context, cl_device_id device,
                                             const oclshade_source *sources, size_t count,
                                             oclshade **out);

/* Release the handle, its programs and kernels, and its retains.  NULL is a no-op.
 * Enqueued commands keep their kernels alive (OpenCL reference counting). */
void oclshade_destroy(oclshade *lib);

/* Message of the handle's latest failure, "" if none; never NULL.  Valid
 * until the next call on the handle.  lib NULL gives a fixed message. */
const char *oclshade_last_error(const oclshade *lib);

/* The OpenCL error code of the latest OCLSHADE_OPENCL_ERROR or
 * OCLSHADE_BUILD_FAILED (CL_SUCCESS if the latest failure was not OpenCL's). */
cl_int oclshade_last_cl_error(const oclshade *lib);

/* "OCLSHADE_OK", "OCLSHADE_INVALID_ARGUMENT", ... ("unknown status" otherwise). */
const char *oclshade_status_name(oclshade_status status);

/* "major.minor.patch" of the library (may differ from the header's macros
 * when linked against another build). */
const char *oclshade_version(void);

/* The source text the handle builds for file "pyramid.cl" or "shadow.cl",
 * includes expanded (byte-identical to the Python host's
 * oclshade.runtime.kernel_source for the same files), or NULL for another
 * name or a failed handle.  Owned by the handle.  For logs, offline
 * compilers and users building the kernels themselves. */
const char *oclshade_program_source(const oclshade *lib, const char *file);

/* Build the programs a later enqueue with this method and output set will
 * use (outputs: OCLSHADE_OUT_* bits, at least one), and the pyramid program,
 * so that no build happens inside a frame.  Optional.  Built with the
 * handle's current tuning: call it after oclshade_set_tuning. */
oclshade_status oclshade_prepare(oclshade *lib, oclshade_method method, unsigned outputs);

/* The -D options and the program file an enqueue with (method, outputs) builds
 * without ray packets (packet_lanes 0),
 * e.g. "-DOCLS_CERT=16 -DOCLS_CERT_K=6 -DOCLS_METHOD=1 -DOCLS_OUT_MASK -cl-std=CL1.2"
 * (the Python host's, sorted by name; OCLS_CERT only for EXACT and MAXMIP).  Writes at most size bytes including the NUL; returns the
 * length the full string needs (snprintf-style), or 0 for a bad method or
 * outputs.  For logs and for users building kernels/shadow.cl themselves. */
size_t oclshade_shadow_build_options(oclshade_method method, unsigned outputs, char *buf, size_t size);

/* The options this handle builds for (method, outputs) with its current
 * tuning: where its packet_lanes > 0, EXACT and MAXMIP add
 * -DOCLS_LANES=<packet_lanes> (after -DOCLS_CERT_K) and
 * -DOCLS_PACKET=<packet_run> (before -cl-std) and launch shadow_cells_packet,
 * packet_lanes rays per work-item on vector lanes, with the same results bit
 * for bit (the Python host's ShadowFeatures(method, outputs, lanes=, run=));
 * otherwise oclshade_shadow_build_options.  Returns as that one, and 0 for a
 * failed handle. */
size_t oclshade_shadow_build_options_for(const oclshade *lib, oclshade_method method, unsigned outputs,
                                         char *buf, size_t size);

/* ------------------------------------------------------------------ tuning */

/* The shadow pass's performance knobs (see "Tuning" above); the Python
 * host's ShadowCaster(knobs={"lanes":, "run":, "group":}).  Legal values: */
typedef struct oclshade_tuning {
    int packet_lanes;  /* 0, 4, 8 or 16: rays per work-item on vector lanes for EXACT and MAXMIP
                          (-D OCLS_LANES, kernel shadow_cells_packet); 0: one ray per work-item
                          (shadow_cells).  Best at the CPU's native float vector width. */
    int packet_run;    /* 16, 64, 256 or 1024: cells of a row per ray-packet work-item
                          (-D OCLS_PACKET); read only where packet_lanes > 0 */
    int group;         /* 16, 64 or 256: the shadow pass's work-group size in work-items (the
                          largest power of two <= group that the device and kernel accept, at
                          most 16 wide, as the Python host's Runtime.grid_2d) */
} oclshade_tuning;

/* The values a new handle on `device` starts with: the Python host's rule
 * for a device without a measured entry (oclshade/tuning/rules.py) from
 * CL_DEVICE_TYPE and CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT: on a CPU device
 * packet_lanes is the widest of 4, 8, 16 within the native width (below 4:
 * 0), on other devices 0; packet_run 1024; group 64.  Reentrant (no handle).
 * INVALID_ARGUMENT for a NULL device or out, OPENCL_ERROR if the device
 * query fails; *out (if not NULL) then holds the safe values (0, 1024, 64). */
oclshade_status oclshade_default_tuning(cl_device_id device, oclshade_tuning *out);

/* Set the handle's tuning, e.g. the values `oclshade tune` measured.  Every
 * field is checked (INVALID_ARGUMENT naming the field and its legal values;
 * nothing is changed then).  Applies to the shadow passes built afterwards:
 * built shadow variants whose knobs change are dropped (under the handle's
 * lock; commands already enqueued are unaffected) and rebuilt on next use
 * or oclshade_prepare.  Setting the current values is a no-op. */
oclshade_status oclshade_set_tuning(oclshade *lib, const oclshade_tuning *tuning);

/* The handle's current tuning into *out (INVALID_ARGUMENT for NULL
 * arguments; a failed handle returns its creation status). */
oclshade_status oclshade_get_tuning(const oclshade *lib, oclshade_tuning *out);

/* ----------------------------------------------------------- heights (host) */

/* float32(heights[i] - offset) into out, subtracting in float64, with
 * offset = (min + max) / 2 of the finite heights (0 if none), exactly as the
 * Python host's Heightmap.relative32: the heights every kernel reads.  NaN
 * stays NaN (nodata); an infinite height is INVALID_ARGUMENT.  offset_out
 * may be NULL.  Reentrant. */
oclshade_status oclshade_relative_heights(const double *heights, size_t count, float *out,
                                          double *offset_out);

/* ----------------------------------------------------------- pyramid */

/* Layout of the extrema pyramid of a rows x cols map (kernels/pyramid.cl):
 * levels 1..levels-1 stored back to back in one buffer of float2 texels
 * (x = max, y = min), level 0 being the heightmap itself. */
typedef struct oclshade_pyramid_layout {
    int levels;                           /* counting level 0; >= 2 */
    int texels;                           /* float2 texels in the pyramid buffer */
    int offsets[OCLSHADE_MAX_LEVELS];     /* [l]: first texel of level l; [0] = -1 (unused), as the kernel reads */
    int level_rows[OCLSHADE_MAX_LEVELS];  /* texel rows of level l; [0] = rows */
    int level_cols[OCLSHADE_MAX_LEVELS];  /* texel cols of level l; [0] = cols */
    size_t pyramid_bytes;                 /* texels * 8: size of the pyramid buffer */
    size_t offsets_bytes;                 /* levels * 4: size of the offsets buffer (int32) */
} oclshade_pyramid_layout;

/* Fill *out for a rows x cols map (rows, cols >= 1, rows * cols < 2^31). Reentrant. */
oclshade_status oclshade_pyramid_layout_for(int rows, int cols, oclshade_pyramid_layout *out);

/* Enqueue the build of the extrema pyramid of `heights` (rows*cols float32,
 * relative heights, NaN = nodata) into `pyramid` (>= pyramid_bytes) and write
 * the level-offset table into `offsets` (>= offsets_bytes, int32) with
 * clEnqueueFillBuffer: the call neither blocks nor keeps host memory.  Both
 * buffers must be writable by kernels; heights readable.  Commands:
 * levels-1 fills, one extrema_base launch and levels-2 extrema_reduce
 * launches, chained.  event (may be NULL) completes when all have. */
oclshade_status oclshade_enqueue_extrema_pyramid(oclshade *lib, cl_command_queue queue, cl_mem heights,
                                                 int rows, int cols, cl_mem pyramid, cl_mem offsets,
                                                 cl_uint num_events_in_wait_list,
                                                 const cl_event *event_wait_list, cl_event *event);

/* ----------------------------------------------------------- sun (host) */

/* The sun as the shadow kernel reads it, computed exactly as the Python host
 * (oclshade/sun.py Sun.ray and Sun.vector, oclshade/shadows.py): sin/cos
 * exact at multiples of 90 degrees and of equal magnitude at odd multiples
 * of 45, w = 1 exactly at elevation 45, each value rounded to float32 with
 * subnormals flushed to 0. */
typedef struct oclshade_sun {
    float ray[4];     /* (ux, uy, w, 0): cells per metre east and south, tan(elevation); 0s when mode != 0 */
    float vector[4];  /* unit vector to the sun (east, north, up, 0) */
    int mode;         /* 0 trace; 1 sun at the zenith (nothing cast); 2 at or below the horizon (all shadow) */
} oclshade_sun;

/* azimuth: degrees clockwise from north, finite; elevation: degrees in
 * [-90, 90]; dx, dy: cell sizes (east-west, north-south), positive finite. Reentrant. */
oclshade_status oclshade_sun_for(double azimuth, double elevation, double dx, double dy,
                                 oclshade_sun *out);

/* ----------------------------------------------------------- shadows */

typedef struct oclshade_shadow_params {
    cl_mem heights;             /* rows*cols float32 relative heights (the pyramid's), NaN = nodata */
    int rows, cols;             /* map size; rows * cols < 2^31 */
    double dx, dy;              /* cell size east-west, north-south, in the unit of the heights */
    cl_mem pyramid, offsets;    /* from oclshade_enqueue_extrema_pyramid for these heights */
    double azimuth, elevation;  /* the sun, degrees (see oclshade_sun_for) */
    oclshade_method method;
    double k_dark, k_bright;    /* paper 000 eq. (1), each in [0, 1]; read only for the coefficient */
    cl_mem mask;                /* rows*cols uchar: 1 shadow, 0 lit, 255 nodata; NULL = not computed */
    cl_mem self_shadow;         /* rows*cols uchar: 1 sun at/below the tangent plane, 0 not, 255 nodata; or NULL */
    cl_mem coefficient;         /* rows*cols float32: 1 lit, else k_dark + (k_bright - k_dark) sin(elev); NaN nodata; or NULL */
} oclshade_shadow_params;

/* Defaults: no buffers, 0 x 0, dx = dy = 1, sun (315, 45) as gdaldem,
 * OCLSHADE_EXACT, k_dark 0.25, k_bright 0.65. */
void oclshade_shadow_params_init(oclshade_shadow_params *params);

/* Enqueue one shadow pass (one launch of shadow_cells, global size (cols,
 * rows) rounded up to the local size, or with ray packets (the tuning's
 * packet_lanes > 0, EXACT and MAXMIP) of shadow_cells_packet, global size
 * (ceil(cols / packet_run), rows) rounded up; for EXACT and MAXMIP with the sun above
 * the horizon and below the zenith, preceded by one launch of shadow_certify
 * into a temporary buffer of far-field tile certificates, see
 * kernels/shadow.cl; the returned event is the last command's).  At least one output buffer must be
 * non-NULL; the program variant compiled is the one for that output set
 * (an output not asked for is not in the program).  Buffer sizes are checked
 * against rows, cols and the pyramid layout. */
oclshade_status oclshade_enqueue_shadows(oclshade *lib, cl_command_queue queue,
                                         const oclshade_shadow_params *params,
                                         cl_uint num_events_in_wait_list,
                                         const cl_event *event_wait_list, cl_event *event);

#ifdef __cplusplus
}
#endif

#endif /* OCLSHADE_H */
