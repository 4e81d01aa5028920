/* oclshade.h — C host API of oclshade for embedding its kernels in an
 * existing OpenCL pipeline.
 *
 * The library works on the caller's cl_context, cl_device_id and
 * cl_command_queue and on caller-owned cl_mem buffers.  It builds the kernels
 * of kernels/ with the same -D options as the Python host, caches each built
 * variant in the handle, and enqueues, one entry point per kernel family:
 *   - the extrema pyramid of a heightmap and its mean mip pyramid (kernels/pyramid.cl);
 *   - heightmap-space shadows: mask, self-shadow flag, shadow coefficient (kernels/shadow.cl);
 *   - the terrain G-buffer of a camera, and the dilated levels it reads (kernels/terrain.cl);
 *   - per-pixel shadows over a G-buffer at any level of detail (kernels/shadow.cl);
 *   - screen-space ambient occlusion with its blurs (kernels/ssao.cl);
 *   - the final frame (kernels/compose.cl);
 *   - sunshine over time: per-cell sums over many suns (kernels/sunshine.cl);
 *   - horizon angles and sky-view factor sums (kernels/horizon.cl);
 *   - cube-map environment maps: seam border, lat-long <-> cube (kernels/envmap.cl).
 * Results are bit-identical to the Python host's on the same device; the
 * host-side maths (sun rays, cameras, SSAO sample tables, coarse grids) is
 * ported from the Python host operation by operation.  Conventions (north-up
 * rows, azimuth clockwise from north, output codes, the G-buffer's frames)
 * are those of the project README and oclshade/gbuffer.py; buffer layouts are
 * in the ABI comments at the top of each kernel file (kernels/).  host/README.md gives
 * each entry point's preconditions.
 *
 * Memory.  The library allocates no device memory (CLBlast's convention).
 * Entry points that need working memory take a caller-owned `scratch` buffer
 * and have a size query (oclshade_*_scratch_size: 0 when none is needed,
 * then scratch may be NULL); the library makes sub-buffer views of it
 * (clCreateSubBuffer: views, no allocation), each at a multiple of the
 * device's CL_DEVICE_MEM_BASE_ADDR_ALIGN.  A scratch buffer may be reused
 * by every call whose commands are ordered after the previous user's (an
 * in-order queue, or events).  Heightmap and G-buffer fields are
 * oclshade_field: a buffer, a byte offset and a row pitch; a field packed at
 * offset 0 is used in place, any other is copied into the scratch
 * (clEnqueueCopyBufferRect; inputs before the kernels, outputs after them).
 *
 * Typical use (error checks omitted; see host/examples/render_frame.c):
 *
 *     oclshade *lib;
 *     oclshade_create(context, device, NULL, &lib);     // NULL: built-in kernel copy
 *     oclshade_relative_heights(dem, rows * cols, rel, &offset);  // float64 -> relative float32
 *     oclshade_field h = oclshade_field_of(heights);     // rows*cols floats holding rel
 *     oclshade_enqueue_extrema_pyramid(lib, queue, &h, rows, cols, pyr, offs, NULL, 0, NULL, NULL);
 *     oclshade_shadow_params p;
 *     oclshade_shadow_params_init(&p);
 *     p.heights = h; p.rows = rows; p.cols = cols; p.dx = 30; p.dy = 30;
 *     p.pyramid = pyr; p.offsets = offs; p.azimuth = 315; p.elevation = 20;
 *     p.mask = oclshade_field_of(mask);              // buffer NULL: not computed
 *     size_t bytes;
 *     oclshade_shadows_scratch_size(lib, &p, &bytes); // certificates of exact / maxmip
 *     p.scratch = scratch;                            // a buffer of >= bytes
 *     oclshade_enqueue_shadows(lib, queue, &p, 0, NULL, NULL);
 *     ...
 *     oclshade_destroy(lib);
 *
 * Errors.  Every function that can fail returns an oclshade_status;
 * oclshade_last_error() gives the message of the calling thread's latest
 * failure on the handle (the argument at fault and the value expected, or the
 * OpenCL call and its error code, or the compiler log of a failed build).
 * On failure an enqueue function may already have enqueued some of its
 * commands; its outputs are then undefined and no event is returned.
 *
 * Thread safety.  The pure host functions (layouts, sun, camera, tables,
 * relative heights) are reentrant.  One handle may be used from several
 * threads at once: builds, knobs and each kernel's argument setting and
 * enqueueing serialise on the handle's lock (as the OpenCL specification
 * requires for a shared cl_kernel); error messages are kept per thread (a
 * thread reads its own).  Functions take no locks across handles; the
 * library has no global state.
 *
 * Kernel sources.  The handle reads them once, at creation: from a directory
 * (the repository's kernels/, or the installed Python package's
 * oclshade/kernels: same files), from caller-provided strings, or from the
 * copy compiled into the library by CMake from kernels/ (the default).  The
 * library expands `#include "name"` lines itself (each file once), as the
 * Python host does, so no -I path is passed to the OpenCL compiler and the
 * program text is byte-identical to the Python host's.
 *
 * Queues may be in-order or out-of-order: the commands of one enqueue call
 * are chained with events, the first waits on the caller's wait list and the
 * returned event completes when all of them have (a marker after the wait list when a
 * call has nothing to enqueue: the mip pyramid of a 1 x 1 array).  The caller orders separate
 * calls (an in-order queue, or the events).  Nothing blocks: no clFinish, no
 * blocking transfer; small tables (offsets, projection rows, sample tables)
 * are written with clEnqueueFillBuffer, which copies them at the call.
 *
 * Tuning.  How each family is built and launched (never what it computes:
 * every legal value gives the same results bit for bit) is set by knobs, the
 * Python host's tuning families (oclshade/tuning): oclshade_set_knob(lib,
 * family, knob, value) with the names `oclshade devices --json` prints
 * ([i].tuning.<family>.values).  A new handle starts with the Python host's
 * rule for a device without a measured entry.  oclshade_tuning is the 0.2
 * interface to three of the shadow family's knobs.
 *
 * Version 0.3 (this header) changed 0.2's signatures: heights and outputs are
 * oclshade_field, enqueue calls that need working memory take a scratch
 * buffer, errors are per thread; see host/README.md "Changes".
 */
#ifndef OCLSHADE_H
#define OCLSHADE_H

/* The header needs only OpenCL's types: it leaves CL_TARGET_OPENCL_VERSION to the
 * includer (the library itself is built with 120 and calls only OpenCL 1.2 functions). */
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
#define OCLSHADE_VERSION_MINOR 3
#define OCLSHADE_VERSION_PATCH 0

/* Status codes.  OCLSHADE_OK is 0.  A failure of a call on a handle leaves
 * its message in oclshade_last_error(); the pure host functions (no handle)
 * only return OCLSHADE_INVALID_ARGUMENT (oclshade_default_tuning, which
 * queries the device, also OPENCL_ERROR). */
typedef enum oclshade_status {
    OCLSHADE_OK = 0,
    OCLSHADE_INVALID_ARGUMENT = 1,  /* the message names the argument and the expected value */
    OCLSHADE_SOURCE_ERROR = 2,      /* a kernel source file is missing or unreadable */
    OCLSHADE_BUILD_FAILED = 3,      /* program build failed; the message holds the compiler log */
    OCLSHADE_OPENCL_ERROR = 4,      /* an OpenCL call failed; see oclshade_last_cl_error() */
    OCLSHADE_OUT_OF_MEMORY = 5      /* a host allocation failed */
} oclshade_status;

/* Shadow traversal methods (kernels/shadow.cl, -D OCLS_METHOD), for heightmap-space and
 * per-pixel shadows. */
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
#define OCLSHADE_NODATA 255       /* mask, self and per-pixel flag and lod; the coefficient is NaN */

#define OCLSHADE_DEFAULT_K_DARK 0.25
#define OCLSHADE_DEFAULT_K_BRIGHT 0.65

/* The most pyramid levels a map can have (counting level 0): 2^31 rows. */
#define OCLSHADE_MAX_LEVELS 33

typedef struct oclshade oclshade;   /* opaque library handle */

/* An in-memory kernel source: name as in `#include "name"` and the file list
 * (common.h, pyramid.cl, shadow.cl, terrain.cl, ssao.cl, compose.cl, sunshine.cl, horizon.cl,
 * cubemap.h, envmap.cl), text NUL-terminated. */
typedef struct oclshade_source {
    const char *name;
    const char *text;
} oclshade_source;

/* A 2-D field of a buffer: rows of elements, element (0, 0) at byte `offset`, row r at
 * offset + r * row_pitch.  row_pitch 0 means packed (the row's size).  Buffers of the
 * handle's context; the element type and count per row are the entry point's. */
typedef struct oclshade_field {
    cl_mem buffer;
    size_t offset;
    size_t row_pitch;
} oclshade_field;

/* The whole of a buffer as a packed field (offset 0, pitch 0). */
static inline oclshade_field oclshade_field_of(cl_mem buffer)
{
    oclshade_field f;
    f.buffer = buffer;
    f.offset = 0;
    f.row_pitch = 0;
    return f;
}

/* ------------------------------------------------------------------ handle */

/* Create a handle for (context, device).  kernel_dir: a directory holding
 * common.h, pyramid.cl, shadow.cl, terrain.cl, ssao.cl, compose.cl, sunshine.cl, horizon.cl,
 * cubemap.h and envmap.cl, or
 * NULL for the copy built into the library.  The context and device are
 * retained until oclshade_destroy.  Sources are read here; programs are built
 * on first use (or oclshade_prepare).
 *
 * *out is set whenever the handle could be allocated, also on failure: then
 * it is a failed handle whose only uses are oclshade_last_error and
 * oclshade_destroy (like sqlite3_open).  *out is NULL only with
 * OCLSHADE_OUT_OF_MEMORY or a NULL out. */
oclshade_status oclshade_create(cl_context context, cl_device_id device, const char *kernel_dir,
                                oclshade **out);

/* As oclshade_create, with the kernel sources given as strings (copied); every file of the
 * list above must be given. */
oclshade_status oclshade_create_from_sources(cl_context context, cl_device_id device,
                                             const oclshade_source *sources, size_t count,
                                             oclshade **out);

/* Release the handle, its programs and kernels, and its retains.  NULL is a no-op.
 * Enqueued commands keep their kernels alive (OpenCL reference counting). */
void oclshade_destroy(oclshade *lib);

/* Message of the calling thread's latest failure on the handle, "" if none; never NULL.
 * Valid until the thread's next call on the handle.  A failed handle gives its creation
 * failure to every thread; lib NULL gives a fixed message. */
const char *oclshade_last_error(const oclshade *lib);

/* The OpenCL error code of the calling thread's latest OCLSHADE_OPENCL_ERROR or
 * OCLSHADE_BUILD_FAILED (CL_SUCCESS if that failure was not OpenCL's). */
cl_int oclshade_last_cl_error(const oclshade *lib);

/* "OCLSHADE_OK", "OCLSHADE_INVALID_ARGUMENT", ... ("unknown status" otherwise). */
const char *oclshade_status_name(oclshade_status status);

/* "major.minor.patch" of the library (may differ from the header's macros
 * when linked against another build). */
const char *oclshade_version(void);

/* The source text the handle builds for a program file ("pyramid.cl", "shadow.cl",
 * "terrain.cl", "ssao.cl", "compose.cl", "sunshine.cl", "horizon.cl", "envmap.cl"), includes
 * expanded (byte-identical to the Python
 * host's oclshade.runtime.kernel_source), or NULL for another name or a failed handle.
 * Owned by the handle.  For logs, offline compilers and users building the kernels
 * themselves. */
