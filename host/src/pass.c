/* pass.c — what every enqueue entry point shares: the argument and contract checks (buffers,
 * fields, aliasing) and passes (plan and run, scratch regions, field staging, event chains,
 * launches). */
#include "internal.h"

#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

/* ------------------------------------------------------------------ checks */

oclshade_status ocls_check_queue(oclshade *lib, cl_command_queue q)
{
    if (q == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "queue must be a valid cl_command_queue, got NULL");
    cl_context ctx = NULL;
    cl_device_id dev = NULL;
    cl_int err = clGetCommandQueueInfo(q, CL_QUEUE_CONTEXT, sizeof ctx, &ctx, NULL);
    if (err == CL_SUCCESS) err = clGetCommandQueueInfo(q, CL_QUEUE_DEVICE, sizeof dev, &dev, NULL);
    if (err != CL_SUCCESS) return ocls_fail_cl(lib, err, "clGetCommandQueueInfo(queue)");
    if (ctx != lib->context || dev != lib->device)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "queue must belong to the handle's context and device");
    return OCLSHADE_OK;
}

oclshade_status ocls_check_wait_list(oclshade *lib, cl_uint n, const cl_event *list)
{
    if ((n == 0) != (list == NULL))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "event_wait_list must be NULL exactly when "
                         "num_events_in_wait_list is 0 (got %u events, list %s)", (unsigned)n, list ? "non-NULL" : "NULL");
    return OCLSHADE_OK;
}

oclshade_status ocls_check_size(oclshade *lib, const char *what_rows, int rows, const char *what_cols, int cols)
{
    if (rows < 1 || cols < 1 || (long long)rows * cols > INT_MAX)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s and %s must be >= 1 with %s * %s < 2^31, got %s %d, %s %d",
                         what_rows, what_cols, what_rows, what_cols, what_rows, rows, what_cols, cols);
    return OCLSHADE_OK;
}

/* The memory object a buffer's bytes belong to (a sub-buffer's parent) and its offset there. */
static cl_int root_of(cl_mem mem, cl_mem *root, size_t *offset)
{
    cl_mem parent = NULL;
    size_t off = 0;
    cl_int err = clGetMemObjectInfo(mem, CL_MEM_ASSOCIATED_MEMOBJECT, sizeof parent, &parent, NULL);
    if (err == CL_SUCCESS && parent != NULL) err = clGetMemObjectInfo(mem, CL_MEM_OFFSET, sizeof off, &off, NULL);
    *root = parent != NULL ? parent : mem;
    *offset = off;
    return err;
}

/* A buffer of the handle's context of at least `bytes`, whose flags allow the access. */
static oclshade_status check_buffer(oclshade *lib, cl_mem mem, const char *name, size_t bytes, int access)
{
    if (mem == NULL)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s must be a cl_mem buffer of at least %lu bytes, got NULL",
                         name, (unsigned long)bytes);
    size_t size = 0;
    cl_context ctx = NULL;
    cl_mem_object_type type = 0;
    cl_mem_flags flags = 0;
    cl_int err = clGetMemObjectInfo(mem, CL_MEM_SIZE, sizeof size, &size, NULL);
    if (err == CL_SUCCESS) err = clGetMemObjectInfo(mem, CL_MEM_CONTEXT, sizeof ctx, &ctx, NULL);
    if (err == CL_SUCCESS) err = clGetMemObjectInfo(mem, CL_MEM_TYPE, sizeof type, &type, NULL);
    if (err == CL_SUCCESS) err = clGetMemObjectInfo(mem, CL_MEM_FLAGS, sizeof flags, &flags, NULL);
    if (err != CL_SUCCESS)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, err, "%s is not a valid cl_mem: %s (%d)", name,
                         ocls_cl_error_name(err), (int)err);
    if (type != CL_MEM_OBJECT_BUFFER || ctx != lib->context)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s must be a buffer (not an image) of the handle's context", name);
    if (size < bytes)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s must hold at least %lu bytes, got a buffer of %lu bytes",
                         name, (unsigned long)bytes, (unsigned long)size);
    if ((access & OCLS_OUT) && (flags & CL_MEM_READ_ONLY))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s is written by the kernels but was created "
                         "CL_MEM_READ_ONLY (expected CL_MEM_READ_WRITE%s)", name, access == OCLS_OUT ? " or CL_MEM_WRITE_ONLY" : "");
    if ((access & OCLS_IN) && (flags & CL_MEM_WRITE_ONLY))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s is read by the kernels but was created "
                         "CL_MEM_WRITE_ONLY (expected CL_MEM_READ_WRITE%s)", name, access == OCLS_IN ? " or CL_MEM_READ_ONLY" : "");
    return OCLSHADE_OK;
}

