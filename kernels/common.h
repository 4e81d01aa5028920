/* oclshade shared kernel header.
 *
 * ABI conventions shared by every kernel file (see each file for its own
 * arguments, layouts and work sizes):
 *   - heightmaps are row-major float32 arrays (rows = north->south,
 *     cols = west->east), NaN = nodata hole;
 *   - heights handed to kernels are relative to a per-map offset chosen by the
 *     host (float64 subtraction on the host), so float32 keeps full precision
 *     for DEMs far from sea level;
 *   - extrema pyramids are one buffer of float2 (x = max, y = min) holding all
 *     levels back to back, with a table of level offsets (see pyramid.cl);
 *   - with -D OCLS_IMAGES (shadow.cl's shadow_cells / shadow_certify only) the
 *     heights are an image2d_t instead (CL_R, CL_FLOAT; texel (column, row))
 *     and the extrema pyramid an atlas image2d_t (CL_RG or CL_RGBA, CL_FLOAT;
 *     .x = max, .y = min) holding level l at columns [0, cols_l), rows
 *     [rows_off[l], rows_off[l] + rows_l); the level table then holds those row
 *     offsets.  Helpers take OCLS_HEIGHTS / OCLS_EXTREMA and read through
 *     OCLS_H_AT / OCLS_EXT_AT, so one source serves both storages;
 *   - no -cl-fast-relaxed-math; contraction into FMA is off so results do not
 *     depend on the device's FMA choices.
 */
#ifndef OCLS_COMMON_H
#define OCLS_COMMON_H

#pragma OPENCL FP_CONTRACT OFF

/* Helpers are small and called in the hot loops: some compilers (PoCL 3's
 * LLVM among them) keep plain `inline` functions out of line. */
#if defined(__clang__) || defined(__GNUC__)
#define OCLS_INLINE inline __attribute__((always_inline))
#else
#define OCLS_INLINE inline
#endif

/* floor / ceil - 1 of a float as an int without the library calls (exact for
 * |p| < 2^31). */
OCLS_INLINE int ocls_floor_int(float p)
{
    const int i = (int)p;                 /* truncates toward zero */
    return (float)i > p ? i - 1 : i;
}

OCLS_INLINE int ocls_ceil_int(float p)
{
    const int i = (int)p;
    return (float)i < p ? i + 1 : i;
}

/* Height and extrema storage: buffers (default) or images (-D OCLS_IMAGES, see
 * above).  OCLS_H_AT(h, W, r, c): sample (r, c) of a map W wide;
 * OCLS_EXT_AT(ext, off, l, Wl, r, c): texel (r, c) of pyramid level l, Wl
 * texels wide.  Images are read with unnormalised integer coordinates and
 * nearest filtering: the stored float, bit for bit (callers stay in range). */
#ifdef OCLS_IMAGES
#define OCLS_HEIGHTS __read_only image2d_t
#define OCLS_EXTREMA __read_only image2d_t
__constant sampler_t ocls_texel = CLK_NORMALIZED_COORDS_FALSE | CLK_ADDRESS_NONE | CLK_FILTER_NEAREST;
#define OCLS_H_AT(h, W, r, c) (read_imagef((h), ocls_texel, (int2)((c), (r))).x)
#define OCLS_EXT_AT(ext, off, l, Wl, r, c) (read_imagef((ext), ocls_texel, (int2)((c), (off)[l] + (r))).xy)
#else
#define OCLS_HEIGHTS __global const float *
#define OCLS_EXTREMA __global const float2 *
#define OCLS_H_AT(h, W, r, c) ((h)[(r) * (W) + (c)])
#define OCLS_EXT_AT(ext, off, l, Wl, r, c) ((ext)[(off)[l] + (r) * (Wl) + (c)])
#endif

/* Rows/cols of pyramid level l for a base grid of n0 rows (or cols): ceil(n0 / 2^l). */
OCLS_INLINE int ocls_level_extent(int n0, int l) { return ((n0 - 1) >> l) + 1; }

/* sums[idx] += term as a Kahan summation: sums[idx] is (sum, compensation), so the sum's rounding
 * does not grow with the number of terms (Kahan 1965; horizon.cl's sky-view sums, sunshine.cl's
 * beam sums) */