const char *oclshade_program_source(const oclshade *lib, const char *file);

/* ------------------------------------------------------------------ knobs */

/* Set one tuning knob of the handle: family and knob as the Python host names them
 * (`oclshade devices --json`: [i].tuning.<family>.values.<knob>).  The C host has:
 *   pyramid         base_lanes 1|4|8|16, own_builtins 0|1
 *   shadow          lanes 0|4|8|16, run 16|64|256|1024, group 16|64|256, cert_tile 16|32|64,
 *                   own_builtins 0|1, gather 0|1
 *   terrain         descend 1..5, leaf 0..4, group 16|64|256, own_builtins 0|1
 *   screen_shadows  group 16|64|256, own_builtins 0|1
 *   ssao            lanes 4|8|16, group 16|64|256, own_builtins 0|1
 *   horizon         group 16|64|256, own_builtins 0|1, lanes 1|4|8|16, sweep_cells 0|64|128|192|256,
 *                   sweep_far 0|1|2, width 4|8|16|32, batch 1|8|64, scan 0|1
 * (the Python pyramid knob in_place, a host-memory choice, has no C counterpart).  An
 * unknown family, knob or value is INVALID_ARGUMENT naming the legal ones; nothing
 * changes then.  Applies to the commands enqueued afterwards (programs built with other
 * values stay cached in the handle).  terrain leaf also sets the dilated levels' layout:
 * rebuild them (oclshade_enqueue_dilated_levels) after changing it. */
oclshade_status oclshade_set_knob(oclshade *lib, const char *family, const char *knob, int value);

/* The knob's current value into *value. */
oclshade_status oclshade_get_knob(const oclshade *lib, const char *family, const char *knob, int *value);

/* The knob's value for a new handle on `device`: the Python host's rule
 * (oclshade/tuning/rules.py): on a CPU device, shadow lanes and pyramid base_lanes are the
 * widest of 4 / 8 / 16 within the float lanes of the compiler's target (PoCL's HSTR
 * target name, else CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT; below 4: 0 resp. 1); every
 * other knob its safe value.  Reentrant. */
oclshade_status oclshade_default_knob(cl_device_id device, const char *family, const char *knob, int *value);

/* The shadow family's knobs lanes, run and group (the 0.2 interface; oclshade_set_knob
 * sets the same values). */
typedef struct oclshade_tuning {
    int packet_lanes;  /* shadow lanes: 0, 4, 8 or 16 rays per work-item on vector lanes for
                          EXACT and MAXMIP (-D OCLS_LANES, kernel shadow_cells_packet); 0: one
                          ray per work-item (shadow_cells) */
    int packet_run;    /* shadow run: 16, 64, 256 or 1024 cells of a row per ray-packet
                          work-item (-D OCLS_PACKET); read only where packet_lanes > 0 */
    int group;         /* shadow group: 16, 64 or 256 work-items per group of the shadow pass */
} oclshade_tuning;

/* The rule's values of the three (see oclshade_default_knob).  INVALID_ARGUMENT for a NULL
 * device or out, OPENCL_ERROR if the device query fails; *out (if not NULL) then holds the
 * safe values (0, 1024, 64). */
oclshade_status oclshade_default_tuning(cl_device_id device, oclshade_tuning *out);
/* Set the three at once (each checked; nothing changes on a bad one). */
oclshade_status oclshade_set_tuning(oclshade *lib, const oclshade_tuning *tuning);
oclshade_status oclshade_get_tuning(const oclshade *lib, oclshade_tuning *out);

/* ----------------------------------------------------------- heights (host) */

/* float32(heights[i] - offset) into out, subtracting in float64, with
 * offset = min / 2 + max / 2 of the finite heights (0 if none), exactly as the
 * Python host's Heightmap.relative32: the heights every kernel reads.  NaN
 * stays NaN (nodata); an infinite height, or one whose relative value overflows float32, is
 * INVALID_ARGUMENT.  offset_out may be NULL.  Reentrant. */
oclshade_status oclshade_relative_heights(const double *heights, size_t count, float *out,
                                          double *offset_out);

/* (min, max) of the finite values of rel (the terrain caster's height range, the Python
 * host's Heightfield.height_range); (0, 0) when none is finite.  Reentrant. */
oclshade_status oclshade_height_range(const float *rel, size_t count, float *lo, float *hi);

/* ----------------------------------------------------------- extrema pyramid */

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

/* Scratch bytes oclshade_enqueue_extrema_pyramid needs: 0 for heights packed at offset 0,
 * else rows * cols * 4 (their packed copy). */
oclshade_status oclshade_extrema_pyramid_scratch_size(oclshade *lib, const oclshade_field *heights,
                                                      int rows, int cols, size_t *bytes);

/* Enqueue the build of the extrema pyramid of `heights` (rows x cols float32, relative
 * heights, NaN = nodata) into `pyramid` (>= pyramid_bytes) and write the level-offset table
 * into `offsets` (>= offsets_bytes, int32) with clEnqueueFillBuffer.  pyramid and offsets
 * are written, so neither may be CL_MEM_READ_ONLY nor overlap heights or each other.
 * Commands: levels-1 fills, one extrema_base launch and levels-2 extrema_reduce launches
 * (after a copy of pitched heights into scratch), chained.  event (may be NULL) completes
 * when all have.  Knobs: pyramid base_lanes, own_builtins. */
oclshade_status oclshade_enqueue_extrema_pyramid(oclshade *lib, cl_command_queue queue,
                                                 const oclshade_field *heights, int rows, int cols,
                                                 cl_mem pyramid, cl_mem offsets, cl_mem scratch,
                                                 cl_uint num_events_in_wait_list,
                                                 const cl_event *event_wait_list, cl_event *event);

/* ----------------------------------------------------------- mean mip pyramid */

/* Layout of the mean mip pyramid of a rows x cols float32 array (kernels/pyramid.cl
 * mip_reduce; oclshade/pyramid.py build_mip_levels): level 0 is the array itself,
 * level l has ceil(rows / 2^l) x ceil(cols / 2^l) floats, down to 1 x 1.  The mip buffer
 * holds levels 1..levels-1, each packed, level l at byte offsets[l] (a multiple of the
 * device's CL_DEVICE_MEM_BASE_ADDR_ALIGN, so a layout is per handle). */
typedef struct oclshade_mip_layout {
    int levels;                           /* counting level 0; 1 for a 1 x 1 array */
    int level_rows[OCLSHADE_MAX_LEVELS];
    int level_cols[OCLSHADE_MAX_LEVELS];
    size_t offsets[OCLSHADE_MAX_LEVELS];  /* bytes; [0] = 0 (level 0 is not in the buffer) */
    size_t bytes;                         /* size of the mip buffer (0 for a 1 x 1 array) */
} oclshade_mip_layout;

oclshade_status oclshade_mip_layout_for(oclshade *lib, int rows, int cols, oclshade_mip_layout *out);

/* Scratch bytes oclshade_enqueue_mip_pyramid needs: 0 for values packed at offset 0, else a
 * packed copy. */
oclshade_status oclshade_mip_pyramid_scratch_size(oclshade *lib, const oclshade_field *values, int rows,
                                                  int cols, size_t *bytes);

/* Enqueue the mean mip pyramid of `values` (rows x cols float32, NaN = no data) into `mip`
 * (>= layout.bytes; written): one mip_reduce launch per level, chained (each level is a
 * sub-buffer view of mip).  Level l texel = the mean of the valid values among the (up to)
 * 2 x 2 below, NaN if none (kernels/pyramid.cl). */
oclshade_status oclshade_enqueue_mip_pyramid(oclshade *lib, cl_command_queue queue,
                                             const oclshade_field *values, int rows, int cols, cl_mem mip,
                                             cl_mem scratch, cl_uint num_events_in_wait_list,
                                             const cl_event *event_wait_list, cl_event *event);

/* ----------------------------------------------------------- sun (host) */

/* The sun as the shadow kernels read it, computed exactly as the Python host
 * (oclshade/sun.py Sun.ray and Sun.vector): sin/cos exact at multiples of 90 degrees and of
 * equal magnitude at odd multiples of 45, w = 1 exactly at elevation 45, each value
 * rounded to float32 with subnormals flushed to 0. */
typedef struct oclshade_sun {
    float ray[4];     /* (ux, uy, w, 0): cells per metre east and south, tan(elevation); 0s when mode != 0 */
    float vector[4];  /* unit vector to the sun (east, north, up, 0) */
    int mode;         /* 0 trace; 1 sun at the zenith (nothing cast); 2 at or below the horizon (all shadow) */
} oclshade_sun;

/* azimuth: degrees clockwise from north, finite; elevation: degrees in
 * [-90, 90]; dx, dy: cell sizes (east-west, north-south), positive finite. Reentrant. */
oclshade_status oclshade_sun_for(double azimuth, double elevation, double dx, double dy,
                                 oclshade_sun *out);

/* The unit vector to the sun in float64 (east, north, up): oclshade/sun.py Sun.vector. */
oclshade_status oclshade_sun_vector(double azimuth, double elevation, double out[3]);

/* ----------------------------------------------------------- heightmap-space shadows */

typedef struct oclshade_shadow_params {
    oclshade_field heights;     /* rows x cols float32 relative heights (the pyramid's), NaN = nodata */
    int rows, cols;             /* map size; rows * cols < 2^31 */
    double dx, dy;              /* cell size east-west, north-south, in the unit of the heights */
    cl_mem pyramid, offsets;    /* from oclshade_enqueue_extrema_pyramid for these heights */
    double azimuth, elevation;  /* the sun, degrees (see oclshade_sun_for) */
    oclshade_method method;
    double k_dark, k_bright;    /* paper 000 eq. (1), each in [0, 1]; read only for the coefficient */
    oclshade_field mask;        /* rows x cols uchar: 1 shadow, 0 lit, 255 nodata; buffer NULL = not computed */
    oclshade_field self_shadow; /* rows x cols uchar: 1 sun at/below the tangent plane, 0 not, 255 nodata */
    oclshade_field coefficient; /* rows x cols float32: 1 lit, else k_dark + (k_bright - k_dark) sin(elev); NaN nodata */
    cl_mem scratch;             /* >= oclshade_shadows_scratch_size bytes, or NULL when that is 0 */
    int origin_row, origin_col; /* the map's first cell in a larger map it is a window of (0, 0: a whole
                                   map); >= 0, origin + size <= 2^30.  The kernels form the larger
                                   map's coordinates, so a window holding every cell that can shade
                                   a cell decides it bit for bit as the larger map does (Python:
                                   ShadowCaster(origin=...), oclshade.tiles) */
    int block_row0, block_col0; /* a block of this map's cells to trace, and only it (Python: a SunField's */
    int block_rows, block_cols; /* blocks, each with its own sun, ShadowCaster.cast_many): 0 x 0, the
                                   default, is every cell; outputs outside the block are left as they
                                   are.  The certificates of the tiles the block touches are made (in
                                   the scratch, for this sun).  With ray packets the run knob is cut to
                                   divide block_col0 and, unless the block ends at the last column,
                                   block_cols; below the lanes knob one ray per work-item runs */
    int field_row_blocks;       /* A sun field in one launch (-D OCLS_SUN_TABLE, kernels/shadow.cl "sun */
    int field_col_blocks;       /* tables"; Python: ShadowCaster.cast_many([SunField]) of a BlockGrid):
                                   0 x 0 (default): the one sun.  Else block (a, b) holds rows
                                   field_row_edges[a] .. field_row_edges[a + 1] - 1 and columns
                                   field_col_edges[b] .. field_col_edges[b + 1] - 1 (edges increasing
                                   from 0 to rows and cols) and is traced with the sun
                                   field_suns[2 k], field_suns[2 k + 1] (azimuth, elevation in degrees;
                                   k = a field_col_blocks + b); azimuth and elevation above are
                                   unread.  The tables go to the scratch; the packet run is cut to
                                   divide every block's first column.  Not with a block window. */
    const int *field_row_edges, *field_col_edges;
    const double *field_suns;
} oclshade_shadow_params;

