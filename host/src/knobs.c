/* knobs.c — the tuning knobs of every family (the Python host's oclshade/tuning families the
 * C host has) and the rule that picks them for a device without measurements
 * (oclshade/tuning/rules.py). */
#include "internal.h"

#include <stdio.h>
#include <string.h>

/* ------------------------------------------------------------------ knobs */

/* What the rule sets a knob to (params.py Param.rule). */
enum { RULE_SAFE, RULE_WIDTH, RULE_WIDER, RULE_CROSSINGS, RULE_LIBRARY_CALLS, RULE_GPU };

/* The knobs of the Python host's tuning families the C host has (the TUNING of each oclshade module):
 * legal values, safe value, and the rule that sets it for a device without an entry:
 * RULE_WIDTH (rule="width"): on a CPU the widest legal value in 4..lanes;
 * RULE_WIDER (rule="wider"): the same where it exceeds the safe value, else the safe value;
 * RULE_CROSSINGS (rule="crossings"): on a CPU the largest legal value up to 16 x the width, at least
 * the smallest non-zero one;
 * RULE_LIBRARY_CALLS (rule="library_calls"): 1 where the driver leaves built-ins as calls;
 * RULE_GPU (rule="gpu"): the largest legal value on devices that are not CPUs. */
typedef struct knob_def {
    const char *family, *name;
    int nlegal;
    int legal[5];
    int safe;
    int rule;
} knob_def;

static const knob_def KNOBS[N_KNOBS] = {
    [K_PYRAMID_BASE_LANES] = {"pyramid", "base_lanes", 4, {1, 4, 8, 16}, 1, RULE_WIDTH},
    [K_PYRAMID_OWN_BUILTINS] = {"pyramid", "own_builtins", 2, {0, 1}, 0, RULE_LIBRARY_CALLS},
    [K_SHADOW_LANES] = {"shadow", "lanes", 4, {0, 4, 8, 16}, 0, RULE_WIDTH},
    [K_SHADOW_OWN_BUILTINS] = {"shadow", "own_builtins", 2, {0, 1}, 0, RULE_LIBRARY_CALLS},
    [K_SHADOW_GATHER] = {"shadow", "gather", 2, {0, 1}, 0, RULE_LIBRARY_CALLS},
    [K_SHADOW_CERT_TILE] = {"shadow", "cert_tile", 3, {16, 32, 64}, 16, RULE_SAFE},
    [K_SHADOW_RUN] = {"shadow", "run", 4, {16, 64, 256, 1024}, 1024, RULE_SAFE},
    [K_SHADOW_GROUP] = {"shadow", "group", 3, {16, 64, 256}, 64, RULE_SAFE},
    [K_TERRAIN_DESCEND] = {"terrain", "descend", 5, {1, 2, 3, 4, 5}, 3, RULE_SAFE},
    [K_TERRAIN_LEAF] = {"terrain", "leaf", 5, {0, 1, 2, 3, 4}, 2, RULE_SAFE},
    [K_TERRAIN_GROUP] = {"terrain", "group", 3, {16, 64, 256}, 64, RULE_SAFE},
    [K_TERRAIN_OWN_BUILTINS] = {"terrain", "own_builtins", 2, {0, 1}, 0, RULE_LIBRARY_CALLS},
    [K_PIXELS_GROUP] = {"screen_shadows", "group", 3, {16, 64, 256}, 64, RULE_SAFE},
    [K_PIXELS_OWN_BUILTINS] = {"screen_shadows", "own_builtins", 2, {0, 1}, 0, RULE_LIBRARY_CALLS},
    [K_SSAO_LANES] = {"ssao", "lanes", 3, {4, 8, 16}, 8, RULE_WIDER},
    [K_SSAO_GROUP] = {"ssao", "group", 3, {16, 64, 256}, 64, RULE_SAFE},
    [K_SSAO_OWN_BUILTINS] = {"ssao", "own_builtins", 2, {0, 1}, 0, RULE_SAFE},
    [K_HORIZON_GROUP] = {"horizon", "group", 3, {16, 64, 256}, 64, RULE_SAFE},
    [K_HORIZON_OWN_BUILTINS] = {"horizon", "own_builtins", 2, {0, 1}, 0, RULE_LIBRARY_CALLS},
    [K_HORIZON_LANES] = {"horizon", "lanes", 4, {1, 4, 8, 16}, 1, RULE_WIDTH},
    [K_HORIZON_SWEEP_CELLS] = {"horizon", "sweep_cells", 5, {0, 64, 128, 192, 256}, 128, RULE_CROSSINGS},
    [K_HORIZON_SWEEP_FAR] = {"horizon", "sweep_far", 3, {0, 1, 2}, 1, RULE_SAFE},
    [K_HORIZON_WIDTH] = {"horizon", "width", 4, {4, 8, 16, 32}, 16, RULE_SAFE},
    [K_HORIZON_BATCH] = {"horizon", "batch", 3, {1, 8, 64}, 1, RULE_GPU},
    [K_HORIZON_SCAN] = {"horizon", "scan", 2, {0, 1}, 0, RULE_GPU},
};