OCLS_INLINE void ocls_kahan_add(__global float2 *sums, int idx, float term)
{
    float2 acc = sums[idx];
    const float y = term - acc.y;          /* the term less the last rounding */
    const float s = acc.x + y;
    acc.y = (s - acc.x) - y;
    acc.x = s;
    sums[idx] = acc;
}

/* Height sample (r, c) of an H x W map; NaN outside the map. */
OCLS_INLINE float ocls_sample(OCLS_HEIGHTS h, int H, int W, int r, int c)
{
    return (r >= 0 && r < H && c >= 0 && c < W) ? OCLS_H_AT(h, W, r, c) : NAN;
}

/* Inline definitions of the OpenCL built-ins the hot loops call
 * (-D OCLS_OWN_BUILTINS: every family's own_builtins tuning knob, oclshade/tuning).
 *
 * Why: PoCL 3.0 from PyPI compiles kernels for the host CPU (znver3 on an
 * AMD EPYC) but links a built-in library compiled for another CPU (haswell),
 * and LLVM does not inline across the two targets: every isnan, select,
 * min, max, fmax, fabs, clamp, vloadN and vstoreN in the ray-packet loop was
 * a function call (about 450 call sites in shadow_cells_packet on a Zen 3;
 * objdump of the cached kernel).  Where the library does inline (the
 * targets match, or on GPUs) these definitions change nothing.
 *
 * Same results: each definition computes what the specification says for
 * every input the kernels give it: isnan is x != x; select(a, b, c) is
 * c ? b : a on scalars and per lane on the sign bit of c (the conditions
 * here are comparisons, -1 or 0, where both readings agree); fmax / fmin
 * return the non-NaN argument when one is NaN; fabs clears the sign bit;
 * integer min / max / clamp are comparisons.  The tests run every kernel
 * with the knob on and off and compare the outputs bit for bit.
 *
 * Only for compilers with clang's overloadable functions; elsewhere the knob
 * is ignored.  Each built-in is renamed by an object-like macro (so nested
 * calls do not repeat their arguments) to an overloaded inline function. */
#ifdef __clang__
#define OCLS_OVL static inline __attribute__((overloadable, always_inline))   /* also shadow.cl's gather */
#endif
#if defined(OCLS_OWN_BUILTINS) && defined(__clang__)