/* Defaults: no buffers, 0 x 0, origin (0, 0), dx = dy = 1, sun (315, 45) as gdaldem,
 * OCLSHADE_EXACT, k_dark 0.25, k_bright 0.65. */
void oclshade_shadow_params_init(oclshade_shadow_params *params);

/* Scratch bytes oclshade_enqueue_shadows needs for these parameters: the far-field tile
 * certificates of EXACT and MAXMIP (ceil(rows / t) * ceil(cols / t) * 6 floats, t the
 * shadow cert_tile knob), packed copies of fields that are not packed at offset 0, and a sun
 * field's tables ((rows + cols) ints, 2 float4 and an int per block). */
oclshade_status oclshade_shadows_scratch_size(oclshade *lib, const oclshade_shadow_params *params,
                                              size_t *bytes);

/* Enqueue one shadow pass: for EXACT and MAXMIP with the sun above the horizon and below the
 * zenith one launch of shadow_certify into the scratch, then one launch of shadow_cells
 * (global size (cols, rows) rounded up to the local size), or with ray packets (the shadow
 * lanes knob > 0, EXACT and MAXMIP) of shadow_cells_packet, global size (ceil(cols / run),
 * rows) rounded up.  At least one output buffer must be non-NULL; the program variant
 * compiled is the one for that output set (an output not asked for is not in the
 * program).  With a sun field (field_row_blocks > 0) the same two launches with -D
 * OCLS_SUN_TABLE, shadow_certify always, the band, table and mode arrays (kernels/shadow.cl,
 * "sun tables") uploaded to the scratch first.  Knobs: shadow lanes, run, group, cert_tile,
 * own_builtins, gather. */
oclshade_status oclshade_enqueue_shadows(oclshade *lib, cl_command_queue queue,
                                         const oclshade_shadow_params *params,
                                         cl_uint num_events_in_wait_list,
                                         const cl_event *event_wait_list, cl_event *event);

/* Build the programs a later oclshade_enqueue_shadows with this method and output set will
 * use (outputs: OCLSHADE_OUT_* bits, at least one), and the extrema pyramid's, so that no
 * build happens inside a frame.  Optional.  Built with the handle's current knobs. */
oclshade_status oclshade_prepare(oclshade *lib, oclshade_method method, unsigned outputs);

/* The -D options and the program file an enqueue with (method, outputs) builds
 * without ray packets (lanes 0) and with the safe knobs,
 * e.g. "-DOCLS_CERT=16 -DOCLS_CERT_K=6 -DOCLS_METHOD=1 -DOCLS_OUT_MASK -cl-std=CL1.2"
 * (the Python host's, sorted by name; OCLS_CERT only for EXACT and MAXMIP).  Writes at most
 * size bytes including the NUL; returns the length the full string needs (snprintf-style),
 * or 0 for a bad method or outputs. */
size_t oclshade_shadow_build_options(oclshade_method method, unsigned outputs, char *buf, size_t size);

/* The options this handle builds for (method, outputs) with its current knobs (the Python
 * host's ShadowFeatures(method, outputs, lanes=, run=, own_builtins=, cert_tile=)); 0 for a
 * failed handle. */
size_t oclshade_shadow_build_options_for(const oclshade *lib, oclshade_method method, unsigned outputs,
                                         char *buf, size_t size);

/* ----------------------------------------------------------- camera (host) */

typedef enum oclshade_projection {
    OCLSHADE_PERSPECTIVE = 0,
    OCLSHADE_ORTHOGRAPHIC = 1
} oclshade_projection;

/* A camera in the frames of oclshade/gbuffer.py and oclshade/camera.py: world x east,
 * y north, z up (metres; sample (i, j) at (j dx, -i dy, height)); view space right-handed,
 * looking down -z; pixel (r, c) at NDC x = (2c + 1) / width - 1, y = 1 - (2r + 1) / height.
 * Matrices are row-major (m[4 * row + col]) and act on column vectors. */
typedef struct oclshade_camera {
    int width, height;                /* pixels, 1..32768 */
    oclshade_projection projection;
    double view[16];                  /* world -> view (a rotation and a translation) */
    double projection_matrix[16];     /* view -> clip, OpenGL conventions (NDC z in [-1, 1]) */
    double sx, sy;                    /* pixel-ray slopes (perspective) or half extents (orthographic) */
    double near_depth, far_depth;     /* near, far: the visible depths t = -z_view (not `near`/`far`: macros on Windows) */
} oclshade_camera;

/* oclshade.camera.Camera(position, look_at, width, height, up, fov, near, far, projection,
 * ortho_height): up NULL is +z; fov (degrees, (0, 180)) is read for a perspective camera,
 * ortho_height (metres, > 0) for an orthographic one; near > 0 (perspective) or >= 0
 * (orthographic), far > near.  Every value computed in float64 in the Python host's order
 * of operations. */
oclshade_status oclshade_camera_look_at(const double position[3], const double look_at[3],
                                        const double up[3], int width, int height,
                                        oclshade_projection projection, double fov, double ortho_height,
                                        double near_depth, double far_depth, oclshade_camera *out);

/* A camera from an engine's matrices: view a rigid world -> view transform (orthonormal
 * rotation within 1e-9, last row 0 0 0 1), projection an OpenGL symmetric perspective
 * (row 3 = 0 0 -1 0, no off-centre terms) or orthographic (row 3 = 0 0 0 1) projection.
 * sx, sy, near, far are recovered from it. */
oclshade_status oclshade_camera_from_matrices(const double view[16], const double projection[16], int width,
                                              int height, oclshade_camera *out);

/* ----------------------------------------------------------- terrain G-buffer */

/* Ray casters of kernels/terrain.cl (-D OCLS_METHOD). */
typedef enum oclshade_caster {
    OCLSHADE_CAST_BISECT = 1,  /* paper 004 voxel bisection (the default) */
    OCLSHADE_CAST_MARCH = 2,   /* uniform steps (a baseline; misses thin crossings) */
    OCLSHADE_CAST_DDA = 3      /* max-mipmap traversal (Tevs et al. 2008) */
} oclshade_caster;

/* The G-buffer (oclshade/gbuffer.py): width x height pixels per field, row-major from the
 * top row.  Elements: position float4, normal float4, uv float2, uv_grad float4, depth
 * float, albedo float4. */
typedef struct oclshade_gbuffer {
    oclshade_field position, normal, uv, uv_grad, depth, albedo;
} oclshade_gbuffer;

/* Layout of the dilated max levels bisection reads (kernels/terrain.cl terrain_dilate):
 * levels first..levels-1 back to back (float), first = min(terrain leaf knob, levels-1),
 * and a table of int2 (offset in floats, columns) per level 0..levels-1. */
typedef struct oclshade_dilated_layout {
    int levels;                           /* the extrema pyramid's, counting level 0 */
    int first;                            /* the first level stored */
    int level_rows[OCLSHADE_MAX_LEVELS];  /* ceil(Hp / 2^l), Hp = max(rows - 1, 1) */
    int level_cols[OCLSHADE_MAX_LEVELS];
    int offsets[OCLSHADE_MAX_LEVELS];     /* floats; 0 below first */
    size_t bytes;                         /* the dilated buffer */
    size_t table_bytes;                   /* the table buffer: levels * 8 */
} oclshade_dilated_layout;

/* For a rows x cols map with the handle's current terrain leaf knob. */
oclshade_status oclshade_dilated_layout_for(oclshade *lib, int rows, int cols, oclshade_dilated_layout *out);

oclshade_status oclshade_dilated_levels_scratch_size(oclshade *lib, const oclshade_field *heights, int rows,
                                                     int cols, size_t *bytes);

/* Enqueue terrain_dilate for every stored level into `dilated` (>= layout bytes) and write
 * the table into `table` (>= table_bytes) with fills.  Once per map (and after a change
 * of the terrain leaf knob); pyramid and offsets from oclshade_enqueue_extrema_pyramid. */
oclshade_status oclshade_enqueue_dilated_levels(oclshade *lib, cl_command_queue queue,
                                                const oclshade_field *heights, int rows, int cols,
                                                cl_mem pyramid, cl_mem offsets, cl_mem dilated, cl_mem table,
                                                cl_mem scratch, cl_uint num_events_in_wait_list,
                                                const cl_event *event_wait_list, cl_event *event);

typedef struct oclshade_terrain_params {
    oclshade_field heights;     /* rows x cols float32 relative heights, NaN = hole */
    int rows, cols;
    double dx, dy;              /* cell sizes, metres */
    double offset;              /* the heights' offset (oclshade_relative_heights) */
    float hmin, hmax;           /* oclshade_height_range of the relative heights */
    double radius;              /* > 0: the map on a sphere of this radius (paraboloid base); 0: plane */
    cl_mem pyramid, offsets;    /* oclshade_enqueue_extrema_pyramid */
    cl_mem dilated, dilated_table;  /* oclshade_enqueue_dilated_levels (read by bisect; may be NULL otherwise) */
    oclshade_camera camera;
    oclshade_caster method;
    /* optional colour texture (-D OCLS_COLOUR), NULL for the hypsometric tint: float4 linear
     * RGBA mip levels back to back and an int4 (offset in float4, cols, rows, 0) per level
     * (kernels/terrain.cl; oclshade/terrain.py TerrainRenderer.texture) */
    cl_mem texture, texture_levels;
    int texture_count;
    oclshade_gbuffer gbuffer;   /* outputs: camera.width x camera.height, every field written */
    cl_mem scratch;
} oclshade_terrain_params;

/* Defaults: no buffers, dx = dy = 1, plane, bisect, a 1 x 1 perspective camera. */
void oclshade_terrain_params_init(oclshade_terrain_params *params);
oclshade_status oclshade_terrain_scratch_size(oclshade *lib, const oclshade_terrain_params *params,
                                              size_t *bytes);
/* One launch of terrain_cast, one work-item per pixel.  Knobs: terrain descend, leaf,
 * group, own_builtins (bisect). */
oclshade_status oclshade_enqueue_terrain(oclshade *lib, cl_command_queue queue,
                                         const oclshade_terrain_params *params,
                                         cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                         cl_event *event);

/* Smooth shading normals of the G-buffer oclshade_enqueue_terrain wrote for these parameters
 * (its uv and position fields are read; kernels/terrain.cl terrain_normals, "Shading
 * normals"): view-space unit float4 normals (w = 0, 0 on empty pixels) into `normals`
 * (camera.width x camera.height), slopes by central differences interpolated at the hit, so
 * a smooth terrain shades without facets.  One 1-D launch; built like the cast. */
oclshade_status oclshade_terrain_normals_scratch_size(oclshade *lib, const oclshade_terrain_params *params,
                                                      const oclshade_field *normals, size_t *bytes);
oclshade_status oclshade_enqueue_terrain_normals(oclshade *lib, cl_command_queue queue,
                                                 const oclshade_terrain_params *params, const oclshade_field *normals,
                                                 cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                 cl_event *event);

/* ----------------------------------------------------------- per-pixel shadows */

/* The level-q surfaces per-pixel shadows start on (oclshade/screen_shadows.py coarse_grid):
 * for q = 1..levels-1 a (ceil(Hp / 2^q) + 1) x (ceil(Wp / 2^q) + 1) float grid, back to
 * back, and the int32 table of their offsets ([q] in floats, [0] = -1). */
