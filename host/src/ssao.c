/* ssao.c — screen-space ambient occlusion (kernels/ssao.cl; oclshade/ssao.py): the sample
 * tables, the projection rows, and the passes ssao_prepare, ssao_ao, blurs. */
#include "internal.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#define M_MIN 4
#define M_MAX 256
#define PAPER_SEED 2019u
#define RAY_STEPS 4                                  /* oclshade/ssao.py RAY_STEPS */
#define DEPTH_TOL "0x1.0000000000000p-16f"           /* DEPTH_TOL.hex() + "f": 2^-16 */
static const double GOLDEN[3] = {0.6180339887498949, 0.7548776662466927, 0.5698402909980532};
static const double PI = 3.141592653589793;          /* np.pi */

/* ------------------------------------------------------------------ numpy's PCG64 */

/* np.random.default_rng(seed).random(): numpy's SeedSequence(seed) (pool of 4 words) seeds
 * PCG64 (XSL-RR 128/64) with generate_state(4, uint64); random() = (next >> 11) * 2^-53. */
typedef struct u128 { uint64_t hi, lo; } u128;

static u128 add128(u128 a, u128 b)
{
    u128 r = {a.hi + b.hi, a.lo + b.lo};
    r.hi += r.lo < a.lo;
    return r;
}

static u128 mul128(u128 a, u128 b)
{
    /* low 128 bits of a * b: a.lo * b.lo in full, plus the cross terms' low words */
    const uint64_t a0 = a.lo & 0xffffffffu, a1 = a.lo >> 32, b0 = b.lo & 0xffffffffu, b1 = b.lo >> 32;
    const uint64_t p00 = a0 * b0, p01 = a0 * b1, p10 = a1 * b0, p11 = a1 * b1;
    const uint64_t mid = (p00 >> 32) + (p01 & 0xffffffffu) + (p10 & 0xffffffffu);
    u128 r;
    r.lo = (mid << 32) | (p00 & 0xffffffffu);
    r.hi = p11 + (p01 >> 32) + (p10 >> 32) + (mid >> 32) + a.hi * b.lo + a.lo * b.hi;
    return r;
}

typedef struct pcg64 { u128 state, inc; } pcg64;

static const u128 PCG_MULT = {2549297995355413924ull, 4865540595714422341ull};

static void pcg_step(pcg64 *g) { g->state = add128(mul128(g->state, PCG_MULT), g->inc); }

static uint64_t pcg_next(pcg64 *g)
{
    pcg_step(g);
    const uint64_t x = g->state.hi ^ g->state.lo;
    const unsigned rot = (unsigned)(g->state.hi >> 58);
    return (x >> rot) | (x << ((64u - rot) & 63u));
}

/* numpy/random/bit_generator.pyx SeedSequence with one entropy word and no spawn key. */
static uint32_t hashmix(uint32_t value, uint32_t *hash_const)
{
    value ^= *hash_const;
    *hash_const *= 0x931e8875u;
    value *= *hash_const;
    value ^= value >> 16;
    return value;
}

static uint32_t mix(uint32_t x, uint32_t y)
{
    uint32_t r = 0xca01f9ddu * x - 0x4973f715u * y;
    r ^= r >> 16;
    return r;
}

static void seed_pcg64(uint32_t entropy, pcg64 *g)
{
    uint32_t pool[4], hash_const = 0x43b0d7e5u;
    for (int i = 0; i < 4; ++i) pool[i] = hashmix(i == 0 ? entropy : 0u, &hash_const);
    for (int src = 0; src < 4; ++src)
        for (int dst = 0; dst < 4; ++dst)
            if (src != dst) pool[dst] = mix(pool[dst], hashmix(pool[src], &hash_const));
    uint32_t words[8];
    hash_const = 0x8b51f9ddu;
    for (int i = 0; i < 8; ++i) {
        uint32_t v = pool[i % 4] ^ hash_const;
        hash_const *= 0x58f38dedu;
        v *= hash_const;
        v ^= v >> 16;
        words[i] = v;
    }
    uint64_t val[4];
    for (int i = 0; i < 4; ++i) val[i] = (uint64_t)words[2 * i] | ((uint64_t)words[2 * i + 1] << 32);
    /* pcg64_set_seed(state, seed = val[0:2], inc = val[2:4]), (high, low) words: srandom_r */
    const u128 seed = {val[0], val[1]}, initseq = {val[2], val[3]};
    g->state.hi = g->state.lo = 0;
    g->inc.hi = (initseq.hi << 1) | (initseq.lo >> 63);
    g->inc.lo = (initseq.lo << 1) | 1u;
    pcg_step(g);
    g->state = add128(g->state, seed);
    pcg_step(g);
}