/* float types: isnan, fabs, fmin, fmax, clamp (vector and vector-scalar forms), select */
#define OCLS_FLOAT_BUILTINS(F, I)                                                               \
    OCLS_OVL I ocls_isnan(F x) { return x != x; }                                               \
    OCLS_OVL F ocls_fabs(F x) { return as_##F(as_##I(x) & (I)0x7fffffff); }                   \
    OCLS_OVL F ocls_fmax(F x, F y) { return ((x >= y) | (y != y)) ? x : y; }                  \
    OCLS_OVL F ocls_fmin(F x, F y) { return ((x <= y) | (y != y)) ? x : y; }                  \
    OCLS_OVL F ocls_select(F a, F b, I c) { return c ? b : a; }                               \
    OCLS_OVL F ocls_clamp(F x, F lo, F hi) { return ocls_fmin(ocls_fmax(x, lo), hi); }

#define OCLS_FLOAT_VECTOR_BUILTINS(F, I)                                                        \
    OCLS_FLOAT_BUILTINS(F, I)                                                                   \
    OCLS_OVL F ocls_fmax(F x, float y) { return ocls_fmax(x, (F)(y)); }                        \
    OCLS_OVL F ocls_fmin(F x, float y) { return ocls_fmin(x, (F)(y)); }                        \
    OCLS_OVL F ocls_clamp(F x, float lo, float hi) { return ocls_clamp(x, (F)(lo), (F)(hi)); }

/* integer types: min, max, clamp (vector and vector-scalar forms), select */
#define OCLS_INT_BUILTINS(T, S, C)                                                              \
    OCLS_OVL T ocls_min(T x, T y) { return y < x ? y : x; }                                    \
    OCLS_OVL T ocls_max(T x, T y) { return x < y ? y : x; }                                    \
    OCLS_OVL T ocls_clamp(T x, T lo, T hi) { return ocls_min(ocls_max(x, lo), hi); }           \
    OCLS_OVL T ocls_select(T a, T b, C c) { return c ? b : a; }

#define OCLS_INT_VECTOR_BUILTINS(T, S, C)                                                       \
    OCLS_INT_BUILTINS(T, S, C)                                                                  \
    OCLS_OVL T ocls_min(T x, S y) { return ocls_min(x, (T)(y)); }                              \
    OCLS_OVL T ocls_max(T x, S y) { return ocls_max(x, (T)(y)); }                              \
    OCLS_OVL T ocls_clamp(T x, S lo, S hi) { return ocls_clamp(x, (T)(lo), (T)(hi)); }

OCLS_FLOAT_BUILTINS(float, int)
OCLS_FLOAT_VECTOR_BUILTINS(float2, int2)
OCLS_FLOAT_VECTOR_BUILTINS(float4, int4)
OCLS_FLOAT_VECTOR_BUILTINS(float8, int8)
OCLS_FLOAT_VECTOR_BUILTINS(float16, int16)
OCLS_INT_BUILTINS(int, int, int)
OCLS_INT_VECTOR_BUILTINS(int2, int, int2)
OCLS_INT_VECTOR_BUILTINS(int4, int, int4)
OCLS_INT_VECTOR_BUILTINS(int8, int, int8)
OCLS_INT_VECTOR_BUILTINS(int16, int, int16)
OCLS_INT_BUILTINS(uint, uint, uint)
OCLS_INT_VECTOR_BUILTINS(uint4, uint, int4)
OCLS_INT_VECTOR_BUILTINS(uint8, uint, int8)
OCLS_INT_VECTOR_BUILTINS(uint16, uint, int16)

/* loads and stores of N lanes: one unaligned vector access through a may_alias typedef (a
 * per-lane loop spilled the vector and reloaded it lane by lane: stores 1.7x slower in
 * shadow_cells_packet on a Rocket Lake Xeon, perf annotate).  Conversions: OCLS_CONVERT_TO below. */
#define OCLS_LANE_BUILTINS(N)                                                                   \
    typedef float ocls_float_u##N __attribute__((ext_vector_type(N), aligned(4), may_alias)); \
    typedef int ocls_int_u##N __attribute__((ext_vector_type(N), aligned(4), may_alias));     \
    OCLS_OVL float##N ocls_own_vload##N(size_t i, const float *p)                                  \
    { return (float##N)(*(const ocls_float_u##N *)(p + i * N)); }                        \
    OCLS_OVL float##N ocls_own_vload##N(size_t i, __global const float *p)                         \
    { return (float##N)(*(__global const ocls_float_u##N *)(p + i * N)); }               \
    OCLS_OVL int##N ocls_own_vload##N(size_t i, const int *p)                                      \
    { return (int##N)(*(const ocls_int_u##N *)(p + i * N)); }                            \
    OCLS_OVL void ocls_own_vstore##N(float##N v, size_t i, float *p)                               \
    { *(ocls_float_u##N *)(p + i * N) = v; }                                             \
    OCLS_OVL void ocls_own_vstore##N(int##N v, size_t i, int *p)                                   \
    { *(ocls_int_u##N *)(p + i * N) = v; }                                               \
    OCLS_OVL void ocls_own_vstore##N(float##N v, size_t i, __global float *p)                      \
    { *(__global ocls_float_u##N *)(p + i * N) = v; }

OCLS_LANE_BUILTINS(4)
OCLS_LANE_BUILTINS(8)
OCLS_LANE_BUILTINS(16)

/* any (the sign bit of some lane: halves OR-ed down to one lane), clz (32 for 0, as the
 * specification says) and popcount.  Vector clz reads the exponent of the value converted to
 * float, which is floor(log2 x) exactly while the conversion is exact (x < 2^24); larger values
 * are shifted right by 8 first (then exact too).  Negative values have clz 0. */
OCLS_OVL int ocls_any(int x) { return x < 0; }
OCLS_OVL int ocls_any(int2 x) { return (x.s0 | x.s1) < 0; }
OCLS_OVL int ocls_any(int4 x) { return ocls_any(x.lo | x.hi); }
OCLS_OVL int ocls_any(int8 x) { return ocls_any(x.lo | x.hi); }
OCLS_OVL int ocls_any(int16 x) { return ocls_any(x.lo | x.hi); }
OCLS_OVL int ocls_clz(int x) { return x == 0 ? 32 : __builtin_clz((uint)x); }
OCLS_OVL int ocls_popcount(int x) { return __builtin_popcount((uint)x); }
#define OCLS_VECTOR_CLZ(I, F)                                                                   \
    OCLS_OVL I ocls_clz(I x)                                                                    \
    {                                                                                           \
        const I big = x >= (1 << 24), y = big ? x >> 8 : x;                                    \
        const I log2 = (as_##I(__builtin_convertvector(y, F)) >> 23) - 127 + (big & 8);         \
        return x < 0 ? (I)(0) : (x == 0 ? (I)(32) : 31 - log2);                                 \
    }
OCLS_VECTOR_CLZ(int4, float4)
OCLS_VECTOR_CLZ(int8, float8)
OCLS_VECTOR_CLZ(int16, float16)

#undef isnan
#define isnan ocls_isnan
#undef fabs
#define fabs ocls_fabs
#undef fmax
#define fmax ocls_fmax
#undef fmin
#define fmin ocls_fmin
#undef min
#define min ocls_min
#undef max
#define max ocls_max
#undef clamp
#define clamp ocls_clamp
#undef select
#define select ocls_select
#undef any
#define any ocls_any
#undef popcount
#define popcount ocls_popcount
#undef clz
#define clz ocls_clz

#endif

/* The N-lane load, store and vector conversion of a kernel's lane macros: ours with the knob, else the
 * built-ins (by name, built with ## from the lane count). */
#define OCLS_CAT_(a, b) a##b
#define OCLS_CAT(a, b) OCLS_CAT_(a, b)
#if defined(OCLS_OWN_BUILTINS) && defined(__clang__)
#define OCLS_LANE_FN(name, n) OCLS_CAT(ocls_own_##name, n)
#define OCLS_CONVERT_TO(T, x) __builtin_convertvector((x), T)   /* the default roundings: rte, rtz */
#else
#define OCLS_LANE_FN(name, n) OCLS_CAT(name, n)
#define OCLS_CONVERT_TO(T, x) OCLS_CAT(convert_, T)(x)
#endif

/* Surface gradient (dz/d(east), dz/d(south)) at sample (i, j) of an H x W map:
 * central differences, one-sided next to holes and at the edges, 0 along an
 * axis with neither neighbour; cell = (dx, dy) in metres.  The surface normal
 * is then (-gx, gy, 1) in (east, north, up), and the sun s = (east, north,
 * up) is above the tangent plane iff s.z - gx s.x + gy s.y > 0 (the
 * self-shadow test of shadow.cl and the facing test of sunshine.cl). */
OCLS_INLINE float2 ocls_gradient(OCLS_HEIGHTS h, int H, int W, int i, int j, float2 cell)
{
    const float hc = OCLS_H_AT(h, W, i, j);
    const float he = ocls_sample(h, H, W, i, j + 1), hw = ocls_sample(h, H, W, i, j - 1);
    const float hs = ocls_sample(h, H, W, i + 1, j), hn = ocls_sample(h, H, W, i - 1, j);
    float gx = 0.0f, gy = 0.0f;
    if (!isnan(he) && !isnan(hw)) gx = (he - hw) / (2.0f * cell.x);
    else if (!isnan(he)) gx = (he - hc) / cell.x;
    else if (!isnan(hw)) gx = (hc - hw) / cell.x;
    if (!isnan(hs) && !isnan(hn)) gy = (hs - hn) / (2.0f * cell.y);
    else if (!isnan(hs)) gy = (hs - hc) / cell.y;
    else if (!isnan(hn)) gy = (hc - hn) / cell.y;
    return (float2)(gx, gy);
}

#endif