static oclshade_status record(oclshade *lib, ocls_uses *uses, const char *name, cl_mem mem, size_t start, size_t end,
                              int access)
{
    if (uses->n == OCLS_MAX_USES) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "too many buffers in one call");
    cl_mem root;
    size_t off;
    const cl_int err = root_of(mem, &root, &off);
    if (err != CL_SUCCESS) return ocls_fail_cl(lib, err, "clGetMemObjectInfo(CL_MEM_ASSOCIATED_MEMOBJECT)");
    ocls_use *u = &uses->u[uses->n++];
    u->name = name;
    u->mem = root;
    u->start = off + start;
    u->end = off + end;
    u->access = access;
    return OCLSHADE_OK;
}

oclshade_status ocls_use_buffer(oclshade *lib, ocls_uses *uses, const char *name, cl_mem mem, size_t bytes, int access)
{
    oclshade_status st = check_buffer(lib, mem, name, bytes, access);
    return st != OCLSHADE_OK ? st : record(lib, uses, name, mem, 0, bytes, access);
}

oclshade_status ocls_use_field(oclshade *lib, ocls_uses *uses, const char *name, const oclshade_field *f, int rows,
                               size_t row_bytes, int access)
{
    const size_t pitch = f->row_pitch ? f->row_pitch : row_bytes;
    if (pitch < row_bytes)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s row_pitch must be 0 (packed) or >= %lu bytes (a row), got %lu",
                         name, (unsigned long)row_bytes, (unsigned long)f->row_pitch);
    if (f->offset > SIZE_MAX - row_bytes || (size_t)(rows - 1) > (SIZE_MAX - f->offset - row_bytes) / pitch)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s offset %lu and row_pitch %lu overflow size_t", name,
                         (unsigned long)f->offset, (unsigned long)f->row_pitch);
    const size_t bytes = f->offset + (size_t)(rows - 1) * pitch + row_bytes;
    oclshade_status st = check_buffer(lib, f->buffer, name, bytes, access);
    return st != OCLSHADE_OK ? st : record(lib, uses, name, f->buffer, f->offset, bytes, access);
}

oclshade_status ocls_check_overlaps(oclshade *lib, const ocls_uses *uses)
{
    for (int i = 0; i < uses->n; ++i) {
        for (int j = i + 1; j < uses->n; ++j) {
            const ocls_use *a = &uses->u[i], *b = &uses->u[j];
            if (!((a->access | b->access) & OCLS_OUT) || a->mem != b->mem) continue;
            if (a->start < b->end && b->start < a->end)
                return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s and %s overlap (bytes %lu..%lu and %lu..%lu of "
                                 "one memory object): a buffer the call writes must not alias another of its buffers",
                                 a->name, b->name, (unsigned long)a->start, (unsigned long)a->end,
                                 (unsigned long)b->start, (unsigned long)b->end);
        }
    }
    return OCLSHADE_OK;
}

/* ------------------------------------------------------------------ passes */

void ocls_pass_init(ocls_pass *ps, oclshade *lib, int run, cl_command_queue q, cl_uint nwait, const cl_event *wait,
                    cl_mem scratch)
{
    memset(ps, 0, sizeof *ps);
    ps->lib = lib;
    ps->run = run;
    ps->queue = q;
    ps->nwait = nwait;
    ps->wait = wait;
    ps->scratch = scratch;
}