static double pcg_double(pcg64 *g) { return (double)(pcg_next(g) >> 11) * (1.0 / 9007199254740992.0); }

/* ------------------------------------------------------------------ sample tables */

/* hemisphere_points(m, distribution) row i into xyz (float64, the Python host's operations). */
static void point_sample(oclshade_ao_samples samples, int m, int i, pcg64 *g, double xyz[3])
{
    if (samples == OCLSHADE_AO_PAPER) {   /* rng.random((n, 3)): row by row */
        const double f0 = pcg_double(g), f1 = pcg_double(g), f2 = pcg_double(g);
        xyz[0] = 2 * f0 - 1;
        xyz[1] = 2 * f1 - 1;
        xyz[2] = f2;
        return;
    }
    const double s = ((double)i + 0.5) / (double)m;
    const double cos_t = fmod((double)i * GOLDEN[1] + 0.5, 1.0);
    const double phi = 2.0 * PI * fmod((double)i * GOLDEN[2] + 0.25, 1.0);
    const double r = samples == OCLSHADE_AO_UNIFORM ? cbrt(s) : 0.1 + 0.9 * s * s;
    const double sin_t = sqrt(1.0 - cos_t * cos_t);
    xyz[0] = r * sin_t * cos(phi);
    xyz[1] = r * sin_t * sin(phi);
    xyz[2] = r * cos_t;
}

/* line_table(m) row i: disk_points (Vogel spiral) and the chord half-length. */
static void line_sample(int m, int i, double xyz[3])
{
    const double r = sqrt(((double)i + 0.5) / (double)m);
    const double phi = 2.0 * PI * fmod((double)i * GOLDEN[0], 1.0);
    const double x = r * cos(phi), y = r * sin(phi);
    const double rest = 1.0 - (x * x + y * y);
    xyz[0] = x;
    xyz[1] = y;
    xyz[2] = sqrt(rest > 0.0 ? rest : 0.0);
}

oclshade_status oclshade_ssao_table(oclshade_ao_samples samples, int m, float *out, int *mpad_out)
{
    if (out == NULL || m < M_MIN || m > M_MAX || (int)samples < OCLSHADE_AO_PAPER || samples > OCLSHADE_AO_RAYS)
        return OCLSHADE_INVALID_ARGUMENT;
    const int mpad = (m + 7) / 8 * 8;
    pcg64 g;
    if (samples == OCLSHADE_AO_PAPER) seed_pcg64(PAPER_SEED, &g);
    for (int i = 0; i < mpad; ++i) {
        double xyz[3] = {NAN, NAN, NAN};
        if (i < m && (samples == OCLSHADE_AO_LINES || samples == OCLSHADE_AO_RAYS)) line_sample(m, i, xyz);
        else if (i < m) point_sample(samples, m, i, &g, xyz);
        for (int a = 0; a < 3; ++a) out[a * mpad + i] = (float)xyz[a];
    }
    if (mpad_out != NULL) *mpad_out = mpad;
    return OCLSHADE_OK;
}

/* ------------------------------------------------------------------ projection rows */

/* The determinant of the 3 x 3 matrix of columns c[0..2] of the 3 x 4 rows. */
static double det3(const double rows[3][4], const int c[3])
{
    return rows[0][c[0]] * (rows[1][c[1]] * rows[2][c[2]] - rows[1][c[2]] * rows[2][c[1]]) -
           rows[0][c[1]] * (rows[1][c[0]] * rows[2][c[2]] - rows[1][c[2]] * rows[2][c[0]]) +
           rows[0][c[2]] * (rows[1][c[0]] * rows[2][c[1]] - rows[1][c[1]] * rows[2][c[0]]);
}