typedef struct oclshade_coarse_layout {
    int levels;                           /* the extrema pyramid's */
    int grid_rows[OCLSHADE_MAX_LEVELS], grid_cols[OCLSHADE_MAX_LEVELS];
    int offsets[OCLSHADE_MAX_LEVELS];     /* [q] first float of grid q; [0] = -1 */
    size_t grids_bytes, offsets_bytes;
} oclshade_coarse_layout;

oclshade_status oclshade_coarse_layout_for(int rows, int cols, oclshade_coarse_layout *out);

/* Fill the grids (host memory, grids_bytes) and the offset table (offsets_bytes) from the
 * relative heights (host, rows x cols packed) and the host copy of their mean mip pyramid
 * (oclshade_enqueue_mip_pyramid of the heights into a buffer of mip_layout, read back; NULL
 * for a 1 x 1 map): grid q samples mip level min(q, mip levels - 1) (level 0: the heights)
 * bilinearly at the level-q tile corners, in float64, rounded to float32, as the Python
 * host.  The caller uploads both.  Reentrant. */
oclshade_status oclshade_coarse_grids(const float *heights, const void *mip, const oclshade_mip_layout *mip_layout,
                                      int rows, int cols, float *grids, int *offsets);

typedef struct oclshade_pixel_shadow_params {
    oclshade_field heights;     /* rows x cols relative heights (the pyramid's) */
    int rows, cols;
    double dx, dy;
    cl_mem pyramid, offsets;    /* extrema pyramid */
    cl_mem coarse, coarse_offsets;  /* the uploaded oclshade_coarse_grids */
    oclshade_field position, uv, uv_grad;   /* G-buffer fields read (float4, float2, float4) */
    int width, height;          /* pixels */
    double azimuth, elevation;
    oclshade_method method;
    int force_q;                /* 0: exact (default); a fixed level 1..levels-1; -1: Algo 1 picks q */
    int bias;                   /* added to Algo 1's q, |bias| <= 64 */
    int n_a_max;                /* anisotropy cap, 1..256 */
    double k_dark, k_bright;
    oclshade_field flag;        /* uchar: 1 cast shadow, 0 lit, 255 empty; buffer NULL = not computed */
    oclshade_field coefficient; /* float: eq. (1), 1 lit or empty */
    oclshade_field lod;         /* uchar: the level q used, 255 empty */
    cl_mem scratch;
} oclshade_pixel_shadow_params;

/* Defaults: exact, q = 0 (force_q 0; -1: Algo 1 with bias 0, n_a_max 16), sun (315, 45), k 0.25 / 0.65. */
void oclshade_pixel_shadow_params_init(oclshade_pixel_shadow_params *params);
oclshade_status oclshade_pixel_shadows_scratch_size(oclshade *lib, const oclshade_pixel_shadow_params *params,
                                                    size_t *bytes);
/* One launch of shadow_pixels.  Knobs: screen_shadows group, own_builtins. */
oclshade_status oclshade_enqueue_pixel_shadows(oclshade *lib, cl_command_queue queue,
                                               const oclshade_pixel_shadow_params *params,
                                               cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                               cl_event *event);

/* ----------------------------------------------------------- SSAO */

/* Sample tables (oclshade/ssao.py). */
typedef enum oclshade_ao_samples {
    OCLSHADE_AO_PAPER = 0,     /* the paper's half-cube, numpy PCG64 seeded 2019 (point samples) */
    OCLSHADE_AO_UNIFORM = 1,   /* stratified, uniform in the hemisphere's volume (point samples) */
    OCLSHADE_AO_CENTRE = 2,    /* uniform's directions, radii towards the centre (point samples) */
    OCLSHADE_AO_LINES = 3,     /* line samples (-D OCLS_LINES): Vogel disk + chord half-lengths */
    OCLSHADE_AO_RAYS = 4       /* ray samples (-D OCLS_RAYS): the same table as directions */
} oclshade_ao_samples;

typedef enum oclshade_blur {
    OCLSHADE_BLUR_NONE = 0,
    OCLSHADE_BLUR_BOX = 1,     /* the paper's box blur, separable */
    OCLSHADE_BLUR_EDGE = 2     /* edge-aware */
} oclshade_blur;

/* The table ssao_ao reads for m samples (4..256): structure of arrays x[mpad], y[mpad],
 * z[mpad], mpad = m rounded up to a multiple of 8, entries m..mpad-1 NaN: the bits of the
 * Python host's SSAO._table (3 * mpad floats; *mpad_out may be NULL).  Reentrant. */
oclshade_status oclshade_ssao_table(oclshade_ao_samples samples, int m, float *out, int *mpad_out);

typedef struct oclshade_ssao_params {
    oclshade_field position, normal;   /* G-buffer fields (float4) */
    oclshade_field alpha;              /* float alpha map, buffer NULL = no alpha (-D OCLS_ALPHA) */
    oclshade_field normal_map, tangent;/* float4 each, both or neither (-D OCLS_NORMAL_MAP) */
    int width, height;
    double projection[16];             /* view -> clip, row-major (oclshade_camera.projection_matrix) */
    double radius;                     /* metres, > 0 */
    int m;                             /* samples (rays for OCLSHADE_AO_RAYS), 4..256 */
    double delta;                      /* depth bias, finite */
    unsigned seed;
    oclshade_ao_samples samples;
    int range_check, plane_test;       /* 0 / 1 (-D OCLS_RANGE_CHECK, OCLS_PLANE_TEST) */
    oclshade_blur blur;
    int blur_size;                     /* odd >= 3 */
    double alpha_eps;                  /* alpha cut-out threshold (with alpha) */
    double plane_tol;                  /* edge-aware blur; 0: radius / 4 */
    oclshade_field ao;                 /* output: float per pixel, 1 = unoccluded */
    cl_mem scratch;
} oclshade_ssao_params;

/* Defaults: the library's (oclshade/ssao.py DEFAULT_FEATURES, DEFAULT_M): 8 ray samples,
 * range check, 3 x 3 box blur; delta 0, seed 0, alpha_eps 0.5; radius 0 (must be set). */
void oclshade_ssao_params_init(oclshade_ssao_params *params);
/* Scratch: per pixel 4 (depth) + 16 (normals) + 4 (raw AO) bytes, + 16 (plane test),
 * + 8 (box blur sums), plus the projection rows and the sample table, plus packed copies. */
oclshade_status oclshade_ssao_scratch_size(oclshade *lib, const oclshade_ssao_params *params, size_t *bytes);
/* ssao_prepare, ssao_ao, then the blur (box: ssao_box_h + ssao_box_v; edge: ssao_edge).
 * Knobs: ssao lanes, group, own_builtins. */
oclshade_status oclshade_enqueue_ssao(oclshade *lib, cl_command_queue queue, const oclshade_ssao_params *params,
                                      cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                      cl_event *event);

/* ----------------------------------------------------------- compose */

typedef struct oclshade_compose_params {
    /* inputs: (height * ssaa) x (width * ssaa) samples each */
    oclshade_field position, albedo;          /* G-buffer fields (float4) */
    oclshade_field normal;      /* float4 shading normals: oclshade_enqueue_terrain_normals' (smooth) or the
                                   G-buffer's normal field (geometric) */
    oclshade_field shadow;      /* float sun visibility per sample (1 = lit), buffer NULL = none */
    oclshade_field ao;          /* float AO factor (1 = unoccluded), buffer NULL = none */
    int width, height;          /* the frame, pixels */
    int ssaa;                   /* samples per pixel along each axis, 1..8, box-filtered */
    double rotation[9];         /* world -> view rotation, row-major (the camera view's 3 x 3) */
    double azimuth, elevation;  /* the sun */
    double sun_intensity;       /* the sun's irradiance on a plane facing it, >= 0 */
    double sky[3];              /* the sky's irradiance on a horizontal plane, linear RGB, >= 0 */
    double background[3];       /* linear RGB of empty samples, >= 0 */
    oclshade_field image;       /* output: width x height uchar4 sRGB (r, g, b, 255); with linear,
                                   width x height float4 linear light (r, g, b, 1) */
    int linear;                 /* 0: 8-bit sRGB, each sample clamped to [0, 1]; 1: the unclamped
                                   mean in float4 (-D OCLS_LINEAR; oclshade.compose.compose_linear:
                                   what generated cube maps are made of) */
    /* The light: the sun (azimuth, elevation) unless point_light is 1, a point light
     * (oclshade.lights.PointLight; -D OCLS_POINT_LIGHT, docs/meshes.md "Point lights"): per
     * sample the direction to light_position, sun_intensity (light_distance / d)^2 at d metres
     * (the inverse-square falloff about its reference distance), or sun_intensity at every
     * distance with light_distance 0 (PointLight(distance=None)). */
    int point_light;            /* 0: the sun; 1: a point light */
    double light_position[3];   /* point light: world position (x east, y north, z up; metres), finite */
    double light_distance;      /* point light: reference distance of the falloff (m), > 0; 0: none */
    double translation[3];      /* point light: world -> view translation (the camera view's last
                                   column, oclshade_compose_set_camera sets it with the rotation) */
    cl_mem scratch;
} oclshade_compose_params;

/* Defaults: oclshade/compose.py Lighting(): sun (315, 45), intensity 2.0, sky (0.21, 0.24,
 * 0.30), background (0.45, 0.62, 0.85); ssaa 1; identity rotation, zero translation; no point
 * light. */
void oclshade_compose_params_init(oclshade_compose_params *params);
/* Sets rotation and translation from the camera's view matrix. */
void oclshade_compose_set_camera(oclshade_compose_params *params, const oclshade_camera *camera);
oclshade_status oclshade_compose_scratch_size(oclshade *lib, const oclshade_compose_params *params, size_t *bytes);
/* One launch of compose, one work-item per output pixel (-D OCLS_SHADOW / OCLS_AO for the
 * inputs given): albedo x (sun x max(n.s, 0) x shadow + sky x AO x (1 + n.up) / 2),
 * kernels/compose.cl; a point light (-D OCLS_POINT_LIGHT): s per sample towards the light's
 * view-space position (view rotation @ light_position + translation, float64 rounded once:
 * Lighting.light_view), falloff = light_distance^2 rounded to float32 (Lighting.falloff). */
oclshade_status oclshade_enqueue_compose(oclshade *lib, cl_command_queue queue, const oclshade_compose_params *params,
                                         cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                         cl_event *event);

/* ----------------------------------------------------------- zeroing */

/* Zero the first `bytes` of `buffer` (>= 1; clEnqueueFillBuffer with zero patterns): the
 * accumulators of oclshade_enqueue_sunshine and oclshade_enqueue_horizon's svf sums before
 * the first sun or azimuth (the Python hosts' enqueue_fill_buffer).  buffer is written. */
oclshade_status oclshade_enqueue_zero(oclshade *lib, cl_command_queue queue, cl_mem buffer, size_t bytes,
                                      cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                      cl_event *event);

/* ----------------------------------------------------------- sunshine over time */

