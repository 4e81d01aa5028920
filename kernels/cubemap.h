/* cubemap.h — cube-map lookups shared by envmap.cl and reflect.cl (paper 002).
 *
 * Frame and face table (docs/reflections.md; float64 twin oclshade/reference/envmap.py).
 * Directions are in the cube-map frame F (right-handed, +Y up).  Face f = 0..5 is
 * +X, -X, +Y, -Y, +Z, -Z: the axis of the largest |component| of d (ties: x before y before
 * z) and its sign (OpenGL's major-axis rule); with ma that |component|:
 *     face  sc   tc          s = (sc / ma + 1) / 2   column coordinate, 0 = left edge
 *     +X    -z   -y          t = (tc / ma + 1) / 2   row coordinate, 0 = top edge
 *     -X    +z   -y
 *     +Y    +x   +z
 *     -Y    +x   -z
 *     +Z    +x   -y
 *     -Z    -x   -y
 * Texel (row i, col j) of an N x N face has its centre at s = (j + 0.5) / N, t = (i + 0.5) / N.
 *
 * Bordered layout (the only cube-map layout the kernels read): 6 faces of (N + 2) x (N + 2)
 * float4 texels back to back (rgb, a unused), face f at f (N + 2)^2, texel (i, j) of the face
 * (i, j in -1..N) at (i + 1)(N + 2) + j + 1.  Rows and columns -1 and N are a one-texel
 * border copied from the neighbouring faces by cube_border (envmap.cl): a border texel holds
 * the texel of the face its centre direction falls on, nearest to that direction (the texel
 * across the seam at the same place along it); a border corner holds the mean of the three
 * faces' texels at that cube corner.  Bilinear filtering with the border is then continuous
 * across seams: on a seam both faces blend the same two texels with weights 1/2.
 */
#ifndef OCLS_CUBEMAP_H
#define OCLS_CUBEMAP_H
#include "common.h"

/* Face of direction d and its (s, t) by the table above. */
OCLS_INLINE int ocls_cube_face(float3 d, float *s, float *t)
{
    const float ax = fabs(d.x), ay = fabs(d.y), az = fabs(d.z);
    int face;
    float ma, sc, tc;
    if (ax >= ay && ax >= az) {
        face = d.x > 0.0f ? 0 : 1; ma = ax; sc = d.x > 0.0f ? -d.z : d.z; tc = -d.y;
    } else if (ay >= az) {
        face = d.y > 0.0f ? 2 : 3; ma = ay; sc = d.x; tc = d.y > 0.0f ? d.z : -d.z;
    } else {
        face = d.z > 0.0f ? 4 : 5; ma = az; sc = d.z > 0.0f ? d.x : -d.x; tc = -d.y;
    }
    *s = 0.5f * (sc / ma + 1.0f);
    *t = 0.5f * (tc / ma + 1.0f);
    return face;
}

/* The direction (on the cube, not normalised) of (face, s, t); s, t may leave [0, 1]. */
OCLS_INLINE float3 ocls_cube_direction(int f, float s, float t)
{
    const float sc = 2.0f * s - 1.0f, tc = 2.0f * t - 1.0f;
    switch (f) {
    case 0: return (float3)(1.0f, -tc, -sc);
    case 1: return (float3)(-1.0f, -tc, sc);
    case 2: return (float3)(sc, 1.0f, tc);
    case 3: return (float3)(sc, -1.0f, -tc);
    case 4: return (float3)(sc, -tc, 1.0f);
    default: return (float3)(-sc, -tc, -1.0f);
    }
}

/* Bilinear sample of a bordered cube map of N x N faces in direction d (any length > 0). */
OCLS_INLINE float4 ocls_cube_sample(__global const float4 *cube, int n, float3 d)
{
    float s, t;
    const int f = ocls_cube_face(d, &s, &t);
    const float u = s * (float)n - 0.5f, v = t * (float)n - 0.5f;
    const int j0 = clamp(ocls_floor_int(u), -1, n - 1), i0 = clamp(ocls_floor_int(v), -1, n - 1);
    const float fu = u - (float)j0, fv = v - (float)i0;
    const int m = n + 2;
    __global const float4 *p = cube + f * m * m + (i0 + 1) * m + (j0 + 1);
    return (p[0] * (1.0f - fu) + p[1] * fu) * (1.0f - fv) + (p[m] * (1.0f - fu) + p[m + 1] * fu) * fv;
}

#endif
