/* envmap.cl — environment maps: the cube map's seam border, lat-long <-> cube conversion.
 *
 * Frames, face table and the bordered cube layout: cubemap.h.  Lat-long maps (H rows x W
 * columns, float4 rgb_, row-major from the top row): texel (r, c) has its centre at
 * longitude lon = pi - 2 pi (c + 0.5) / W, latitude lat = pi/2 - pi (r + 0.5) / H, direction
 * (sin lon cos lat, sin lat, cos lon cos lat) in the cube-map frame; bilinear filtering wraps
 * in longitude and clamps rows at the poles.  Float64 twin: oclshade/reference/envmap.py.
 *
 * ABI
 *   cube_border(cube, n)
 *     __global float4 *cube   bordered cube map (cubemap.h) whose face interiors are filled;
 *                             the kernel writes the borders (reads interiors only)
 *     int n                   face size N
 *     global size (>= N + 2, 4, 6): (position along the side, side, face); sides 0, 1 are
 *     rows -1 and N (corners included), sides 2, 3 columns -1 and N (rows 0..N-1)
 *   latlong_to_cube(ll, H, W, cube, n)
 *     __global const float4 *ll   lat-long map, H x W
 *     __global float4 *cube       bordered cube map: the kernel writes the face interiors
 *                                 (run cube_border after it)
 *     global size (>= N, >= N, 6): (column, row, face); each texel is the lat-long map's
 *     bilinear sample in the direction of the texel's centre
 *   cube_to_latlong(cube, n, ll, H, W)
 *     __global const float4 *cube bordered cube map with its border
 *     __global float4 *ll         lat-long map out, H x W: each texel the cube map's
 *                                 seam-continuous bilinear sample in its centre's direction
 *     global size (>= W, >= H)
 *   cube_face_store(frame, n, face, cube)
 *     __global const float4 *frame  an N x N frame (row-major, float4 linear rgb_) of the camera
 *                             that looks along face `face` (oclshade/scene/generate.py)
 *     int n, face             face size N, face index 0..5
 *     __global float4 *cube   bordered cube map: texel (r, c) of the face's interior gets frame
 *                             pixel (r, N - 1 - c) (the face table's mirror image of a
 *                             right-handed camera's view); run cube_border after the six faces
 *     global size (>= N, >= N): (column, row)
 *   No -D options; build with -cl-std=CL1.2 (no fast-math).
 */
#include "cubemap.h"

#define OCLS_PI 3.14159265358979323846f

/* Interior texel of face f nearest to the direction of tap (i, j) of face g, one step
 * outside g (the texel across the seam). */
OCLS_INLINE float4 across_seam(__global const float4 *cube, int n, int g, int i, int j)
{
    float s, t;
    const int f = ocls_cube_face(ocls_cube_direction(g, ((float)j + 0.5f) / (float)n,
                                                     ((float)i + 0.5f) / (float)n), &s, &t);
    const int fi = clamp(ocls_floor_int(t * (float)n), 0, n - 1), fj = clamp(ocls_floor_int(s * (float)n), 0, n - 1);
    const int m = n + 2;
    return cube[f * m * m + (fi + 1) * m + fj + 1];
}

__kernel void cube_border(__global float4 *cube, const int n)
{
    const int k = get_global_id(0), side = get_global_id(1), f = get_global_id(2);
    if (k >= n + 2 || side >= 4 || f >= 6) return;
    int i, j;
    if (side < 2) {
        i = side == 0 ? -1 : n;
        j = k - 1;
    } else {
        if (k < 1 || k > n) return;
        i = k - 1;
        j = side == 2 ? -1 : n;
    }
    const int m = n + 2, out_i = i < 0 || i >= n, out_j = j < 0 || j >= n;
    float4 value;
    if (out_i && out_j) {
        const int ci = clamp(i, 0, n - 1), cj = clamp(j, 0, n - 1);
        value = (cube[f * m * m + (ci + 1) * m + cj + 1] + across_seam(cube, n, f, i, cj)
                 + across_seam(cube, n, f, ci, j)) / 3.0f;
    } else {
        value = across_seam(cube, n, f, i, j);
    }
    cube[f * m * m + (i + 1) * m + j + 1] = value;
}

__kernel void latlong_to_cube(__global const float4 *ll, const int H, const int W, __global float4 *cube,
                              const int n)
{
    const int j = get_global_id(0), i = get_global_id(1), f = get_global_id(2);
    if (j >= n || i >= n || f >= 6) return;
    const float3 d = ocls_cube_direction(f, ((float)j + 0.5f) / (float)n, ((float)i + 0.5f) / (float)n);
    const float lon = atan2(d.x, d.z), lat = atan2(d.y, hypot(d.x, d.z));
    const float u = (OCLS_PI - lon) / (2.0f * OCLS_PI) * (float)W - 0.5f;
    const float v = (0.5f * OCLS_PI - lat) / OCLS_PI * (float)H - 0.5f;
    const int j0 = ocls_floor_int(u), i0 = ocls_floor_int(v);
    const float fu = u - (float)j0, fv = v - (float)i0;
    const int ja = ((j0 % W) + W) % W, jb = (ja + 1) % W;
    const int ia = clamp(i0, 0, H - 1), ib = clamp(i0 + 1, 0, H - 1);
    const float4 value = (ll[ia * W + ja] * (1.0f - fu) + ll[ia * W + jb] * fu) * (1.0f - fv)
                         + (ll[ib * W + ja] * (1.0f - fu) + ll[ib * W + jb] * fu) * fv;
    const int m = n + 2;
    cube[f * m * m + (i + 1) * m + j + 1] = value;
}

__kernel void cube_to_latlong(__global const float4 *cube, const int n, __global float4 *ll, const int H,
                              const int W)
{
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= W || r >= H) return;
    const float lon = OCLS_PI - 2.0f * OCLS_PI * ((float)c + 0.5f) / (float)W;
    const float lat = 0.5f * OCLS_PI - OCLS_PI * ((float)r + 0.5f) / (float)H;
    const float3 d = (float3)(sin(lon) * cos(lat), sin(lat), cos(lon) * cos(lat));
    ll[r * W + c] = ocls_cube_sample(cube, n, d);
}

__kernel void cube_face_store(__global const float4 *frame, const int n, const int face, __global float4 *cube)
{
    const int c = get_global_id(0), r = get_global_id(1);
    if (c >= n || r >= n || face < 0 || face >= 6) return;
    const int m = n + 2;
    cube[face * m * m + (r + 1) * m + c + 1] = frame[r * n + (n - 1 - c)];
}