/* One daylight sun's contribution to per-cell sums (kernels/sunshine.cl; oclshade/sunshine
 * SunshineCaster.accumulate): per cell, with s the unit vector to the sun and (gx, gy) the
 * gradient of shadow.cl's self test, facing = s.z - gx s.x + gy s.y > 0, cast = the cell is in
 * cast shadow, direct = facing and not cast:
 *   sun   uint32 seconds of direct sun:   += seconds when direct
 *   cast  uint32 seconds in cast shadow:  += seconds when cast
 *   beam  float2 (sum, compensation) of a Kahan sum of (seconds / 3600) cos(incidence) when
 *         direct; the hours are sum - compensation (in float64)
 * Nodata cells are left untouched.  The sums are whole packed buffers of rows * cols
 * elements, zeroed by oclshade_enqueue_zero before the first sun; the caller keeps the
 * total of the seconds below 2^32 (device contents are not checked).  The Python host's
 * outputs: hours = sun / 3600, fraction = cast / (total daylight seconds), irradiation =
 * beam.x - beam.y, NaN at nodata. */
typedef struct oclshade_sunshine_params {
    oclshade_field heights;     /* rows x cols float32 relative heights (the shadow pass's), NaN = nodata */
    int rows, cols;
    double dx, dy;              /* cell size east-west, north-south */
    double azimuth, elevation;  /* the sun, degrees; elevation in (0, 90] (the host skips the night) */
    cl_uint seconds;            /* the sun's weight w, >= 1 */
    /* where the cast-shadow flag comes from: exactly one of */
    oclshade_field mask;        /* rows x cols uchar: oclshade_enqueue_shadows' mask for this sun (kernel
                                   sunshine_masks), or */
    oclshade_field low, high;   /* rows x cols float32 horizon angles (degrees, oclshade_enqueue_horizon) at
                                   the two grid azimuths around the sun's (kernel sunshine_horizons): cast iff
                                   low + fraction (high - low) > elevation, in float32 */
    double fraction;            /* horizons: where the sun's azimuth lies between low's and high's, [0, 1]
                                   (rounded to float32, as the Python host's np.float32) */
    cl_mem sun, cast, beam;     /* the sums (read and written); NULL = not accumulated, at least one given */
    cl_mem scratch;             /* >= oclshade_sunshine_scratch_size (packed copies of pitched inputs) */
} oclshade_sunshine_params;

/* Defaults: no buffers, 0 x 0, dx = dy = 1, sun (0, 45), seconds 1, fraction 0. */
void oclshade_sunshine_params_init(oclshade_sunshine_params *params);
oclshade_status oclshade_sunshine_scratch_size(oclshade *lib, const oclshade_sunshine_params *params,
                                               size_t *bytes);
/* One launch of sunshine_masks (mask given) or sunshine_horizons (low and high given), global
 * size (cols, rows) rounded up to the local size, compiled with -D OCLS_OUT_SUN / OCLS_OUT_CAST
 * / OCLS_OUT_BEAM for the sums given.  Calls for successive suns on the same sums must be
 * ordered (an in-order queue or the events). */
oclshade_status oclshade_enqueue_sunshine(oclshade *lib, cl_command_queue queue,
                                          const oclshade_sunshine_params *params,
                                          cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                          cl_event *event);

/* ----------------------------------------------------------- sun position */

/* The sun's topocentric azimuth and elevation by NREL's Solar Position Algorithm (Reda & Andreas
 * 2008), as oclshade.solar.sun_position computes them (within 1e-8 degree of it, and within 0.01
 * degree of pvlib over the years 1950-2100: tests/test_solar.py).  Pure host code, no handle:
 * OCLSHADE_INVALID_ARGUMENT for an argument out of its range. */
typedef struct oclshade_sun_options {
    double altitude;      /* the observer's height above sea level, metres (parallax), finite; 0 */
    double pressure;      /* hPa, > 0 (refraction only); 1010 */
    double temperature;   /* degrees Celsius, > -273 (refraction only); 10 */
    double delta_t;       /* TT - UT1 in seconds, finite; NaN (the default): oclshade_delta_t_estimate */
    int refraction;       /* 1 (default): the apparent elevation (SPA eq. 42, while the sun's upper limb
                             is up); 0: the geometric one */
} oclshade_sun_options;

/* Defaults: sea level, 1010 hPa, 10 C, Delta T estimated, refraction on. */
void oclshade_sun_options_init(oclshade_sun_options *options);

/* The sun at POSIX time `unix_seconds` (UTC, taken as UT1: at most 0.004 degree) seen from
 * `latitude` (degrees north, [-90, 90]) and `longitude` (degrees east, [-180, 180]): *azimuth
 * in degrees clockwise from north, [0, 360), *elevation in degrees above the horizon.
 * `options` NULL: the defaults.  A geographic grid's suns are true ones; a projected grid's
 * azimuths turn by the meridian convergence (the Python host's MapSite.grid_suns). */
oclshade_status oclshade_sun_position(double unix_seconds, double latitude, double longitude,
                                      const oclshade_sun_options *options, double *azimuth, double *elevation);

/* TT - UT1 in seconds for a decimal year: Espenak & Meeus (2006), the pieces from 1900 to 2150
 * and their long-term parabola outside (oclshade.solar.delta_t_estimate). */
double oclshade_delta_t_estimate(double year);

/* ----------------------------------------------------------- horizons and sky-view factor */

/* Sky-view factor definitions (kernels/horizon.cl -D OCLS_OUT_SVF). */
typedef enum oclshade_svf_definition {
    OCLSHADE_SVF_COSINE = 1,       /* term sin^2(max(h, 0)); svf = 1 - mean of the terms */
    OCLSHADE_SVF_SOLID_ANGLE = 2   /* term sin(max(h, 0)) (Zaksek / RVT) */
} oclshade_svf_definition;

/* One azimuth of horizon angles (kernels/horizon.cl; oclshade/horizon HorizonCaster): per cell
 * the elevation angle (degrees) of the highest point of the bilinear surface seen from the
 * cell's surface point towards `azimuth`, -90 where nothing is seen, NaN at nodata; and/or
 * its sky-view factor term added to a Kahan sum. */
typedef struct oclshade_horizon_params {
    oclshade_field heights;     /* rows x cols float32 relative heights (the pyramid's), NaN = nodata */
    int rows, cols;
    double dx, dy;
    cl_mem pyramid, offsets;    /* from oclshade_enqueue_extrema_pyramid for these heights */
    double azimuth;             /* degrees clockwise from north, finite */
    double curvature;           /* Earth curvature drop per square metre (1 - k) / (2 R), rounded to float32
                                   (the Python host's Curvature.coefficient); 0: a flat Earth (no
                                   -D OCLS_CURVATURE) */
    double max_distance;        /* search radius in metres, rounded to float32 (HorizonCaster's radius);
                                   0: the whole map (no -D OCLS_MAX_DISTANCE) */
    oclshade_field angle;       /* output: rows x cols float32 degrees; buffer NULL = not computed */
    cl_mem svf;                 /* rows x cols float2 (sum, compensation), read and written; NULL = none.
                                   Zero it before the first azimuth; after N equally spaced azimuths
                                   svf = 1 - (sum - compensation) / N, NaN at nodata (the Python host's) */
    oclshade_svf_definition svf_definition;
    cl_mem scratch;             /* >= oclshade_horizon_scratch_size (packed copies of pitched fields) */
    const double *azimuths;     /* n_azimuths > 0: these azimuths (finite degrees) in one call instead of
                                   `azimuth` (whole map only: max_distance 0); angle then holds
                                   n_azimuths bands of rows x cols, band k at rows k rows .. (k + 1) rows
                                   - 1 of the field (n_azimuths * rows rows), and svf adds all of them
                                   in order.  The same bits as one call per azimuth. */
    int n_azimuths;             /* 0 (default): the one `azimuth` */
    const double *row_scales;   /* NULL (default): every cell dx by dy metres.  Else rows x
                                   row_scale_columns doubles (row-major): row r's true metres east and
                                   north of one grid metre, positive and finite (a geographic raster's,
                                   or a projected one's 1 / k both ways: the Python host's
                                   MapPlaces.row_scales()), and with 4 columns a projected grid's
                                   stretch by direction (p, q): a grid metre along grid azimuth a is
                                   s sqrt(1 + p cos 2a + q sin 2a) true metres (p^2 + q^2 < 1; only
                                   where east = north = s; oclshade/solar/scale.py).  The rows are cut
                                   into bands as the Python host's scale_bands (0.01 degree; multiples
                                   of 16 rows where they hold it) and each band's cells are walked (or
                                   swept) with its own ray and cell sizes (dx, dy times the band's
                                   scale, the ray's times its stretch at the azimuth; the seeds keep
                                   the middle band's ray): true angles, the Python host's
                                   HorizonCaster(row_scales=...) bit for bit.  With row_scale_bands,
                                   per column band too. */
    int row_scale_columns;      /* 2 (default; 0 reads as 2): (east, north); 4: (east, north, p, q) */
    int row_scale_bands;        /* 0 (default): row_scales holds one scale per row.  m (1 to max(1,
                                   cols / 16)): rows x m x row_scale_columns doubles, row r's in each
                                   of m column bands (column band b: columns from (b cols + A m / 2)
                                   / (A m) * A, integer division, to the next band's, A the largest
                                   of 1024, 256, 64 and 16 with 2 A m <= cols, else 16; the Python
                                   host's MapPlaces.row_scales() of a projected grid: the middle of
                                   the row's scales over the band), traced in blocks of rows by
                                   column bands (scale_blocks; its bands of rows keep half of the
                                   tolerance's share, the rest the cells' spread about their row's
                                   band's), each block's cells launched with global offsets its
                                   first column and row */
    int clamped;                /* 0 (default); 1: -D OCLS_CLAMP, only angles whose tangent lies in
                                   clamp_bounds are wanted (a strip of the sun's disc:
                                   oclshade_sun_disc_strips): the walk starts at lo and stops once past
                                   hi, so the angle is exact where its tangent is in [lo, hi], atan(lo)
                                   below (and where nothing is seen) and some angle >= atan(hi) above.
                                   One azimuth's angle alone: svf NULL, n_azimuths 0, row_scales NULL;
                                   no seeds, never the sweep (HorizonCaster._strip_angles). */
    double clamp_bounds[2];     /* (lo, hi) tangents, finite, lo < hi (rounded to float32) */
} oclshade_horizon_params;

/* Defaults: no buffers, 0 x 0, dx = dy = 1, azimuth 0, flat Earth, no search radius, the cosine
 * definition, no row scales. */
void oclshade_horizon_params_init(oclshade_horizon_params *params);
oclshade_status oclshade_horizon_scratch_size(oclshade *lib, const oclshade_horizon_params *params,
                                              size_t *bytes);
/* Without a search radius two launches: horizon_seeds on the seed grid ((rows - 1) / 8 + 2 by
 * (cols - 1) / 8 + 2 cells, float2 each, in scratch: the scratch size is then never 0), then
 * horizon_cells (alone with a search radius), global size (cols,
 * rows) rounded up to the local size; -D OCLS_OUT_ANGLE when angle is given, OCLS_OUT_SVF=definition
 * when svf is, OCLS_CURVATURE when curvature > 0, OCLS_MAX_DISTANCE when max_distance > 0.  Within
 * a short search radius (the ray crosses at most the knob sweep_cells patch columns and rows within
 * it, rows and cols >= 2: HorizonCaster's sweeps()) one launch of horizon_sweep instead (the same
 * angles), -D OCLS_SWEEP=lanes, global size (ceil(cols / lanes), rows) rounded up (the pyramid is
 * then not read); past that reach too where the knob sweep_far is 2 (1, the Python host's pilot,
 * walks here: timing would wait for the queue).  With n_azimuths > 0 (kernels/horizon.cl,
 * "Batches"): per knob `batch` azimuths (the last launch fewer), horizon_seeds_batch (global
 * (seed cols, seed rows, count), scratch for count seed grids) then horizon_cells_batch (global
 * (cols, rows, count), or (cols, rows, 1) with svf: each cell walks the count azimuths in
 * order), the rays in scratch.  Knobs: horizon group, width (the work-group's width in cells),
 * own_builtins, lanes, sweep_cells, sweep_far, batch, scan (-D OCLS_LEVEL_SCAN: how the walk finds the
 * tile it may skip; the same bits).  With row_scales (and not one block of scale 1: blocks of a
 * band of rows by a column band) horizon_cells and horizon_cells_batch are built with -D
 * OCLS_SUN_TABLE and read each cell's block's ray(s) and cell sizes from a table in scratch (the
 * blocks' bands, rows + cols ints, and per block its ray then (-inf, inf, dx, dy), or per batch
 * its (dx, dy, 0, 0) then the batch's rays: uploaded by clEnqueueFillBuffer), one launch as
 * without them; horizon_sweep is launched once per block, global offsets its first column (in
 * lanes) and row, with the block's ray; the seeds keep the middle block's ray (the route, walk
 * or sweep, is the grid ray's, as the Python host's). */
