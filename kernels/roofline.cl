/* roofline.cl — the two probes of `oclshade bench` (oclshade/bench/roofline.py):
 * the device's global-memory bandwidth and its arithmetic rate, in the manner
 * of clpeak (small kernels, many launches, the best batch counts).
 *
 * ABI (int arguments are 32-bit ints)
 *   roofline_copy(src, dst, n)             global >= n (1-D), any local size
 *       __global const float4 *src         n float4 read, one per work-item
 *       __global float4 *dst               n float4 written: dst[i] = src[i]
 *       The host counts 32 bytes moved per work-item (16 read + 16 written,
 *       the STREAM "copy" convention).
 *   roofline_mad(out, a, b, iterations)    global = any multiple of the local size
 *       __global float *out                one float per work-item (the sum of
 *                                          its accumulators, so nothing is dead code)
 *       float a, b                         x <- mad(x, a, b); the host passes
 *                                          a = 0.999, b = 0.001 (values stay near 1)
 *       int iterations                     loop trips per work-item
 *       Each trip does 8 independent mad()s (8 chains, MAD_CHAINS on the host)
 *       on RL_WIDTH-wide vectors, so a work-item does iterations * 8 * RL_WIDTH
 *       multiply-adds, counted as 2 flops each.
 *   -D options: RL_WIDTH = 1, 2, 4, 8 or 16 (vector width of roofline_mad's
 *   accumulators, default 4); RL_SPLIT: x * a + b as a separate multiply and
 *   add instead of mad().  The host builds with -cl-std=CL1.2, tries several
 *   widths with and without RL_SPLIT, and keeps the fastest.
 *
 * Arithmetic: the project's kernels forbid contraction (common.h:
 * FP_CONTRACT OFF) so that results do not depend on the device's FMA choices.
 * This probe measures a peak rate instead, so it asks for mad() explicitly:
 * mad lets a device use its fastest multiply-add (a fused FMA on current CPUs
 * and GPUs).  RL_SPLIT is there because a driver may not: PyPI's PoCL 3.0
 * runs mad() and fma() about 5x slower than a multiply and an add (measured
 * on an AMD EPYC, znver3 target).  Either way a multiply-add counts 2 flops.
 * The result is never compared.
 */
#include "common.h"

#ifndef RL_WIDTH
#define RL_WIDTH 4
#endif

#if RL_WIDTH == 1
#define RL_FLOAT float
#define RL_SUM(v) (v)
#elif RL_WIDTH == 2
#define RL_FLOAT float2
#define RL_SUM(v) ((v).s0 + (v).s1)
#elif RL_WIDTH == 4
#define RL_FLOAT float4
#define RL_SUM(v) ((v).s0 + (v).s1 + (v).s2 + (v).s3)
#elif RL_WIDTH == 8
#define RL_FLOAT float8
#define RL_SUM(v) ((v).s0 + (v).s1 + (v).s2 + (v).s3 + (v).s4 + (v).s5 + (v).s6 + (v).s7)
#elif RL_WIDTH == 16
#define RL_FLOAT float16
#define RL_SUM(v) (RL_SUM8((v).lo) + RL_SUM8((v).hi))
#define RL_SUM8(v) ((v).s0 + (v).s1 + (v).s2 + (v).s3 + (v).s4 + (v).s5 + (v).s6 + (v).s7)
#else
#error "RL_WIDTH must be 1, 2, 4, 8 or 16"
#endif

__kernel void roofline_copy(__global const float4 *src, __global float4 *dst, const int n)
{
    const int i = get_global_id(0);
    if (i < n) dst[i] = src[i];
}

#ifdef RL_SPLIT
#define RL_MAD(x, a, b) ((x) * (a) + (b))     /* FP_CONTRACT OFF: a multiply, then an add */
#else
#define RL_MAD(x, a, b) mad((x), (a), (b))
#endif

__kernel void roofline_mad(__global float *out, const float a, const float b, const int iterations)
{
    const int i = get_global_id(0);
    const RL_FLOAT va = (RL_FLOAT)(a), vb = (RL_FLOAT)(b);
    /* eight independent chains: enough to cover the multiply-add latency of CPUs and GPUs */
    RL_FLOAT x0 = (RL_FLOAT)((float)(i & 255) * 1e-3f), x1 = x0 + 0.1f, x2 = x0 + 0.2f, x3 = x0 + 0.3f;
    RL_FLOAT x4 = x0 + 0.4f, x5 = x0 + 0.5f, x6 = x0 + 0.6f, x7 = x0 + 0.7f;
    for (int k = 0; k < iterations; ++k) {
        x0 = RL_MAD(x0, va, vb); x1 = RL_MAD(x1, va, vb); x2 = RL_MAD(x2, va, vb); x3 = RL_MAD(x3, va, vb);
        x4 = RL_MAD(x4, va, vb); x5 = RL_MAD(x5, va, vb); x6 = RL_MAD(x6, va, vb); x7 = RL_MAD(x7, va, vb);
    }
    out[i] = RL_SUM(x0 + x1 + x2 + x3 + x4 + x5 + x6 + x7);
}