/* oclshade/ssao.py line_eye: the point every line of sight passes through, the null vector of
 * the projection's rows 0, 1 and 3 (here by cofactors, the Python host by SVD: the same
 * vector up to rounding, exactly for the Python host's cameras, whose rows are sparse);
 * 0 on success, -1 for rank < 3, -2 for lines of sight without a z component. */
static int line_eye(const double proj[16], double e[4])
{
    double rows[3][4];
    for (int c = 0; c < 4; ++c) {
        rows[0][c] = proj[c];
        rows[1][c] = proj[4 + c];
        rows[2][c] = proj[12 + c];
    }
    static const int minors[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    double big = 0.0, scale = 0.0;
    for (int i = 0; i < 4; ++i) {
        e[i] = (i % 2 ? -1.0 : 1.0) * det3(rows, minors[i]);
        if (fabs(e[i]) > big) big = fabs(e[i]);
    }
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) scale = fabs(rows[r][c]) > scale ? fabs(rows[r][c]) : scale;
    if (!(big > 1e-12 * scale * scale * scale)) return -1;
    const double m3 = fmax(fmax(fabs(e[0]), fabs(e[1])), fabs(e[2]));
    if (fabs(e[3]) > 1e-9 * m3) {
        const double w = e[3];
        for (int i = 0; i < 4; ++i) e[i] = e[i] / w;
        return 0;
    }
    if (fabs(e[2]) <= 1e-9 * m3) return -2;
    const double norm = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]), sign = e[2] > 0 ? 1.0 : -1.0;
    for (int i = 0; i < 3; ++i) e[i] = e[i] / norm * sign;
    e[3] = 0.0;
    return 0;
}

/* ------------------------------------------------------------------ the pass */

void oclshade_ssao_params_init(oclshade_ssao_params *p)
{
    if (p == NULL) return;
    memset(p, 0, sizeof *p);
    p->m = 8;                          /* ssao.py DEFAULT_M, DEFAULT_FEATURES */
    p->samples = OCLSHADE_AO_RAYS;
    p->range_check = 1;
    p->blur = OCLSHADE_BLUR_BOX;
    p->blur_size = 3;
    p->alpha_eps = 0.5;
    for (int i = 0; i < 4; ++i) p->projection[5 * i] = 1.0;
}

typedef struct ssao_job {
    const oclshade_ssao_params *p;
    float prj[16];       /* pru, prv, prw, E */
    int mpad;
    float table[3 * M_MAX];
} ssao_job;

static oclshade_status ssao_job_for(oclshade *lib, const oclshade_ssao_params *p, ssao_job *j)
{
    oclshade_status st;
    memset(j, 0, sizeof *j);
    if (p == NULL) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "params must point to oclshade_ssao_params, got NULL");
    if ((st = ocls_check_size(lib, "height", p->height, "width", p->width)) != OCLSHADE_OK) return st;
    if (p->m < M_MIN || p->m > M_MAX)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "m must be an integer in %d..%d (samples per pixel), got %d",
                         M_MIN, M_MAX, p->m);
    if (!(isfinite(p->radius) && p->radius > 0.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "radius must be positive and finite (metres), got %g", p->radius);
    if (!isfinite(p->delta)) return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "delta must be finite, got %g", p->delta);
    if ((int)p->samples < OCLSHADE_AO_PAPER || p->samples > OCLSHADE_AO_RAYS)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "samples must be an oclshade_ao_samples (0..4), got %d",
                         (int)p->samples);
    if ((int)p->blur < OCLSHADE_BLUR_NONE || p->blur > OCLSHADE_BLUR_EDGE)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "blur must be OCLSHADE_BLUR_NONE, _BOX or _EDGE (0..2), got %d",
                         (int)p->blur);
    if (p->blur != OCLSHADE_BLUR_NONE && (p->blur_size < 3 || p->blur_size % 2 == 0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "blur_size must be an odd integer >= 3 (the paper's N), got %d",
                         p->blur_size);
    const double tol = p->plane_tol == 0.0 ? p->radius / 4.0 : p->plane_tol;
    if (p->blur == OCLSHADE_BLUR_EDGE && !(isfinite(tol) && tol > 0.0))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "plane_tol must be positive and finite (0: radius / 4), got %g",
                         p->plane_tol);
    if ((p->normal_map.buffer == NULL) != (p->tangent.buffer == NULL))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "normal_map and tangent go together (the tangent builds the "
                         "TBN frame): give both buffers or neither");
    if (p->alpha.buffer != NULL && !isfinite(p->alpha_eps))
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "alpha_eps must be finite, got %g", p->alpha_eps);
    for (int i = 0; i < 16; ++i)
        if (!isfinite(p->projection[i]))
            return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "projection must be a finite 4 x 4 matrix, element %d is %g",
                             i, p->projection[i]);
    double e[4];
    const int eye = line_eye(p->projection, e);
    if (eye == -1)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "projection: rows 0, 1 and 3 (clip x, y, w) must have rank 3 "
                         "(a camera)");
    if (eye == -2)
        return ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "projection: the lines of sight lie in the view plane z = const "
                         "(no depth); SSAO needs a view direction with a z component");
    /* SSAO.run: rows = [W/2 (M0 + M3), H/2 (M3 - M1), M3, E] in float64, rounded once */
    const double *M = p->projection;
    for (int c = 0; c < 4; ++c) {
        j->prj[c] = (float)(0.5 * p->width * (M[c] + M[12 + c]));
        j->prj[4 + c] = (float)(0.5 * p->height * (M[12 + c] - M[4 + c]));
        j->prj[8 + c] = (float)M[12 + c];
        j->prj[12 + c] = (float)e[c];
    }
    oclshade_ssao_table(p->samples, p->m, j->table, &j->mpad);
    j->p = p;
    return OCLSHADE_OK;
}