oclshade_status oclshade_enqueue_horizon(oclshade *lib, cl_command_queue queue,
                                         const oclshade_horizon_params *params,
                                         cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                         cl_event *event);

/* Soft shadows (oclshade/horizon/disc.py; HorizonCaster.sun_disc): the share of the sun's disc
 * each cell sees, from its exact horizons at `columns` azimuths across the disc.  The disc of
 * angular radius r is cut into columns vertical strips of width w = 2 r / columns; strip k's
 * middle is x_k = -r + (k + 1/2) w across, at azimuth (azimuth + x_k / cos(elevation)) mod 360,
 * its half-chord c_k = sqrt(r^2 - x_k^2), and its horizons are needed only within the
 * tangents of [elevation - c_k - 0.001, elevation + c_k + 0.001] degrees (clamp_bounds).  The
 * share is sum_k clip(elevation + c_k - h_k, 0, 2 c_k) / sum_k 2 c_k, in double.
 * oclshade_sun_disc_strips fills those per strip (azimuths[columns], half_chords[columns],
 * bounds[columns][2]; any may be NULL): radius in (0, 5] degrees, columns 1..1024, |elevation|
 * < 90 - radius, azimuth finite.  Both the Python host's bits (disc_columns, strip_bounds). */
oclshade_status oclshade_sun_disc_strips(double azimuth, double elevation, double radius, int columns,
                                         double *azimuths, double *half_chords, double (*bounds)[2]);

/* The soft shadows of one sun on a grid as drawn (no row scales: a scaled grid's disc is its
 * blocks', which need horizon.cl's sun tables, which this host does not build yet). */
typedef struct oclshade_sun_disc_params {
    oclshade_field heights;     /* rows x cols float32 relative heights (the pyramid's), NaN = nodata */
    int rows, cols;
    double dx, dy;
    cl_mem pyramid, offsets;    /* from oclshade_enqueue_extrema_pyramid for these heights */
    double azimuth, elevation;  /* the sun's centre, degrees */
    double radius;              /* the disc's angular radius, degrees; 0: 0.2666 (the mean sun's) */
    int columns;                /* strips across the disc; 0: 16 (the Python host's DEFAULT_COLUMNS) */
    double curvature, max_distance;   /* as oclshade_horizon_params' */
    oclshade_field angle;       /* rows x cols float32: each strip's clamped angles go through it (written) */
    cl_mem scratch;             /* >= oclshade_sun_disc_scratch_size (the clamped horizon pass's) */
    double *work;               /* host memory, rows x cols doubles: the strips' running sums (written) */
} oclshade_sun_disc_params;

void oclshade_sun_disc_params_init(oclshade_sun_disc_params *params);
oclshade_status oclshade_sun_disc_scratch_size(oclshade *lib, const oclshade_sun_disc_params *params,
                                               size_t *bytes);
/* Blocking, the one such entry point: per strip a clamped oclshade_enqueue_horizon into `angle`,
 * read back into `fraction` and summed into `work` in double, as the Python host sums; then
 * `fraction` (host memory, rows x cols float32) holds the visible share, in [0, 1], NaN at
 * nodata: HorizonCaster(...).sun_disc(Sun(azimuth, elevation), radius, columns) bit for bit.
 * Nothing is allocated; the queue is finished by each strip's read. */
oclshade_status oclshade_sun_disc(oclshade *lib, cl_command_queue queue, const oclshade_sun_disc_params *params,
                                  float *fraction);

/* ----------------------------------------------------------- environment maps */

/* A cube map on the device in the bordered layout of kernels/cubemap.h: 6 faces of (N + 2) x
 * (N + 2) float4 texels (rgb, a unused) back to back, face f at f (N + 2)^2, texel (i, j),
 * i, j in -1..N, at (i + 1)(N + 2) + j + 1; rows and columns -1 and N are the one-texel
 * border copied across the seams.  Lat-long maps: height x width float4 texels, longitude
 * across, latitude down (kernels/envmap.cl).  oclshade/envmap/cube.py. */
typedef struct oclshade_envmap_params {
    cl_mem cube;                /* >= 96 (face + 2)^2 bytes */
    int face;                   /* N, 1..8192 */
    oclshade_field latlong;     /* height x width float4: read by latlong_to_cube, written by cube_to_latlong */
    int height, width;          /* 1..32768 each (width >= 2 to read one) */
    oclshade_field frame;       /* face x face float4: a face camera's linear frame (cube_face_store) */
    int face_index;             /* 0..5: the face cube_face_store writes (+X, -X, +Y, -Y, +Z, -Z) */
    cl_mem scratch;             /* >= oclshade_envmap_scratch_size (a packed copy of a pitched latlong
                                   or frame) */
} oclshade_envmap_params;

void oclshade_envmap_params_init(oclshade_envmap_params *params);
/* Scratch bytes of oclshade_enqueue_latlong_to_cube and oclshade_enqueue_cube_to_latlong
 * (0 for a lat-long field packed at offset 0, or none); with latlong unset and frame set, of
 * oclshade_enqueue_cube_face_store (0 for a frame packed at offset 0). */
oclshade_status oclshade_envmap_scratch_size(oclshade *lib, const oclshade_envmap_params *params, size_t *bytes);
/* cube_border over (N + 2, 4, 6) work-items: the border of a cube whose face interiors are
 * filled (DeviceCubeMap.fill_border).  cube is read and written. */
oclshade_status oclshade_enqueue_cube_border(oclshade *lib, cl_command_queue queue,
                                             const oclshade_envmap_params *params,
                                             cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                             cl_event *event);
/* latlong_to_cube (each face texel the lat-long map's bilinear sample in its centre's
 * direction; global size (N, N) rounded up to the local size, x 6 faces), then cube_border:
 * oclshade.envmap.latlong_to_cube on an RGBA map (the Python host's a = 0). */
oclshade_status oclshade_enqueue_latlong_to_cube(oclshade *lib, cl_command_queue queue,
                                                 const oclshade_envmap_params *params,
                                                 cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                 cl_event *event);
/* cube_face_store over (N, N): the interior of face face_index gets the frame mirrored
 * left-right (texel (r, c) = frame pixel (r, N - 1 - c)): one face of a generated cube map
 * (oclshade.scene.generate; the frame from oclshade_enqueue_compose with linear = 1 of the
 * face camera, oclshade.scene.generate.face_cameras).  Run oclshade_enqueue_cube_border after
 * the six faces.  cube is written (the face's interior only). */
oclshade_status oclshade_enqueue_cube_face_store(oclshade *lib, cl_command_queue queue,
                                                 const oclshade_envmap_params *params,
                                                 cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                 cl_event *event);
/* cube_to_latlong over (width, height): each texel the bordered cube's seam-continuous
 * bilinear sample in its centre's direction (DeviceCubeMap.to_latlong, before the host drops
 * the a channel). */
oclshade_status oclshade_enqueue_cube_to_latlong(oclshade *lib, cl_command_queue queue,
                                                 const oclshade_envmap_params *params,
                                                 cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                 cl_event *event);

/* ----------------------------------------------------------- quadrics (kernels/quadric.cl) */

/* Paper 004's objects on the terrain: quadrics ray-cast in closed form into a G-buffer,
 * depth-merged with the terrain's, their normals put into the shading normals, their shadows
 * (oclshade/quadrics/caster.py QuadricCaster; docs/reflections.md). */
typedef enum oclshade_quadric_kind {
    OCLSHADE_SPHERE = 0,        /* radii (r, r, r) */
    OCLSHADE_ELLIPSOID = 1,     /* radii (a, b, c) along the local x, y, z axes */
    OCLSHADE_CYLINDER = 2,      /* radii (r, r, height / 2); centre: the middle of its axis; closed by flat caps */
    OCLSHADE_PARABOLOID = 3     /* radii (r, r, height); centre: the vertex of the open bowl */
} oclshade_quadric_kind;

/* One quadric in the world (x east, y north, z up; metres): oclshade.quadrics.Quadric. */
typedef struct oclshade_quadric {
    oclshade_quadric_kind kind;
    double centre[3];
    double radii[3];            /* positive; a sphere's three equal */
    double axis[3];             /* local z, non-zero (local x: east made perpendicular to it) */
    double colour[3];           /* linear albedo (the material colour), written to the G-buffer */
} oclshade_quadric;

#define OCLSHADE_MAX_QUADRICS 4096

/* The per-camera tables of kernels/quadric.cl (QuadricCaster.tables), host only, reentrant:
 * qf 5 float4 per quadric (rows of M = S^-1 R^T in view space with -(M c), albedo, the
 * view-space bounding sphere), qi 2 int4 (kind code, screen rectangle).  You upload them
 * (count * 80 and count * 32 bytes) for the cast and shadow calls of this camera.  Computed
 * in float64 as the Python host does (see README "Exactness"). */
oclshade_status oclshade_quadric_tables(const oclshade_quadric *quadrics, int count, const oclshade_camera *camera,
                                        cl_float4 *qf, cl_int4 *qi);

/* A G-buffer with object ids (width x height each; layouts of oclshade/gbuffer.py). */
typedef struct oclshade_object_gbuffer {
    oclshade_field position, normal;   /* float4 */
    oclshade_field uv;                 /* float2 */
    oclshade_field uv_grad;            /* float4 */
    oclshade_field depth;              /* float */
    oclshade_field albedo;             /* float4 */
    oclshade_field object;             /* int32: quadric index + 1, 0 none (a terrain G-buffer: all 0) */
} oclshade_object_gbuffer;

/* One params struct for the six quadric calls; each reads the members its comment names
 * ("point shadows": the terrain's and the quadrics' shadows of a point light). */
typedef struct oclshade_quadric_params {
    oclshade_camera camera;            /* all: the frame (width x height); cast, shadow, point shadows: the view */
    int count;                         /* cast, shadow, quadric point shadow: quadrics, 1..OCLSHADE_MAX_QUADRICS */
    cl_mem qf, qi;                     /* cast, shadow, quadric point shadow: oclshade_quadric_tables for this
                                          camera, uploaded */
    /* the terrain (cast: the uv of hits; shadow: the sun rays of object pixels; terrain point
     * shadow: the segments to the light); heights.buffer NULL: no terrain (uv 0, no terrain
     * test: the terrain point shadow sets every pixel to 1) */
    oclshade_field heights;            /* rows x cols relative float32 heights, NaN = hole */
    int rows, cols;
    double dx, dy, offset;             /* cell sizes; offset of oclshade_relative_heights */
    float hmax;                        /* shadow, terrain point shadow: oclshade_height_range's hi (0 when no
                                          height is finite) */
    oclshade_object_gbuffer objects;   /* cast: written; merge: read (the source) */
    oclshade_object_gbuffer gbuffer;   /* merge: read and written (nearest wins; a tie keeps it);
                                          normals: normal, object read; shadow, point shadows: position,
                                          object read */
    oclshade_field shading;            /* normals: float4 shading normals, read and written */
    double azimuth, elevation;         /* shadow: the sun (degrees) */
    double k_dark, k_bright;           /* shadow: paper 000 eq. (1) for shadowed pixels, in [0, 1];
                                          point shadows: k_dark, a shadowed pixel's coefficient */
    oclshade_field coefficient;        /* shadow: float per pixel, the terrain shadow pass's, read and written;
                                          terrain point shadow: written (every pixel); quadric point
                                          shadow: read and written */
    double light_position[3];          /* point shadows: the point light's world position (metres), finite */
    cl_mem scratch;                    /* >= oclshade_quadric_scratch_size (packed copies of pitched fields) */
} oclshade_quadric_params;