/* oclshade/tuning/rules.py TARGET_FLOAT_LANES: float lanes of the LLVM CPU target PoCL names in
 * CL_DEVICE_VERSION ("HSTR: pthread-x86_64-...-haswell"); the first row that matches wins. */
static const struct { cl_uint lanes; const char *names; } TARGET_FLOAT_LANES[] = {
    {16, "avx512 cascadelake cooperlake cannonlake icelake tigerlake rocketlake sapphirerapids graniterapids "
         "emeraldrapids znver4 znver5 x86-64-v4"},
    {8, "haswell broadwell skylake alderlake raptorlake meteorlake arrowlake lunarlake sandybridge ivybridge "
        "znver1 znver2 znver3 bdver btver2 x86-64-v3"},
    {4, "penryn nehalem westmere core2 bonnell silvermont goldmont tremont athlon amdfam10 btver1 x86-64"},
};

/* The target's float lanes from the device version, 0 if it names no known target. */
static cl_uint target_float_lanes(cl_device_id device)
{
    char version[512] = {0};
    if (clGetDeviceInfo(device, CL_DEVICE_VERSION, sizeof version - 1, version, NULL) != CL_SUCCESS) return 0;
    const char *target = strstr(version, "HSTR:");
    if (target == NULL) return 0;
    for (size_t row = 0; row < N_ITEMS(TARGET_FLOAT_LANES); ++row) {
        const char *p = TARGET_FLOAT_LANES[row].names;
        while (*p) {
            char name[32];
            size_t n = strcspn(p, " ");
            if (n >= sizeof name) n = sizeof name - 1;
            memcpy(name, p, n);
            name[n] = '\0';
            if (strstr(target, name) != NULL) return TARGET_FLOAT_LANES[row].lanes;
            p += n;
            while (*p == ' ') ++p;
        }
    }
    return 0;
}

/* rules.py builtins_are_calls: a PoCL CPU device whose driver version is 3.0 (the PyPI wheel leaves
 * the built-ins as calls into its library; Debian's 3.1 inlines them). */
static int builtins_are_calls(cl_device_id device, cl_device_type type)
{
    char version[512] = {0}, driver[128] = {0};
    if (!(type & CL_DEVICE_TYPE_CPU)) return 0;
    if (clGetDeviceInfo(device, CL_DEVICE_VERSION, sizeof version - 1, version, NULL) != CL_SUCCESS) return 0;
    if (clGetDeviceInfo(device, CL_DRIVER_VERSION, sizeof driver - 1, driver, NULL) != CL_SUCCESS) return 0;
    return strstr(version, "PoCL") != NULL && strncmp(driver, "3.0", 3) == 0;
}

