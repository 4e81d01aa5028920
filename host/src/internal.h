/* internal.h — what the per-family sources of the C host API share (not installed).
 *
 * core.c        handle, per-thread errors, build options, program cache
 * sources.c     kernel sources (directory, strings, built-in copy), include expansion
 * knobs.c       tuning knobs of every family and the rule for a new handle
 * pass.c        argument and contract checks; passes (plan / run, scratch regions, field
 *               staging, event chains, launches)
 * heightmap.c   relative heights, extrema pyramid, mean mip pyramid, coarse grids
 * shadows.c     sun parameters, heightmap-space shadows
 * camera.c      camera maths (host only)
 * terrain.c     dilated levels, terrain G-buffer
 * pixels.c      per-pixel shadows
 * ssao.c        SSAO sample tables and passes
 * compose.c     the final frame
 * sunshine.c    sums over many suns; zeroing of accumulators
 * horizon.c     horizon angles and sky-view factor sums
 * envmap.c      cube maps: seam border, lat-long <-> cube
 * specialize.c  paper 002's @IF meta-language (reflect.cl's variants)
 * quadrics.c    quadrics: tables, G-buffer, depth merge, object normals, shadows; the sun and
 *               terrain arguments every object family's terrain shadows take
 * meshes.c      meshes: tables file, per-camera and light tables, G-buffer, shadows
 * shadow_volumes.c  mesh shadows by shadow volumes: frame tables file, tile offsets, passes
 * reflect.c     environment reflections around compose (specialised reflect.cl)
 */
#ifndef OCLSHADE_INTERNAL_H
#define OCLSHADE_INTERNAL_H

#include "oclshade.h"

#include <stdarg.h>
#include <stddef.h>

#if defined(_WIN32)
#include <windows.h>
typedef CRITICAL_SECTION ocls_mutex;
typedef DWORD ocls_thread;
#else
#include <pthread.h>
typedef pthread_mutex_t ocls_mutex;
typedef pthread_t ocls_thread;
#endif

void ocls_mutex_init(ocls_mutex *m);
void ocls_mutex_free(ocls_mutex *m);
void ocls_mutex_lock(ocls_mutex *m);
void ocls_mutex_unlock(ocls_mutex *m);

#define OCLS_STR2(x) #x
#define OCLS_STR(x) OCLS_STR2(x)
#define CL_STD_OPTION "-cl-std=CL1.2"
/* appended at the build on devices that support it (core.c build; Python: runtime.rounding_options) */
#define OCLS_ROUNDING_OPTION "-cl-fp32-correctly-rounded-divide-sqrt"
#define N_ITEMS(a) (sizeof(a) / sizeof((a)[0]))

/* ------------------------------------------------------------------ knobs */

/* The families of the Python host's tuning database (oclshade/tuning) and the knobs the C host
 * has (oclshade_set_knob); indices into oclshade.knobs. */
enum {
    K_PYRAMID_BASE_LANES, K_PYRAMID_OWN_BUILTINS,
    K_SHADOW_LANES, K_SHADOW_OWN_BUILTINS, K_SHADOW_GATHER, K_SHADOW_CERT_TILE, K_SHADOW_RUN, K_SHADOW_GROUP,
    K_TERRAIN_DESCEND, K_TERRAIN_LEAF, K_TERRAIN_GROUP, K_TERRAIN_OWN_BUILTINS,
    K_PIXELS_GROUP, K_PIXELS_OWN_BUILTINS,
    K_SSAO_LANES, K_SSAO_GROUP, K_SSAO_OWN_BUILTINS,
    K_HORIZON_GROUP, K_HORIZON_OWN_BUILTINS, K_HORIZON_LANES, K_HORIZON_SWEEP_CELLS, K_HORIZON_SWEEP_FAR,
    K_HORIZON_WIDTH, K_HORIZON_BATCH, K_HORIZON_SCAN,
    N_KNOBS
};

/* ------------------------------------------------------------------ handle */

typedef struct err_slot {
    ocls_thread thread;
    char *message;
    size_t cap;
    cl_int cl_error;
    struct err_slot *next;
} err_slot;

typedef struct kernel_entry {
    char *name;
    cl_kernel kernel;
    size_t max_group;            /* CL_KERNEL_WORK_GROUP_SIZE */
    struct kernel_entry *next;
} kernel_entry;

typedef struct program_entry {
    const char *file;            /* one of PROGRAM_FILES (static) */
    char *options;
    char *variant;               /* the condition vector its source was specialised for (NULL: none) */
    cl_program program;
    kernel_entry *kernels;
    struct program_entry *next;
} program_entry;