/* Zeroes (no terrain, sun (0, 0), k_dark = k_bright = 0, light at the origin). */
void oclshade_quadric_params_init(oclshade_quadric_params *params);
/* Scratch of the largest of the six calls for these parameters (0 when every field is packed
 * at offset 0). */
oclshade_status oclshade_quadric_scratch_size(oclshade *lib, const oclshade_quadric_params *params, size_t *bytes);
/* quadric_cast over (width, height) (-D OCLS_ORTHO for an orthographic camera): the objects'
 * own G-buffer and ids (QuadricCaster.cast). */
oclshade_status oclshade_enqueue_quadric_cast(oclshade *lib, cl_command_queue queue,
                                              const oclshade_quadric_params *params,
                                              cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                              cl_event *event);
/* gbuffer_merge: objects over gbuffer where nearer (QuadricCaster.merge with given ids). */
oclshade_status oclshade_enqueue_gbuffer_merge(oclshade *lib, cl_command_queue queue,
                                               const oclshade_quadric_params *params,
                                               cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                               cl_event *event);
/* object_normals: shading = gbuffer.normal on object pixels (QuadricCaster.object_normals). */
oclshade_status oclshade_enqueue_object_normals(oclshade *lib, cl_command_queue queue,
                                                const oclshade_quadric_params *params,
                                                cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                cl_event *event);
/* quadric_shadow after the terrain's per-pixel shadow pass (QuadricCaster.shadow): terrain
 * pixels whose sun ray meets a quadric and object pixels in shadow get eq. (1), lit object
 * pixels 1. */
oclshade_status oclshade_enqueue_quadric_shadow(oclshade *lib, cl_command_queue queue,
                                                const oclshade_quadric_params *params,
                                                cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                cl_event *event);
/* A point light (docs/meshes.md "Point lights"), first of the two passes: terrain_point_shadow
 * (oclshade.quadrics.caster.terrain_point_shadow) on every pixel of a merged G-buffer (terrain,
 * quadric and mesh pixels): coefficient = k_dark where the terrain rises above the segment
 * from the pixel's surface point to light_position (exact, every patch under it; a terrain
 * pixel, object 0, starts on the surface), else 1 (empty pixels too; no terrain: every pixel
 * 1).  Replaces the sun's per-pixel and quadric shadow calls for a point light. */
oclshade_status oclshade_enqueue_terrain_point_shadow(oclshade *lib, cl_command_queue queue,
                                                      const oclshade_quadric_params *params,
                                                      cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                      cl_event *event);
/* Second pass: quadric_point_shadow (QuadricCaster.point_shadow): every hit pixel whose segment
 * to light_position meets a quadric (its own closed shape excluded) gets k_dark; the others
 * keep their coefficient.  The meshes' shadows of a point light: oclshade_mesh_light_table
 * with point 1 and the mesh shadow rays (apply at elevation 0), or the shadow volumes. */
oclshade_status oclshade_enqueue_quadric_point_shadow(oclshade *lib, cl_command_queue queue,
                                                      const oclshade_quadric_params *params,
                                                      cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                      cl_event *event);

/* ----------------------------------------------------------- reflections (kernels/reflect.cl) */

/* Paper 002's static optimiser: source written in the @IF meta-language resolved for a
 * condition vector ("REFLECT FRESNEL", names separated by blanks), oclshade.specialize.specialize.
 * out (size bytes, may be NULL with 0) gets the text NUL-terminated; *needed the bytes of the
 * whole text with its NUL (call once with size 0 to size out).  OCLSHADE_SOURCE_ERROR with the
 * Python host's message ("line N: ...") in error (error_size bytes, may be NULL) on malformed
 * source or conditions.  Host only, reentrant. */
oclshade_status oclshade_specialize(const char *source, const char *conditions, char *out, size_t size,
                                    size_t *needed, char *error, size_t error_size);

typedef enum oclshade_material_kind {
    OCLSHADE_DIFFUSE = 0,       /* colour x diffuse light; no reflection */
    OCLSHADE_MIRROR = 1,        /* colour x E (REFLECT) */
    OCLSHADE_GLOSSY = 2         /* (1 - F) colour x diffuse + F E, Schlick F (REFLECT FRESNEL) */
} oclshade_material_kind;

/* oclshade.envmap.materials.Material, with the index of the cube map its object reflects. */
typedef struct oclshade_material {
    oclshade_material_kind kind;
    double colour[3];           /* linear RGB in [0, 1] (the Python defaults are per kind: set it) */
    double roughness;           /* [0, 1] (mirror, glossy): > 0 adds ROUGH, a cone of roughness x 45 degrees */
    double fresnel;             /* F0 in [0, 1] (glossy) */
    int cube;                   /* index of its map in the stacked cube buffer (0: the scene's) */
} oclshade_material;

#define OCLSHADE_MAX_GROUPS 8
/* The material groups of a scene: one program per distinct condition vector (Reflections). */
typedef struct oclshade_reflect_groups {
    int count;                                  /* distinct vectors of the reflective materials */
    char vector[OCLSHADE_MAX_GROUPS][32];       /* sorted names ("FRESNEL REFLECT"), groups in the Python order */
} oclshade_reflect_groups;

/* The material table of reflect.cl (3 float4 per object; you upload count * 48 bytes) and the
 * groups, as oclshade.envmap.reflect.Reflections builds them; host only, reentrant.  A table
 * row's group indexes groups->vector (-1: diffuse). */
oclshade_status oclshade_reflect_tables(const oclshade_material *materials, int count, oclshade_reflect_groups *groups,
                                        cl_float4 *table);

typedef struct oclshade_reflect_params {
    /* the G-buffer samples, (height * ssaa) x (width * ssaa) each */
    oclshade_field position, normal, albedo;   /* float4 (the merged G-buffer) */
    oclshade_field object;                     /* int32 object ids */
    int width, height, ssaa;                   /* the frame, samples per pixel along each axis (1..8) */
    oclshade_camera camera;                    /* the samples' camera ((height ssaa) x (width ssaa) pixels) */
    int objects;                               /* rows of the material table, >= 1 */
    cl_mem materials;                          /* oclshade_reflect_tables' table, uploaded */
    oclshade_reflect_groups groups;            /* oclshade_reflect_tables' groups (count 0: no reflective object) */
    cl_mem cube;                               /* bordered cube maps (cubemap.h) back to back */
    int face, cubes;                           /* their face size and number (>= 1) */
    double rotation;                           /* the environment's, degrees (oclshade.envmap.cube_frame) */
    double intensity;                          /* scale of the map's values, >= 0 */
    int background;                            /* empty samples show map 0 (the BACKGROUND program) */
    oclshade_field weighted;                   /* weights: float4 samples, written: the albedo compose reads */
    cl_mem acc;                                /* apply: width x height float4, written; finish: read */
    oclshade_field frame;                      /* finish: compose's width x height uchar4 sRGB, read */
    oclshade_field image;                      /* finish: width x height uchar4, written */
    cl_mem scratch;                            /* >= oclshade_reflect_scratch_size */
} oclshade_reflect_params;

/* Zeroes, then Reflections' defaults: ssaa 1, intensity 1, background on. */
void oclshade_reflect_params_init(oclshade_reflect_params *params);
oclshade_status oclshade_reflect_scratch_size(oclshade *lib, const oclshade_reflect_params *params, size_t *bytes);
/* Reflections.weights: weighted = albedo, then reflect_weights of each group's specialised
 * program (0 on mirror samples, (1 - F) albedo on glossy ones). */
oclshade_status oclshade_enqueue_reflect_weights(oclshade *lib, cl_command_queue queue,
                                                 const oclshade_reflect_params *params,
                                                 cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                 cl_event *event);
/* Reflections.accumulate: acc = 0, then reflect_apply of each group's program and, with
 * background, of the BACKGROUND program: the reflections per pixel in linear light. */
oclshade_status oclshade_enqueue_reflect_apply(oclshade *lib, cl_command_queue queue,
                                               const oclshade_reflect_params *params,
                                               cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                               cl_event *event);
/* reflect_finish: image = compose's frame + acc in linear light, 8-bit sRGB (Reflections.apply). */
oclshade_status oclshade_enqueue_reflect_finish(oclshade *lib, cl_command_queue queue,
                                                const oclshade_reflect_params *params,
                                                cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                cl_event *event);

/* ----------------------------------------------------------- meshes (kernels/mesh.cl) */

/* Paper 001's mesh G-buffers: triangle meshes ray-cast through a BVH into a G-buffer, their
 * pixels shaded against the terrain, any-hit shadow rays (oclshade/meshes/caster.py
 * MeshCaster; docs/meshes.md).  The depth merge and object normals are the quadric calls
 * above (oclshade_enqueue_gbuffer_merge, oclshade_enqueue_object_normals: the same kernels
 * for every kind of object; mesh k's pixels have id -(k + 1)).  The BVH and the flattened
 * tables are built by the Python host (oclshade.meshes.tables.write_mesh_tables) and read
 * here from its file (host/README.md "Meshes"). */
#define OCLSHADE_MAX_MESHES 65536

/* The tables of one set of meshes, host arrays (layouts of kernels/mesh.cl's ABI). */
typedef struct oclshade_mesh_tables {
    int meshes, nodes, slots, vertices, texels;
    cl_int4 *mi;              /* 3 per mesh: (root, flags, 0, 0), texture, normal map */
    double *origin;           /* 3 per mesh: world origin (float64) the mesh's tables are relative to */
    double *reach;            /* 1 per mesh: largest distance of a vertex from its origin */
    cl_float4 *surface;       /* 1 per mesh: colour (linear rgb), alpha cutoff */
    cl_float4 *box;           /* 2 per node */
    cl_int2 *info;            /* 1 per node */
    cl_float4 *tri;           /* 3 per slot */
    cl_int4 *tvtx;            /* 1 per slot */
    cl_float4 *tangent;       /* 1 per slot */
    cl_float4 *vnrm;          /* 1 per vertex */
    cl_float2 *vuv;           /* 1 per vertex */
    cl_float4 *texel;         /* texels (>= 1) */
} oclshade_mesh_tables;

/* Read a tables file (format: oclshade/meshes/tables.py; host/README.md) into *out (arrays
 * malloc'd; free with oclshade_mesh_tables_free).  OCLSHADE_INVALID_ARGUMENT with the reason
 * in error (error_size bytes, may be NULL): an unreadable or short file, a wrong magic, counts
 * out of range, indices outside the tables; OCLSHADE_OUT_OF_MEMORY.
 * Host only, reentrant. */
oclshade_status oclshade_mesh_tables_read(const char *path, oclshade_mesh_tables *out, char *error, size_t error_size);
/* Frees the arrays of tables read by oclshade_mesh_tables_read and zeroes *tables (NULL: nothing). */
void oclshade_mesh_tables_free(oclshade_mesh_tables *tables);