/* rules.py rule_values for every knob into values[]; the safe values when a query fails. */
cl_int ocls_rule_values(cl_device_id device, int values[N_KNOBS])
{
    for (int k = 0; k < N_KNOBS; ++k) values[k] = KNOBS[k].safe;
    cl_device_type type = 0;
    cl_uint width = 0;
    cl_int err = clGetDeviceInfo(device, CL_DEVICE_TYPE, sizeof type, &type, NULL);
    if (err == CL_SUCCESS) err = clGetDeviceInfo(device, CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT, sizeof width, &width, NULL);
    if (err != CL_SUCCESS) return err;
    const cl_uint target = target_float_lanes(device);
    if (target) width = target;
    if (width < 1) width = 1;   /* rules.py: native_vector_width_float or 1 */
    if (!(type & CL_DEVICE_TYPE_CPU)) {
        for (int k = 0; k < N_KNOBS; ++k)
            if (KNOBS[k].rule == RULE_GPU) values[k] = KNOBS[k].legal[KNOBS[k].nlegal - 1];   /* ascending */
        return CL_SUCCESS;
    }
    const int calls = builtins_are_calls(device, type);
    for (int k = 0; k < N_KNOBS; ++k) {
        if (KNOBS[k].rule == RULE_LIBRARY_CALLS) values[k] = calls;
        if (KNOBS[k].rule == RULE_CROSSINGS) {
            int reach = 0, least = 0;
            for (int i = 0; i < KNOBS[k].nlegal; ++i) {
                const int v = KNOBS[k].legal[i];
                if (v > 0 && (cl_uint)v <= 16 * width && v > reach) reach = v;
                if (v > 0 && (least == 0 || v < least)) least = v;
            }
            values[k] = reach > 0 ? reach : least;
        }
        if (KNOBS[k].rule != RULE_WIDTH && KNOBS[k].rule != RULE_WIDER) continue;
        int best = -1, least = KNOBS[k].legal[0];
        for (int i = 0; i < KNOBS[k].nlegal; ++i) {
            const int v = KNOBS[k].legal[i];
            if (v >= 4 && (cl_uint)v <= width && v > best) best = v;
            if (v < least) least = v;
        }
        values[k] = best > 0 ? best : least;
        if (KNOBS[k].rule == RULE_WIDER && values[k] < KNOBS[k].safe) values[k] = KNOBS[k].safe;
    }
    return CL_SUCCESS;
}

static void legal_list(int k, char *buf, size_t size)
{
    size_t used = 0;
    buf[0] = '\0';
    for (int i = 0; i < KNOBS[k].nlegal && used < size; ++i)
        used += (size_t)snprintf(buf + used, size - used, "%s%d", i ? (i + 1 == KNOBS[k].nlegal ? " or " : ", ") : "",
                                 KNOBS[k].legal[i]);
}

/* The index of (family, name), or -1 with the failure recorded (lib may be NULL). */
static int find_knob(oclshade *lib, const char *family, const char *name)
{
    int family_known = 0;
    for (int k = 0; k < N_KNOBS; ++k) {
        if (family == NULL || strcmp(KNOBS[k].family, family) != 0) continue;
        family_known = 1;
        if (name != NULL && strcmp(KNOBS[k].name, name) == 0) return k;
    }
    if (lib == NULL) return -1;
    if (!family_known) {
        ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "family must be one of pyramid, shadow, terrain, screen_shadows, "
                  "ssao, horizon (the Python host's tuning families), got %s%s%s", family ? "\"" : "", family ? family : "NULL",
                  family ? "\"" : "");
        return -1;
    }
    char names[160] = "";
    size_t used = 0;
    for (int k = 0; k < N_KNOBS; ++k)
        if (strcmp(KNOBS[k].family, family) == 0 && used < sizeof names)
            used += (size_t)snprintf(names + used, sizeof names - used, "%s%s", used ? ", " : "", KNOBS[k].name);
    ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "knob must be one the C host has of family %s (%s), got %s%s%s%s",
              family, names, name ? "\"" : "", name ? name : "NULL", name ? "\"" : "",
              name && strcmp(family, "pyramid") == 0 && strcmp(name, "in_place") == 0
                  ? " (in_place chooses how the Python host holds host memory; the C host reads the caller's buffers)"
                  : "");
    return -1;
}

static int legal(int k, int value)
{
    for (int i = 0; i < KNOBS[k].nlegal; ++i)
        if (KNOBS[k].legal[i] == value) return 1;
    return 0;
}

int ocls_knob(oclshade *lib, int knob) { return lib->knobs[knob]; }