#define N_PROGRAM_FILES 12
extern const char *const OCLS_PROGRAM_FILES[N_PROGRAM_FILES];   /* pyramid, shadow, terrain, ssao, compose,
                                                                   sunshine, horizon, envmap, quadric, reflect,
                                                                   mesh, shadow_volume */

struct oclshade {
    cl_context context;
    cl_device_id device;
    int ready;                       /* creation is over (before: failures are the creation message) */
    oclshade_status failed;          /* != OK: creation failed, the handle only reports it */
    char *creation_message;          /* the failure of a failed handle (written before it is shared) */
    char *sources[N_PROGRAM_FILES];  /* expanded program sources, OCLS_PROGRAM_FILES order */
    size_t dev_max_wg, dev_max_item0;
    size_t align;                    /* CL_DEVICE_MEM_BASE_ADDR_ALIGN in bytes: scratch regions start there */
    ocls_mutex lock;                 /* builds, knobs, kernel arguments + enqueues */
    int knobs[N_KNOBS];              /* under lock */
    program_entry *programs;         /* under lock */
    ocls_mutex err_lock;             /* the err_slot list only (a leaf lock) */
    err_slot *errors;
};

/* The program source of `file` ("shadow.cl", ...), NULL for another name. */
const char *ocls_source(const oclshade *lib, const char *file);

/* Where kernel sources come from: a directory, or a list of (name, text). */
typedef struct source_set {
    const char *dir;
    const oclshade_source *list;
    size_t count;
} source_set;

/* The text of `name` with its local includes expanded, each file once (malloc'd into *out). */
oclshade_status ocls_expanded_source(oclshade *lib, const source_set *set, const char *name, char **out);

/* The rule's value of every knob for a device (the safe values when a query fails). */
cl_int ocls_rule_values(cl_device_id device, int values[N_KNOBS]);

/* ------------------------------------------------------------------ errors */