static cl_uint chain_n(const ocls_pass *ps) { return ps->last ? 1u : ps->nwait; }
static const cl_event *chain_list(const ocls_pass *ps) { return ps->last ? &ps->last : ps->wait; }

static void chain_next(ocls_pass *ps, cl_int err, cl_event ev)
{
    if (ps->last) clReleaseEvent(ps->last);
    ps->last = err == CL_SUCCESS ? ev : NULL;
}

oclshade_status ocls_view(oclshade *lib, cl_mem mem, size_t offset, size_t size, const char *what, cl_mem *out)
{
    cl_mem root;
    size_t off;
    cl_int err = root_of(mem, &root, &off);
    if (err == CL_SUCCESS && (off + offset) % lib->align != 0)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "%s: a sub-buffer at byte %lu of its buffer; expected a "
                         "multiple of CL_DEVICE_MEM_BASE_ADDR_ALIGN (%lu bytes)", what, (unsigned long)off,
                         (unsigned long)lib->align);
    cl_buffer_region region = {off + offset, size};
    *out = err == CL_SUCCESS ? clCreateSubBuffer(root, 0, CL_BUFFER_CREATE_TYPE_REGION, &region, &err) : NULL;
    if (err != CL_SUCCESS) {
        char call[96];
        snprintf(call, sizeof call, "clCreateSubBuffer(%s)", what);
        return ocls_fail_cl(lib, err, call);
    }
    return OCLSHADE_OK;
}

oclshade_status ocls_scratch(ocls_pass *ps, size_t bytes, const char *what, cl_mem *view)
{
    const size_t a = ps->lib->align;
    const size_t start = (ps->scratch_used + a - 1) / a * a;
    ps->scratch_used = start + (bytes ? bytes : 1);
    *view = NULL;
    if (!ps->run) return OCLSHADE_OK;
    if (ps->nviews == OCLS_MAX_VIEWS) return ocls_fail(ps->lib, OCLSHADE_INVALID_ARGUMENT, 0, "too many scratch regions");
    char name[96];
    snprintf(name, sizeof name, "scratch: %s", what);
    oclshade_status st = ocls_view(ps->lib, ps->scratch, start, bytes ? bytes : 1, name, view);
    if (st == OCLSHADE_OK) ps->views[ps->nviews++] = *view;
    return st;
}

static int packed(const oclshade_field *f, size_t row_bytes)
{
    return f->offset == 0 && (f->row_pitch == 0 || f->row_pitch == row_bytes);
}

/* Copy rows x row_bytes between a field and a packed view, chained.  Between the buffers the
 * sub-buffers belong to (PoCL 3.0 and 3.1 crash in clEnqueueCopyBufferRect on a sub-buffer). */
static oclshade_status copy_rect(ocls_pass *ps, cl_mem src, size_t src_off, size_t src_pitch, cl_mem dst, size_t dst_off,
                                 size_t dst_pitch, int rows, size_t row_bytes, const char *name)
{
    cl_mem src_root, dst_root;
    size_t src_base, dst_base;
    cl_int err = root_of(src, &src_root, &src_base);
    if (err == CL_SUCCESS) err = root_of(dst, &dst_root, &dst_base);
    if (err != CL_SUCCESS) return ocls_fail_cl(ps->lib, err, "clGetMemObjectInfo(CL_MEM_ASSOCIATED_MEMOBJECT)");
    const size_t src_origin[3] = {src_base + src_off, 0, 0}, dst_origin[3] = {dst_base + dst_off, 0, 0};
    const size_t region[3] = {row_bytes, (size_t)rows, 1};
    cl_event ev = NULL;
    err = clEnqueueCopyBufferRect(ps->queue, src_root, dst_root, src_origin, dst_origin, region, src_pitch, 0,
                                  dst_pitch, 0, chain_n(ps), chain_list(ps), &ev);
    chain_next(ps, err, ev);
    if (err != CL_SUCCESS) {
        char call[96];
        snprintf(call, sizeof call, "clEnqueueCopyBufferRect(%s)", name);
        return ocls_fail_cl(ps->lib, err, call);
    }
    return OCLSHADE_OK;
}