/* The per-camera table mf of kernels/mesh.cl (MeshCaster.table): 3 float4 per mesh (camera
 * position - origin rounded once from float64; colour and cutoff; the screen rectangle of
 * the mesh's bounding sphere).  position: the camera's world position (the one given to
 * oclshade_camera_look_at; it must agree with camera->view within 1e-6 of its size + 1 m).
 * You upload meshes * 48 bytes.  Host only, reentrant. */
oclshade_status oclshade_mesh_camera_table(const oclshade_mesh_tables *tables, const oclshade_camera *camera,
                                           const double position[3], cl_float4 *mf);

/* A light for the shadow rays: the sun (point 0: azimuth, elevation in degrees) or a point
 * light (point 1: world position, metres). */
typedef struct oclshade_mesh_light {
    int point;
    double azimuth, elevation;
    double position[3];
} oclshade_mesh_light;

/* The light table of mesh_shadow_rays (MeshCaster.light_table): 1 float4 per mesh, (sun
 * vector, 0) or (position - origin rounded once, 1).  You upload meshes * 16 bytes.  Host
 * only, reentrant. */
oclshade_status oclshade_mesh_light_table(const oclshade_mesh_tables *tables, const oclshade_mesh_light *light,
                                          cl_float4 *table);

/* One params struct for the mesh calls; each reads the members its comment names. */
typedef struct oclshade_mesh_params {
    oclshade_camera camera;            /* all: the frame (width x height); cast, rays: the view */
    int count;                         /* cast, rays: meshes, 1..OCLSHADE_MAX_MESHES */
    int nodes, slots, vertices, texels;/* cast, rays: the tables' sizes (oclshade_mesh_tables) */
    cl_mem mf;                         /* cast, rays: oclshade_mesh_camera_table for this camera, uploaded */
    cl_mem mi;                         /* cast, rays: the tables' mi, uploaded (count * 48 bytes) */
    cl_mem box, info, tri, tvtx;       /* cast, rays: the tables' arrays, uploaded */
    cl_mem tangent, vnrm;              /* cast: the tables' arrays, uploaded */
    cl_mem vuv, texel;                 /* cast, rays: the tables' arrays, uploaded */
    int own_builtins;                  /* cast, rays, terrain shadow: -D OCLS_OWN_BUILTINS (the same
                                          bits; the Python host's default: on) */
    oclshade_object_gbuffer objects;   /* cast: written */
    oclshade_object_gbuffer gbuffer;   /* terrain shadow: position, object read; rays: position read */
    /* terrain shadow: the terrain (heights.buffer NULL: none, every mesh pixel lit unless the
     * sun is at or below the horizon) and the sun, as oclshade_quadric_params */
    oclshade_field heights;
    int rows, cols;
    double dx, dy, offset;
    float hmax;
    double azimuth, elevation;         /* terrain shadow, apply: the sun (degrees) */
    double k_dark, k_bright;           /* terrain shadow, apply: paper 000 eq. (1), in [0, 1] */
    oclshade_field coefficient;        /* terrain shadow, apply: float per pixel, read and written */
    cl_mem light;                      /* rays: oclshade_mesh_light_table, uploaded (count * 16 bytes) */
    oclshade_field hidden;             /* rays: int32 per pixel, written; apply: read */
    cl_mem scratch;                    /* >= oclshade_mesh_scratch_size (packed copies of pitched fields) */
} oclshade_mesh_params;

/* Zeroes, then own_builtins 1 (MeshCaster's default). */
void oclshade_mesh_params_init(oclshade_mesh_params *params);
/* Scratch of the largest of the four calls for these parameters (0 when every field is packed
 * at offset 0). */
oclshade_status oclshade_mesh_scratch_size(oclshade *lib, const oclshade_mesh_params *params, size_t *bytes);
/* mesh_cast over (width, height) (-D OCLS_ORTHO for an orthographic camera): the meshes' own
 * G-buffer and ids -(k + 1) (MeshCaster.cast). */
oclshade_status oclshade_enqueue_mesh_cast(oclshade *lib, cl_command_queue queue, const oclshade_mesh_params *params,
                                           cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                           cl_event *event);
/* mesh_terrain_shadow (MeshCaster.shadow): every mesh pixel (id < 0) of gbuffer gets eq. (1)
 * when the terrain hides the sun from it, else 1; other pixels keep their coefficient. */
oclshade_status oclshade_enqueue_mesh_terrain_shadow(oclshade *lib, cl_command_queue queue,
                                                     const oclshade_mesh_params *params,
                                                     cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                     cl_event *event);
/* mesh_shadow_rays (MeshCaster.shadow_rays): hidden = 1 where a hit pixel's ray toward the
 * light meets a triangle of a mesh that casts shadows (alpha cut-outs honoured), else 0. */
oclshade_status oclshade_enqueue_mesh_shadow_rays(oclshade *lib, cl_command_queue queue,
                                                  const oclshade_mesh_params *params,
                                                  cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                  cl_event *event);
/* mesh_shadow_apply (the second half of MeshCaster.ray_shadow): coefficient = eq. (1) of the
 * sun (azimuth, elevation, k_dark, k_bright) where hidden, else unchanged. */
oclshade_status oclshade_enqueue_mesh_shadow_apply(oclshade *lib, cl_command_queue queue,
                                                   const oclshade_mesh_params *params,
                                                   cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                   cl_event *event);

/* ------------------------------------------------ shadow volumes (kernels/shadow_volume.cl) */

/* Paper 003's mesh shadows by shadow volumes, counted per pixel (oclshade/meshes/
 * shadow_volumes.py MeshShadows; docs/shadow_volumes.md).  The volumes, the silhouette and the
 * eye's start count are host work in float64 that stays in Python: MeshShadows.frame_tables +
 * write_frame_tables write one frame's tables, oclshade_shadow_volume_frame_read reads them.
 * Per frame: bin (count faces per tile), read the counts back, oclshade_shadow_volume_offsets,
 * upload the offsets, mask (fill the tile lists, count), apply (host/README.md). */

/* One frame's tables (layouts of kernels/shadow_volume.cl's ABI), host arrays. */
typedef struct oclshade_shadow_volume_frame {
    int vertices, faces;      /* rows of verts and tris (>= 1; faces 1 with ntri 0: no volume) */
    int ntri;                 /* volume faces to count (0 or faces) */
    int start_count;          /* the eye's winding number (pinhole cameras) */
    float start_height;       /* zs: the orthographic start height */
    float max_depth;          /* the largest depth of a hit pixel of the frame they were made for */
    cl_float4 *verts;         /* view-space vertex positions (xyz, w 0) */
    cl_int4 *tris;            /* (a, b, c, kind): vertex indices, kind 0 side, 1 cap */
} oclshade_shadow_volume_frame;

/* Read a frame tables file (oclshade.meshes.shadow_volumes.write_frame_tables; host/README.md)
 * into *out (arrays malloc'd; free with oclshade_shadow_volume_frame_free).  INVALID_ARGUMENT
 * with the reason in error (at most error_size bytes) for a missing, short, long or damaged
 * file (an index outside the vertices, a kind other than 0 or 1); *out is then cleared.  Host
 * only, reentrant. */
oclshade_status oclshade_shadow_volume_frame_read(const char *path, oclshade_shadow_volume_frame *out, char *error,
                                                  size_t error_size);
/* Frees the arrays of oclshade_shadow_volume_frame_read and zeroes *frame (NULL: nothing). */
void oclshade_shadow_volume_frame_free(oclshade_shadow_volume_frame *frame);
/* The exclusive prefix sums of tiles counts (sv_bin's first pass) into offsets (tiles + 1
 * entries; offsets[tiles] the list's length).  INVALID_ARGUMENT for a NULL array, tiles < 1,
 * a negative count or a total over INT_MAX.  Host only, reentrant. */
oclshade_status oclshade_shadow_volume_offsets(const cl_int *counts, int tiles, cl_int *offsets);

/* One params struct for the shadow volume calls; each reads the members its comment names. */
typedef struct oclshade_shadow_volume_params {
    oclshade_camera camera;            /* all: the frame (width x height); bin, mask: projection, sx, sy, near */
    int ntri, vertices;                /* bin, mask: volume faces (>= 0) and vertex rows (>= 1) */
    cl_mem verts;                      /* bin, mask: the frame's verts, uploaded (vertices * 16 bytes) */
    cl_mem tris;                       /* bin, mask: the frame's tris, uploaded (max(ntri, 1) * 16 bytes) */
    double max_depth;                  /* bin: faces deeper than every hit pixel are dropped (>= 0) */
    int tile;                          /* bin, mask: tile side T in pixels (MeshShadows: 16, doubled while
                                          the lists exceed 2^25 entries) */
    cl_mem counts;                     /* bin: written; mask: scratch (TW * TH ints, TW = ceil(width / T)) */
    cl_mem offsets;                    /* mask: oclshade_shadow_volume_offsets of bin's counts, uploaded */
    int entries;                       /* mask: the lists' length, offsets[TW * TH] */
    cl_mem list;                       /* mask: written (max(entries, 1) ints) */
    cl_mem planes;                     /* mask, pinhole: written (max(ntri, 1) * 64 bytes) */
    int start_count;                   /* mask: the frame's start_count (pinhole) */
    float start_height;                /* mask: the frame's start_height (orthographic) */
    oclshade_field position;           /* mask: the G-buffer's view-space float4 (w = 1 hit), read */
    oclshade_field mask;               /* mask: uchar per pixel, 1 the light hidden, written; apply: read */
    double elevation;                  /* apply: the sun's elevation (degrees; a point light: 0) */
    double k_dark, k_bright;           /* apply: paper 000 eq. (1), in [0, 1] */
    oclshade_field coefficient;        /* apply: float per pixel, read and written */
    cl_mem scratch;                    /* >= oclshade_shadow_volume_scratch_size (pitched fields) */
} oclshade_shadow_volume_params;

/* Zeroes, then tile 16 (MeshShadows' TILE). */
void oclshade_shadow_volume_params_init(oclshade_shadow_volume_params *params);
/* Scratch of the largest of the three calls (0 when every field is packed at offset 0). */
oclshade_status oclshade_shadow_volume_scratch_size(oclshade *lib, const oclshade_shadow_volume_params *params,
                                                    size_t *bytes);
/* Zero counts, sv_bin's first pass (fill 0): counts[t] = the faces binned to tile t. */
oclshade_status oclshade_enqueue_shadow_volume_bin(oclshade *lib, cl_command_queue queue,
                                                   const oclshade_shadow_volume_params *params,
                                                   cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                   cl_event *event);
/* Zero counts, sv_bin's second pass (fill 1: the tile lists), sv_prepare (pinhole), sv_count:
 * mask = 1 where a hit pixel's count is not 0 (MeshShadows.mask). */
oclshade_status oclshade_enqueue_shadow_volume_mask(oclshade *lib, cl_command_queue queue,
                                                    const oclshade_shadow_volume_params *params,
                                                    cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                    cl_event *event);
/* sv_apply (MeshShadows.shadow): coefficient = eq. (1) of (elevation, k_dark, k_bright) where
 * mask, else unchanged. */
oclshade_status oclshade_enqueue_shadow_volume_apply(oclshade *lib, cl_command_queue queue,
                                                     const oclshade_shadow_volume_params *params,
                                                     cl_uint num_events_in_wait_list, const cl_event *event_wait_list,
                                                     cl_event *event);

#ifdef __cplusplus
}
#endif

#endif /* OCLSHADE_H */