/* Record a failure for the calling thread; returns status.  cl_err: the OpenCL code or 0. */
oclshade_status ocls_fail(oclshade *lib, oclshade_status status, cl_int cl_err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
oclshade_status ocls_fail_cl(oclshade *lib, cl_int err, const char *call);
const char *ocls_cl_error_name(cl_int err);
/* Common entry check: a usable handle; clears the calling thread's message. */
oclshade_status ocls_enter(oclshade *lib);
/* A knob's current value (under the lock). */
int ocls_knob(oclshade *lib, int knob);

/* ------------------------------------------------------------------ build options */

/* -D defines of one program variant; rendered sorted by name as the Python host's
 * runtime.define_options, then -cl-std=CL1.2. */
#define OCLS_MAX_DEFINES 24
typedef struct ocls_defines {
    int n;
    struct { const char *name; char value[48]; int bare; } d[OCLS_MAX_DEFINES];
} ocls_defines;

void ocls_def_flag(ocls_defines *d, const char *name, int on);      /* -DNAME when on */
void ocls_def_int(ocls_defines *d, const char *name, int value);    /* -DNAME=value */
void ocls_def_text(ocls_defines *d, const char *name, const char *value);
/* snprintf-style: the length needed including the NUL. */
size_t ocls_options(const ocls_defines *d, char *buf, size_t size);

/* ------------------------------------------------------------------ checks */

oclshade_status ocls_check_queue(oclshade *lib, cl_command_queue q);
oclshade_status ocls_check_wait_list(oclshade *lib, cl_uint n, const cl_event *list);
oclshade_status ocls_check_size(oclshade *lib, const char *what_rows, int rows, const char *what_cols, int cols);

/* How a call uses a buffer: read by the kernels, written, or both. */
enum { OCLS_IN = 1, OCLS_OUT = 2, OCLS_INOUT = 3 };

/* The buffers of one call, for the contract checks: each is a valid buffer of the handle's
 * context, large enough, with access flags that allow the use, and no buffer written
 * overlaps another buffer of the call (the same memory object or sub-buffers of one). */
#define OCLS_MAX_USES 24
typedef struct ocls_use {
    const char *name;
    cl_mem mem;
    size_t start, end;           /* byte range of the memory object the call touches */
    int access;
} ocls_use;

typedef struct ocls_uses {
    int n;
    ocls_use u[OCLS_MAX_USES];
} ocls_uses;

/* A whole buffer of at least `bytes` (its first `bytes` are used). */
oclshade_status ocls_use_buffer(oclshade *lib, ocls_uses *uses, const char *name, cl_mem mem, size_t bytes,
                                int access);
/* A field of rows x row_bytes (its offset and row pitch checked). */
oclshade_status ocls_use_field(oclshade *lib, ocls_uses *uses, const char *name, const oclshade_field *f,
                               int rows, size_t row_bytes, int access);
/* The overlap check over every buffer recorded. */
oclshade_status ocls_check_overlaps(oclshade *lib, const ocls_uses *uses);

/* ------------------------------------------------------------------ passes */

/* One enqueue call.  Its body runs twice: first to plan (size the scratch: every region
 * taken, nothing enqueued, no program built), then to run (lock held: programs built,
 * regions are sub-buffer views of the caller's scratch, commands chained by events). */
#define OCLS_MAX_VIEWS 24
typedef struct ocls_pass {
    oclshade *lib;
    int run;                     /* 0 plan, 1 run */
    cl_command_queue queue;
    cl_uint nwait;
    const cl_event *wait;
    cl_event last;
    cl_mem scratch;              /* run: the caller's scratch (or NULL when none is needed) */
    size_t scratch_used;         /* bytes taken so far */
    int nviews;
    cl_mem views[OCLS_MAX_VIEWS];
    int nstaged;
    struct { const oclshade_field *field; cl_mem view; int rows; size_t row_bytes; const char *name; }
        staged[OCLS_MAX_VIEWS];  /* outputs written to scratch, copied out at the end */
} ocls_pass;

void ocls_pass_init(ocls_pass *ps, oclshade *lib, int run, cl_command_queue q, cl_uint nwait,
                    const cl_event *wait, cl_mem scratch);
/* A sub-buffer view of bytes [offset, offset + size) of mem (of its parent when mem is a
 * sub-buffer itself); the start must be a multiple of the base address alignment. */
oclshade_status ocls_view(oclshade *lib, cl_mem mem, size_t offset, size_t size, const char *what, cl_mem *out);
/* Take a scratch region of `bytes`; run: *view is a sub-buffer over it. */
oclshade_status ocls_scratch(ocls_pass *ps, size_t bytes, const char *what, cl_mem *view);
/* The buffer a kernel reads for an input field: the field's own buffer when packed at
 * offset 0, else a scratch copy (clEnqueueCopyBufferRect). */
oclshade_status ocls_bind_in(ocls_pass *ps, const oclshade_field *f, int rows, size_t row_bytes,
                             const char *name, cl_mem *out);
/* The buffer a kernel writes for an output field: its own when packed at offset 0, else a
 * scratch region copied out by ocls_pass_finish. */
oclshade_status ocls_bind_out(ocls_pass *ps, const oclshade_field *f, int rows, size_t row_bytes,
                              const char *name, cl_mem *out);
/* Fill `bytes` at `offset` of mem with the data (copied at once: clEnqueueFillBuffer with the
 * largest fitting patterns), chained. */
oclshade_status ocls_upload(ocls_pass *ps, cl_mem mem, size_t offset, const void *data, size_t bytes,
                            const char *what);

/* Copy the first `bytes` of src to dst (run mode; between the parent buffers), chained. */
oclshade_status ocls_copy(ocls_pass *ps, cl_mem src, cl_mem dst, size_t bytes, const char *name);

/* Zero the first `bytes` of mem (clEnqueueFillBuffer), chained. */
oclshade_status ocls_zero(ocls_pass *ps, cl_mem mem, size_t bytes, const char *what);

/* A kernel of a program variant (built on first use; run mode only). */
oclshade_status ocls_kernel(ocls_pass *ps, const char *file, const ocls_defines *d, const char *name,
                            kernel_entry **out);
/* As ocls_kernel, of the file's source specialised for a condition vector first (paper 002's
 * @IF language, ocls_specialize; conditions NULL: the source as it is). */
oclshade_status ocls_kernel_variant(ocls_pass *ps, const char *file, const ocls_defines *d, const char *conditions,
                                    const char *name, kernel_entry **out);
/* Kernel arguments: {size, pointer to the value}. */
typedef struct ocls_arg { size_t size; const void *value; } ocls_arg;
#define OCLS_ARG(v) {sizeof(v), &(v)}
oclshade_status ocls_set_args(ocls_pass *ps, kernel_entry *k, const ocls_arg *args, int n);
/* Enqueue k over (cols, rows) work-items in groups of at most `wanted`, at most max_x wide
 * (the Python host's Runtime.grid_2d), or 1-D (rows 0: Runtime.local_size). */
oclshade_status ocls_launch(ocls_pass *ps, kernel_entry *k, int cols, int rows, size_t wanted, size_t max_x);
/* As ocls_launch over (cols, rows, layers) work-items (layers > 0) in groups of (grid_2d's x,
 * y, 1); wanted 0: global size exactly (cols, rows, layers) and the driver's local size. */
oclshade_status ocls_launch_3d(ocls_pass *ps, kernel_entry *k, int cols, int rows, int layers, size_t wanted,
                               size_t max_x);
/* Enqueue k over exactly (cols, rows) work-items from the global offset (col0, row0), each side
 * of the local size the largest power of two dividing that side within ocls_launch's limits
 * (a sun field's block, one enqueue each): nothing outside the window runs. */
oclshade_status ocls_launch_window(ocls_pass *ps, kernel_entry *k, int col0, int row0, int cols, int rows,
                                   size_t wanted, size_t max_x);
/* Copies out the staged outputs, releases the views; returns st (or the first failure) and
 * the last command's event in *event. */
oclshade_status ocls_pass_finish(ocls_pass *ps, oclshade_status st, cl_event *event);

/* The whole protocol of an enqueue entry point: plan the body, check the scratch against the
 * plan, run the body under the lock. */
typedef oclshade_status (*ocls_body)(ocls_pass *ps, const void *params);
oclshade_status ocls_enqueue(oclshade *lib, cl_command_queue q, cl_mem scratch, ocls_uses *uses,
                             ocls_body body, const void *params, cl_uint nwait, const cl_event *wait,
                             cl_event *event);
/* The scratch bytes an entry needs (the plan of its body). */
oclshade_status ocls_plan(oclshade *lib, ocls_body body, const void *params, size_t *bytes);

/* ------------------------------------------------------------------ @IF meta-language */

/* oclshade.specialize.specialize(source, conditions): the text into out (at most size bytes,
 * NUL-terminated when size > 0), *needed the bytes of the whole text with its NUL.  Returns 1,
 * or 0 with the message ("line N: ...") in error on malformed source or conditions. */
int ocls_specialize(const char *source, const char *conditions, char *out, size_t size, size_t *needed,
                    char *error, size_t error_size);

/* ------------------------------------------------------------------ shared maths */

/* oclshade/pyramid.py extrema_shapes / level_shapes (exposed through the layouts) */
int ocls_extent(int n0, int level);      /* ceil(n0 / 2^level) */

/* (ux, uy) of oclshade/sun.py Sun(azimuth, 0).ray(dx, dy): cells per metre east and south, float32
 * with subnormals flushed (shadows.c; the horizon rays). */
void ocls_horizontal_ray(double azimuth, double dx, double dy, cl_float out[2]);
/* oclshade/solar/scale.py direction_factor: sqrt(1 + p cos 2a + q sin 2a) with cos 2a = c^2 - s^2 and
 * sin 2a = 2 s c of sincos_degrees(azimuth), exactly 1 where p = q = 0 */
double ocls_direction_factor(double p, double q, double azimuth);

/* ------------------------------------------------------------------ objects on the terrain (quadrics.c) */

/* The arguments of kernels/terrain_ray.h's sun test on object pixels (caster.py
 * terrain_shadow_args): view-space sun (w = 1 at or below the horizon), terrain ray, eq. (1). */
typedef struct ocls_sun_args {
    cl_float4 sun, ray;
    cl_float kshadow;
} ocls_sun_args;
oclshade_status ocls_check_sun(oclshade *lib, double azimuth, double elevation, double k_dark, double k_bright);
float ocls_kshadow(double elevation, double k_dark, double k_bright);
oclshade_status ocls_sun_args_for(oclshade *lib, const oclshade_camera *camera, int terrain, double dx, double dy,
                                  double azimuth, double elevation, double k_dark, double k_bright, ocls_sun_args *out);
/* caster.py screen_rect: pixels (x0, y0, x1, y1) that may see a view-space sphere. */
void ocls_screen_rect(const oclshade_camera *cam, const double centre[3], double radius, cl_int out[4]);
/* An input and output field: ocls_bind_in, and a staged copy is copied back by ocls_pass_finish. */
oclshade_status ocls_bind_inout(ocls_pass *ps, const oclshade_field *f, int rows, size_t row_bytes, const char *name,
                                cl_mem *out);
/* Rows of the affine map view -> (u, v, z - offset) of the heightmap (zeros without one). */
void ocls_heightmap_rows(const double *view, int terrain, double dx, double dy, double offset, cl_float4 hm[3]);

#endif /* OCLSHADE_INTERNAL_H */