oclshade_status ocls_bind_in(ocls_pass *ps, const oclshade_field *f, int rows, size_t row_bytes, const char *name,
                             cl_mem *out)
{
    if (f->buffer == NULL || packed(f, row_bytes)) { *out = f->buffer; return OCLSHADE_OK; }
    oclshade_status st = ocls_scratch(ps, (size_t)rows * row_bytes, name, out);
    if (st != OCLSHADE_OK || !ps->run) return st;
    return copy_rect(ps, f->buffer, f->offset, f->row_pitch, *out, 0, row_bytes, rows, row_bytes, name);
}

oclshade_status ocls_bind_out(ocls_pass *ps, const oclshade_field *f, int rows, size_t row_bytes, const char *name,
                              cl_mem *out)
{
    if (f->buffer == NULL || packed(f, row_bytes)) { *out = f->buffer; return OCLSHADE_OK; }
    oclshade_status st = ocls_scratch(ps, (size_t)rows * row_bytes, name, out);
    if (st != OCLSHADE_OK || !ps->run) return st;
    const int i = ps->nstaged++;
    ps->staged[i].field = f;
    ps->staged[i].view = *out;
    ps->staged[i].rows = rows;
    ps->staged[i].row_bytes = row_bytes;
    ps->staged[i].name = name;
    return OCLSHADE_OK;
}

oclshade_status ocls_copy(ocls_pass *ps, cl_mem src, cl_mem dst, size_t bytes, const char *name)
{
    if (!ps->run) return OCLSHADE_OK;
    cl_mem src_root, dst_root;
    size_t src_base, dst_base;
    cl_int err = root_of(src, &src_root, &src_base);
    if (err == CL_SUCCESS) err = root_of(dst, &dst_root, &dst_base);
    if (err != CL_SUCCESS) return ocls_fail_cl(ps->lib, err, "clGetMemObjectInfo(CL_MEM_ASSOCIATED_MEMOBJECT)");
    cl_event ev = NULL;
    err = clEnqueueCopyBuffer(ps->queue, src_root, dst_root, src_base, dst_base, bytes, chain_n(ps), chain_list(ps), &ev);
    chain_next(ps, err, ev);
    if (err != CL_SUCCESS) {
        char call[96];
        snprintf(call, sizeof call, "clEnqueueCopyBuffer(%s)", name);
        return ocls_fail_cl(ps->lib, err, call);
    }
    return OCLSHADE_OK;
}

oclshade_status ocls_upload(ocls_pass *ps, cl_mem mem, size_t offset, const void *data, size_t bytes, const char *what)
{
    if (!ps->run) return OCLSHADE_OK;
    const unsigned char *p = (const unsigned char *)data;
    size_t done = 0;
    while (done < bytes) {
        size_t n = 128;   /* the largest pattern OpenCL allows; offsets and sizes multiples of it */
        while (n > 1 && ((offset + done) % n != 0 || bytes - done < n)) n /= 2;
        cl_event ev = NULL;
        const cl_int err = clEnqueueFillBuffer(ps->queue, mem, p + done, n, offset + done, n, chain_n(ps),
                                               chain_list(ps), &ev);
        chain_next(ps, err, ev);
        if (err != CL_SUCCESS) {
            char call[96];
            snprintf(call, sizeof call, "clEnqueueFillBuffer(%s)", what);
            return ocls_fail_cl(ps->lib, err, call);
        }
        done += n;
    }
    return OCLSHADE_OK;
}

oclshade_status ocls_zero(ocls_pass *ps, cl_mem mem, size_t bytes, const char *what)
{
    static const cl_float4 zeros[8];   /* 128 bytes of zero bits */
    if (!ps->run) return OCLSHADE_OK;
    size_t done = 0;
    while (done < bytes) {
        size_t n = 128;   /* the largest pattern that divides both the offset and what is left */
        while (n > 1 && (done % n != 0 || (bytes - done) % n != 0)) n /= 2;
        const size_t span = (bytes - done) / n * n;
        cl_event ev = NULL;
        const cl_int err = clEnqueueFillBuffer(ps->queue, mem, zeros, n, done, span, chain_n(ps), chain_list(ps), &ev);
        chain_next(ps, err, ev);
        if (err != CL_SUCCESS) {
            char call[96];
            snprintf(call, sizeof call, "clEnqueueFillBuffer(%s)", what);
            return ocls_fail_cl(ps->lib, err, call);
        }
        done += span;
    }
    return OCLSHADE_OK;
}