static void ssao_defines(oclshade *lib, const oclshade_ssao_params *p, ocls_defines *d)
{
    /* AOFeatures.defines + OCLS_SSAO_LANES, OCLS_OWN_BUILTINS, OCLS_DEPTH_TOL (SSAO.run) */
    memset(d, 0, sizeof *d);
    ocls_def_flag(d, "OCLS_NORMAL_MAP", p->normal_map.buffer != NULL);
    ocls_def_flag(d, "OCLS_ALPHA", p->alpha.buffer != NULL);
    ocls_def_flag(d, "OCLS_RANGE_CHECK", p->range_check);
    ocls_def_flag(d, "OCLS_PLANE_TEST", p->plane_test);
    ocls_def_flag(d, "OCLS_LINES", p->samples == OCLSHADE_AO_LINES);
    ocls_def_flag(d, "OCLS_RAYS", p->samples == OCLSHADE_AO_RAYS);
    if (p->samples == OCLSHADE_AO_RAYS) ocls_def_int(d, "OCLS_RAY_STEPS", RAY_STEPS);
    ocls_def_flag(d, "OCLS_BLUR_BOX", p->blur == OCLSHADE_BLUR_BOX);
    ocls_def_flag(d, "OCLS_BLUR_EDGE", p->blur == OCLSHADE_BLUR_EDGE);
    ocls_def_int(d, "OCLS_SSAO_LANES", ocls_knob(lib, K_SSAO_LANES));
    ocls_def_flag(d, "OCLS_OWN_BUILTINS", ocls_knob(lib, K_SSAO_OWN_BUILTINS));
    ocls_def_text(d, "OCLS_DEPTH_TOL", DEPTH_TOL);
}