oclshade_status oclshade_set_knob(oclshade *lib, const char *family, const char *name, int value)
{
    oclshade_status st = ocls_enter(lib);
    if (st != OCLSHADE_OK) return st;
    const int k = find_knob(lib, family, name);
    if (k < 0) return OCLSHADE_INVALID_ARGUMENT;
    if (!legal(k, value)) {
        char values[64];
        legal_list(k, values, sizeof values);
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "knob %s %s must be %s, got %d", family, name, values, value);
    }
    ocls_mutex_lock(&lib->lock);
    lib->knobs[k] = value;
    ocls_mutex_unlock(&lib->lock);
    return OCLSHADE_OK;
}

oclshade_status oclshade_get_knob(const oclshade *clib, const char *family, const char *name, int *value)
{
    oclshade *lib = (oclshade *)clib;   /* the lock guards the knobs */
    oclshade_status st = ocls_enter(lib);
    if (st != OCLSHADE_OK) return st;
    const int k = find_knob(lib, family, name);
    if (k < 0) return OCLSHADE_INVALID_ARGUMENT;
    if (value == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "value must point to an int, got NULL");
    ocls_mutex_lock(&lib->lock);
    *value = lib->knobs[k];
    ocls_mutex_unlock(&lib->lock);
    return OCLSHADE_OK;
}

oclshade_status oclshade_default_knob(cl_device_id device, const char *family, const char *name, int *value)
{
    const int k = find_knob(NULL, family, name);
    if (device == NULL || value == NULL || k < 0) return OCLSHADE_INVALID_ARGUMENT;
    int values[N_KNOBS];
    const cl_int err = ocls_rule_values(device, values);
    *value = values[k];
    return err == CL_SUCCESS ? OCLSHADE_OK : OCLSHADE_OPENCL_ERROR;
}

oclshade_status oclshade_default_tuning(cl_device_id device, oclshade_tuning *out)
{
    if (out == NULL) return OCLSHADE_INVALID_ARGUMENT;
    int values[N_KNOBS];
    const cl_int err = device != NULL ? ocls_rule_values(device, values) : CL_INVALID_DEVICE;
    if (device == NULL) for (int k = 0; k < N_KNOBS; ++k) values[k] = KNOBS[k].safe;
    out->packet_lanes = values[K_SHADOW_LANES];
    out->packet_run = values[K_SHADOW_RUN];
    out->group = values[K_SHADOW_GROUP];
    if (device == NULL) return OCLSHADE_INVALID_ARGUMENT;
    return err == CL_SUCCESS ? OCLSHADE_OK : OCLSHADE_OPENCL_ERROR;
}

oclshade_status oclshade_set_tuning(oclshade *lib, const oclshade_tuning *t)
{
    oclshade_status st = ocls_enter(lib);
    if (st != OCLSHADE_OK) return st;
    if (t == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "tuning must point to an oclshade_tuning, got NULL");
    const struct { int knob; const char *field; int value; } fields[3] = {
        {K_SHADOW_LANES, "packet_lanes", t->packet_lanes}, {K_SHADOW_RUN, "packet_run", t->packet_run},
        {K_SHADOW_GROUP, "group", t->group}};
    for (int i = 0; i < 3; ++i) {
        if (!legal(fields[i].knob, fields[i].value)) {
            char values[64];
            legal_list(fields[i].knob, values, sizeof values);
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "tuning %s must be %s (knob shadow %s), got %d",
                             fields[i].field, values, KNOBS[fields[i].knob].name, fields[i].value);
        }
    }
    ocls_mutex_lock(&lib->lock);
    for (int i = 0; i < 3; ++i) lib->knobs[fields[i].knob] = fields[i].value;
    ocls_mutex_unlock(&lib->lock);
    return OCLSHADE_OK;
}

oclshade_status oclshade_get_tuning(const oclshade *clib, oclshade_tuning *out)
{
    oclshade *lib = (oclshade *)clib;
    if (lib == NULL || out == NULL) return OCLSHADE_INVALID_ARGUMENT;
    if (lib->failed != OCLSHADE_OK) return lib->failed;
    ocls_mutex_lock(&lib->lock);
    out->packet_lanes = lib->knobs[K_SHADOW_LANES];
    out->packet_run = lib->knobs[K_SHADOW_RUN];
    out->group = lib->knobs[K_SHADOW_GROUP];
    ocls_mutex_unlock(&lib->lock);
    return OCLSHADE_OK;
}