oclshade_status ocls_set_args(ocls_pass *ps, kernel_entry *k, const ocls_arg *args, int n)
{
    for (int i = 0; i < n; ++i) {
        const cl_int err = clSetKernelArg(k->kernel, (cl_uint)i, args[i].size, args[i].value);
        if (err != CL_SUCCESS) {
            char call[96];
            snprintf(call, sizeof call, "clSetKernelArg(%s, %d)", k->name, i);
            return ocls_fail_cl(ps->lib, err, call);
        }
    }
    return OCLSHADE_OK;
}

/* The Python host's Runtime.local_size: the largest power of two <= wanted that the device
 * and the kernel accept. */
static size_t local_size(const oclshade *lib, const kernel_entry *k, size_t wanted)
{
    size_t limit = k->max_group;
    if (lib->dev_max_wg < limit) limit = lib->dev_max_wg;
    if (lib->dev_max_item0 < limit) limit = lib->dev_max_item0;
    if (wanted < limit) limit = wanted;
    size_t ls = 1;
    while (ls * 2 <= limit) ls *= 2;
    return ls;
}

static size_t round_up(size_t n, size_t m) { return (n + m - 1) / m * m; }

static oclshade_status launch(ocls_pass *ps, kernel_entry *k, cl_uint dims, const size_t *offset, const size_t *global,
                              const size_t *local)
{
    cl_event ev = NULL;
    const cl_int err = clEnqueueNDRangeKernel(ps->queue, k->kernel, dims, offset, global, local, chain_n(ps),
                                              chain_list(ps), &ev);
    chain_next(ps, err, ev);
    if (err != CL_SUCCESS) {
        char call[96];
        snprintf(call, sizeof call, "clEnqueueNDRangeKernel(%s)", k->name);
        return ocls_fail_cl(ps->lib, err, call);
    }
    return OCLSHADE_OK;
}

oclshade_status ocls_launch(ocls_pass *ps, kernel_entry *k, int cols, int rows, size_t wanted, size_t max_x)
{
    return ocls_launch_3d(ps, k, cols, rows, 0, wanted, max_x);
}

oclshade_status ocls_launch_3d(ocls_pass *ps, kernel_entry *k, int cols, int rows, int layers, size_t wanted,
                               size_t max_x)
{
    size_t local[3] = {0, 1, 1}, global[3] = {(size_t)cols, (size_t)rows, (size_t)layers};
    if (wanted == 0) return launch(ps, k, 3, NULL, global, NULL);   /* the driver's local size */
    const size_t ls = local_size(ps->lib, k, wanted);
    if (rows == 0) {   /* 1-D over cols items */
        local[0] = ls;
        global[0] = round_up((size_t)cols, ls);
        return launch(ps, k, 1, NULL, global, local);
    }
    local[0] = ls < max_x ? ls : max_x;   /* Runtime.grid_2d, each layer one deep */
    local[1] = ls / local[0] ? ls / local[0] : 1;
    global[0] = round_up((size_t)cols, local[0]);
    global[1] = round_up((size_t)rows, local[1]);
    return launch(ps, k, layers > 0 ? 3 : 2, NULL, global, local);
}

/* The largest power of two that divides n and is at most limit (>= 1): Runtime._power_of_two_divisor. */
static size_t power_of_two_divisor(size_t n, size_t limit)
{
    size_t size = 1;
    while (size * 2 <= limit && n % (size * 2) == 0) size *= 2;
    return size;
}