/* oclshade/ssao.py SSAO.run */
static oclshade_status ssao_body(ocls_pass *ps, const void *params)
{
    const ssao_job *j = (const ssao_job *)params;
    const oclshade_ssao_params *p = j->p;
    oclshade *lib = ps->lib;
    const int rows = p->height;
    const size_t w = (size_t)p->width, n = w * (size_t)rows;
    cl_mem pos, nrm, alpha = NULL, nmap = NULL, tangent = NULL, out;
    cl_mem zbuf, nout, ao, plane = NULL, tmp = NULL, prj, kern;
    oclshade_status st;
    if ((st = ocls_bind_in(ps, &p->position, rows, 16 * w, "position", &pos)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->normal, rows, 16 * w, "normal", &nrm)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->alpha, rows, 4 * w, "alpha", &alpha)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->normal_map, rows, 16 * w, "normal_map", &nmap)) != OCLSHADE_OK ||
        (st = ocls_bind_in(ps, &p->tangent, rows, 16 * w, "tangent", &tangent)) != OCLSHADE_OK ||
        (st = ocls_scratch(ps, 4 * n, "AO depth", &zbuf)) != OCLSHADE_OK ||
        (st = ocls_scratch(ps, 16 * n, "AO normals", &nout)) != OCLSHADE_OK ||
        (st = ocls_scratch(ps, sizeof j->prj, "projection rows", &prj)) != OCLSHADE_OK ||
        (st = ocls_scratch(ps, 12u * (size_t)j->mpad, "sample table", &kern)) != OCLSHADE_OK ||
        (p->plane_test && (st = ocls_scratch(ps, 16 * n, "occluder planes", &plane)) != OCLSHADE_OK) ||
        (p->blur == OCLSHADE_BLUR_BOX && (st = ocls_scratch(ps, 8 * n, "blur sums", &tmp)) != OCLSHADE_OK) ||
        (st = ocls_bind_out(ps, &p->ao, rows, 4 * w, "ao", &out)) != OCLSHADE_OK)
        return st;
    /* the raw AO map: the output itself without a blur, else scratch */
    if (p->blur == OCLSHADE_BLUR_NONE) ao = out;
    else if ((st = ocls_scratch(ps, 4 * n, "AO map", &ao)) != OCLSHADE_OK) return st;
    if (!ps->run) return OCLSHADE_OK;

    if ((st = ocls_upload(ps, prj, 0, j->prj, sizeof j->prj, "projection rows")) != OCLSHADE_OK ||
        (st = ocls_upload(ps, kern, 0, j->table, 12u * (size_t)j->mpad, "sample table")) != OCLSHADE_OK)
        return st;
    ocls_defines d;
    ssao_defines(lib, p, &d);
    const cl_int W = p->width, H = p->height, m = p->m, mpad = j->mpad;
    const int lanes = ocls_knob(lib, K_SSAO_LANES);
    const size_t group = (size_t)ocls_knob(lib, K_SSAO_GROUP);
    const int items = (p->width + lanes - 1) / lanes;   /* `lanes` pixels per work-item */
    kernel_entry *k;

    if ((st = ocls_kernel(ps, "ssao.cl", &d, "ssao_prepare", &k)) != OCLSHADE_OK) return st;
    const cl_float alpha_eps = (cl_float)p->alpha_eps;
    ocls_arg a[16];
    int na = 0;
    a[na].size = sizeof pos; a[na++].value = &pos;
    a[na].size = sizeof nrm; a[na++].value = &nrm;
    if (alpha) {
        a[na].size = sizeof alpha; a[na++].value = &alpha;
        a[na].size = sizeof alpha_eps; a[na++].value = &alpha_eps;
    }
    if (nmap) {
        a[na].size = sizeof nmap; a[na++].value = &nmap;
        a[na].size = sizeof tangent; a[na++].value = &tangent;
    }
    a[na].size = sizeof W; a[na++].value = &W;
    a[na].size = sizeof H; a[na++].value = &H;
    a[na].size = sizeof zbuf; a[na++].value = &zbuf;
    a[na].size = sizeof nout; a[na++].value = &nout;
    if (plane) { a[na].size = sizeof plane; a[na++].value = &plane; }
    if ((st = ocls_set_args(ps, k, a, na)) != OCLSHADE_OK || (st = ocls_launch(ps, k, W, H, group, 16)) != OCLSHADE_OK)
        return st;

    if ((st = ocls_kernel(ps, "ssao.cl", &d, "ssao_ao", &k)) != OCLSHADE_OK) return st;
    const cl_float radius = (cl_float)p->radius, delta = (cl_float)p->delta;
    const cl_uint seed = p->seed;
    const ocls_arg ao_args[] = {OCLS_ARG(pos), OCLS_ARG(nout), OCLS_ARG(zbuf), OCLS_ARG(W), OCLS_ARG(H),
                                OCLS_ARG(prj), OCLS_ARG(kern), OCLS_ARG(m), OCLS_ARG(mpad), OCLS_ARG(radius),
                                OCLS_ARG(delta), OCLS_ARG(seed), OCLS_ARG(ao), OCLS_ARG(plane)};
    if ((st = ocls_set_args(ps, k, ao_args, plane ? 14 : 13)) != OCLSHADE_OK ||
        (st = ocls_launch(ps, k, items, H, group, 16)) != OCLSHADE_OK)
        return st;

    const cl_int half = p->blur_size / 2;
    if (p->blur == OCLSHADE_BLUR_BOX) {
        const ocls_arg h_args[] = {OCLS_ARG(ao), OCLS_ARG(zbuf), OCLS_ARG(W), OCLS_ARG(H), OCLS_ARG(half), OCLS_ARG(tmp)};
        const ocls_arg v_args[] = {OCLS_ARG(tmp), OCLS_ARG(zbuf), OCLS_ARG(W), OCLS_ARG(H), OCLS_ARG(half), OCLS_ARG(out)};
        if ((st = ocls_kernel(ps, "ssao.cl", &d, "ssao_box_h", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, h_args, 6)) != OCLSHADE_OK || (st = ocls_launch(ps, k, items, H, group, 16)) != OCLSHADE_OK ||
            (st = ocls_kernel(ps, "ssao.cl", &d, "ssao_box_v", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, v_args, 6)) != OCLSHADE_OK || (st = ocls_launch(ps, k, items, H, group, 16)) != OCLSHADE_OK)
            return st;
    } else if (p->blur == OCLSHADE_BLUR_EDGE) {
        const cl_float tol = (cl_float)(p->plane_tol == 0.0 ? p->radius / 4.0 : p->plane_tol);
        const ocls_arg e_args[] = {OCLS_ARG(ao), OCLS_ARG(pos), OCLS_ARG(nout), OCLS_ARG(zbuf), OCLS_ARG(W),
                                   OCLS_ARG(H), OCLS_ARG(half), OCLS_ARG(tol), OCLS_ARG(out)};
        if ((st = ocls_kernel(ps, "ssao.cl", &d, "ssao_edge", &k)) != OCLSHADE_OK ||
            (st = ocls_set_args(ps, k, e_args, 9)) != OCLSHADE_OK || (st = ocls_launch(ps, k, W, H, group, 16)) != OCLSHADE_OK)
            return st;
    }
    return OCLSHADE_OK;
}