oclshade_status ocls_launch_window(ocls_pass *ps, kernel_entry *k, int col0, int row0, int cols, int rows,
                                   size_t wanted, size_t max_x)
{
    const size_t ls = local_size(ps->lib, k, wanted);
    size_t local[2], offset[2] = {(size_t)col0, (size_t)row0}, global[2] = {(size_t)cols, (size_t)rows};
    local[0] = power_of_two_divisor((size_t)cols, ls < max_x ? ls : max_x);   /* exact: nothing past the window */
    local[1] = power_of_two_divisor((size_t)rows, ls / local[0] ? ls / local[0] : 1);
    return launch(ps, k, 2, offset, global, local);
}

oclshade_status ocls_pass_finish(ocls_pass *ps, oclshade_status st, cl_event *event)
{
    for (int i = 0; i < ps->nstaged && st == OCLSHADE_OK; ++i) {
        const oclshade_field *f = ps->staged[i].field;
        st = copy_rect(ps, ps->staged[i].view, 0, ps->staged[i].row_bytes, f->buffer, f->offset, f->row_pitch,
                       ps->staged[i].rows, ps->staged[i].row_bytes, ps->staged[i].name);
    }
    for (int i = 0; i < ps->nviews; ++i) clReleaseMemObject(ps->views[i]);   /* OpenCL keeps them for the commands */
    ps->nviews = 0;
    if (st == OCLSHADE_OK && event != NULL && ps->last == NULL && ps->queue != NULL) {
        /* nothing to do (the mip pyramid of a 1 x 1 map): still an event, after the wait list */
        cl_event ev = NULL;
        const cl_int err = clEnqueueMarkerWithWaitList(ps->queue, ps->nwait, ps->wait, &ev);
        chain_next(ps, err, ev);
        if (err != CL_SUCCESS) st = ocls_fail_cl(ps->lib, err, "clEnqueueMarkerWithWaitList");
    }
    if (st == OCLSHADE_OK && event != NULL) {
        *event = ps->last;
    } else if (ps->last) {
        clReleaseEvent(ps->last);
    }
    ps->last = NULL;
    return st;
}

oclshade_status ocls_plan(oclshade *lib, ocls_body body, const void *params, size_t *bytes)
{
    ocls_pass ps;
    ocls_pass_init(&ps, lib, 0, NULL, 0, NULL, NULL);
    ocls_mutex_lock(&lib->lock);    /* the body reads knobs */
    const oclshade_status st = body(&ps, params);
    ocls_mutex_unlock(&lib->lock);
    *bytes = ps.scratch_used;
    return st;
}

oclshade_status ocls_enqueue(oclshade *lib, cl_command_queue q, cl_mem scratch, ocls_uses *uses, ocls_body body,
                             const void *params, cl_uint nwait, const cl_event *wait, cl_event *event)
{
    oclshade_status st;
    if ((st = ocls_check_queue(lib, q)) != OCLSHADE_OK || (st = ocls_check_wait_list(lib, nwait, wait)) != OCLSHADE_OK)
        return st;
    ocls_pass ps;
    ocls_pass_init(&ps, lib, 0, NULL, 0, NULL, NULL);
    ocls_mutex_lock(&lib->lock);   /* held from the plan to the last enqueue: one set of knobs */
    st = body(&ps, params);
    if (st == OCLSHADE_OK) st = ocls_check_overlaps(lib, uses);   /* the caller's buffers first: the clearer message */
    if (st == OCLSHADE_OK && ps.scratch_used > 0) {
        st = ocls_use_buffer(lib, uses, "scratch", scratch, ps.scratch_used, OCLS_INOUT);
        if (st != OCLSHADE_OK && scratch == NULL)
            st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "scratch must be a buffer of at least %lu bytes for these "
                           "parameters (the entry point's scratch_size query), got NULL", (unsigned long)ps.scratch_used);
    }
    if (st == OCLSHADE_OK) st = ocls_check_overlaps(lib, uses);
    if (st == OCLSHADE_OK) {
        ocls_pass_init(&ps, lib, 1, q, nwait, wait, scratch);
        st = body(&ps, params);
        st = ocls_pass_finish(&ps, st, event);
    }
    ocls_mutex_unlock(&lib->lock);
    return st;
}