oclshade_status oclshade_ssao_scratch_size(oclshade *lib, const oclshade_ssao_params *params, size_t *bytes)
{
    ssao_job job;
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK && bytes == NULL) st = ocls_fail(lib, OCLSHADE_INVALID_ARGUMENT, 0, "bytes must not be NULL");
    if (st == OCLSHADE_OK) st = ssao_job_for(lib, params, &job);
    return st != OCLSHADE_OK ? st : ocls_plan(lib, ssao_body, &job, bytes);
}

oclshade_status oclshade_enqueue_ssao(oclshade *lib, cl_command_queue queue, const oclshade_ssao_params *p,
                                      cl_uint num_events_in_wait_list, const cl_event *event_wait_list, cl_event *event)
{
    ssao_job j;
    ocls_uses uses = {0};
    oclshade_status st = ocls_enter(lib);
    if (st == OCLSHADE_OK) st = ssao_job_for(lib, p, &j);
    if (st != OCLSHADE_OK) return st;
    const int rows = p->height;
    const size_t w = (size_t)p->width;
    const struct { const char *name; const oclshade_field *f; size_t row; int access; } fields[] = {
        {"position", &p->position, 16 * w, OCLS_IN}, {"normal", &p->normal, 16 * w, OCLS_IN},
        {"alpha", &p->alpha, 4 * w, OCLS_IN}, {"normal_map", &p->normal_map, 16 * w, OCLS_IN},
        {"tangent", &p->tangent, 16 * w, OCLS_IN}, {"ao", &p->ao, 4 * w, OCLS_OUT}};
    for (size_t i = 0; i < N_ITEMS(fields) && st == OCLSHADE_OK; ++i)
        if (fields[i].f->buffer != NULL || i < 2 || fields[i].access == OCLS_OUT)
            st = ocls_use_field(lib, &uses, fields[i].name, fields[i].f, rows, fields[i].row, fields[i].access);
    if (st != OCLSHADE_OK) return st;
    return ocls_enqueue(lib, queue, p->scratch, &uses, ssao_body, &j, num_events_in_wait_list, event_wait_list, event);
}
