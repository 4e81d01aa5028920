/* reflect.cl — environment reflections through a cube map (paper 002), applied around compose.
 *
 * Written in paper 002's meta-language: the host resolves the @IF blocks with
 * oclshade.specialize.specialize(source, vector) before compiling, one program per condition
 * vector (a material's, oclshade/envmap/materials.py), so a feature no object uses is in no
 * program.  Conditions:
 *   REFLECT     the object reflects the environment (mirror, glossy)
 *   FRESNEL     Schlick-weighted (glossy): F = F0 + (1 - F0)(1 - cos)^5, cos = -U.N, the
 *               reflection tint x F x E and the diffuse part kept with weight 1 - F; without
 *               it (a mirror) the reflection is tint x E and the diffuse part is removed
 *   ROUGH       E is the mean over 16 directions in a cone around R when the object's cone
 *               is > 0 (else one lookup)
 *   BACKGROUND  empty samples show the environment in their view direction (a vector of its
 *               own: its program serves the empty samples, no object)
 *
 * Frames (docs/reflections.md): U = the unit vector from the eye to the sample (view space;
 * (0, 0, -1) for an orthographic camera), N its view-space normal; R = U - 2 (N.U) N in view
 * space; to the object's world-aligned frame by the inverse view rotation (its transpose,
 * rows v2w); to the cube-map frame by the environment's rotation (rows w2c); face and (s, t)
 * by the major-axis rule, bilinear across seams (cubemap.h).
 *
 * Passes (the frame's colour = compose's diffuse colour + the reflection):
 *   reflect_weights  before compose: the albedo compose reads, weighted by what the
 *                    diffuse part keeps: 1 - F (glossy) or 0 (mirror) on the objects of the
 *                    vector's material group; the host copies the albedo first
 *   reflect_apply    after compose: acc[pixel] += (1/ssaa^2) sum over the pixel's samples of
 *                    the group: tint x F x E (F = 1 without FRESNEL); BACKGROUND:
 *                    sum over its empty samples of E(view direction)
 *   reflect_finish   out = encode(decode(frame) + acc) where acc > 0, frame kept elsewhere
 *                    (8-bit sRGB in and out; the reflection is exact in linear light before
 *                    that rounding)
 *
 * ABI (n = width * height output pixels; samples (height ssaa) x (width ssaa), row-major)
 *   reflect_weights(ns, position, normal, albedo, object, mat, group, cam, albedo_out)
 *     int ns                              sample count; global size >= ns (1-D)
 *     __global const float4 *position, *normal, *albedo   G-buffer fields (oclshade/gbuffer.py)
 *     __global const int *object          object id per sample (index + 1, 0 none)
 *     __global const float4 *mat          3 float4 per object: (colour rgb, F0),
 *                                         (tan of the cone's half-angle, group, 0, 0),
 *                                         (reflection tint rgb, index of its cube map)
 *     int group                           the material group this program serves
 *     float4 cam                          as for reflect_apply
 *     __global float4 *albedo_out         written on the group's samples only
 *   reflect_apply(width, height, ssaa, position, normal, object, mat, group, cam, v2w0, v2w1,
 *                 v2w2, w2c0, w2c1, w2c2, cube, n_cube, intensity, acc)
 *     int width, height, ssaa             output size, samples per pixel along each axis
 *     float4 cam                          (sx, sy, orthographic ? 1 : 0, 0): pixel-ray slopes
 *     float4 v2w0..2                      rows of the view -> world rotation (xyz)
 *     float4 w2c0..2                      rows of the world -> cube-map rotation (xyz)
 *     __global const float4 *cube         bordered cube maps (cubemap.h) of n_cube x n_cube faces
 *                                         back to back, 6 (n_cube + 2)^2 float4 each: an object
 *                                         reads the one its mat row gives (a map generated from
 *                                         its centre, or 0: the scene's), BACKGROUND map 0
 *     float intensity                     scale of the environment's values
 *     __global float4 *acc                n pixels, linear rgb; the host zeroes it per frame
 *     global size >= n (1-D)
 *   reflect_finish(n, frame, acc, out)
 *     __global const uchar4 *frame        compose's n sRGB pixels;  __global uchar4 *out
 *   Build: specialise, then -cl-std=CL1.2 (no fast-math).
 */
#include "cubemap.h"

#define OCLS_CONE_SAMPLES 16
#define OCLS_GOLDEN_ANGLE 2.39996322972865332f

/* compose.cl's encoding (the same formula) and its inverse */
OCLS_INLINE float srgb_encode(float c)
{
    c = clamp(c, 0.0f, 1.0f);
    return c <= 0.0031308f ? 12.92f * c : 1.055f * exp2(log2(c) * (1.0f / 2.4f)) - 0.055f;
}

OCLS_INLINE float srgb_decode(float c)
{
    return c <= 0.04045f ? c / 12.92f : exp2(log2((c + 0.055f) / 1.055f) * 2.4f);
}

OCLS_INLINE float schlick(float f0, float cosine)
{
    const float m = 1.0f - clamp(cosine, 0.0f, 1.0f), m2 = m * m;
    return f0 + (1.0f - f0) * (m2 * m2 * m);
}

/* U: the unit vector from the eye to the sample */
OCLS_INLINE float3 eye_to(float3 p, float4 cam)
{
    return cam.z != 0.0f ? (float3)(0.0f, 0.0f, -1.0f) : normalize(p);
}

/* a view-space direction through the chain view -> world (object world-aligned) -> cube map */
OCLS_INLINE float3 to_cube(float3 r, float4 v2w0, float4 v2w1, float4 v2w2, float4 w2c0, float4 w2c1, float4 w2c2)
{
    const float3 w = (float3)(dot(v2w0.xyz, r), dot(v2w1.xyz, r), dot(v2w2.xyz, r));
    return (float3)(dot(w2c0.xyz, w), dot(w2c1.xyz, w), dot(w2c2.xyz, w));
}

__kernel void reflect_weights(const int ns, __global const float4 *position, __global const float4 *normal,
                              __global const float4 *albedo, __global const int *object,
                              __global const float4 *mat, const int group, const float4 cam,
                              __global float4 *albedo_out)
{
    const int i = get_global_id(0);
    if (i >= ns) return;
    const int obj = object[i];
    if (obj <= 0 || (int)mat[3 * obj - 2].y != group) return;
@IF REFLECT;
@IF FRESNEL;
    const float3 n = normal[i].xyz, u = eye_to(position[i].xyz, cam);
    albedo_out[i] = (float4)(albedo[i].xyz * (1.0f - schlick(mat[3 * obj - 3].w, -dot(u, n))), albedo[i].w);
@ELSE;
    albedo_out[i] = (float4)(0.0f, 0.0f, 0.0f, albedo[i].w);
@ENDIF;
@ENDIF;
}

__kernel void reflect_apply(const int width, const int height, const int ssaa, __global const float4 *position,
                            __global const float4 *normal, __global const int *object,
                            __global const float4 *mat, const int group, const float4 cam,
                            const float4 v2w0, const float4 v2w1, const float4 v2w2,
                            const float4 w2c0, const float4 w2c1, const float4 w2c2,
                            __global const float4 *cube, const int n_cube, const float intensity,
                            __global float4 *acc)
{
    const int i = get_global_id(0);
    if (i >= width * height) return;
    const int y = i / width, x = i - y * width, row = width * ssaa, sw = width * ssaa, sh = height * ssaa;
    float3 sum = (float3)(0.0f);
    for (int j = 0; j < ssaa; ++j)
        for (int k = 0; k < ssaa; ++k) {
            const int sy = y * ssaa + j, sx = x * ssaa + k, p = sy * row + sx;
            const int obj = object[p];
@IF BACKGROUND;
            if (position[p].w > 0.5f) continue;
            const float nx = (2.0f * (float)sx + 1.0f) / (float)sw - 1.0f;
            const float ny = 1.0f - (2.0f * (float)sy + 1.0f) / (float)sh;
            const float3 view_dir = cam.z != 0.0f ? (float3)(0.0f, 0.0f, -1.0f) : (float3)(nx * cam.x, ny * cam.y, -1.0f);
            sum += ocls_cube_sample(cube, n_cube, to_cube(view_dir, v2w0, v2w1, v2w2, w2c0, w2c1, w2c2)).xyz;
@ENDIF;
@IF REFLECT;
            if (obj <= 0 || (int)mat[3 * obj - 2].y != group) continue;
            const float3 n = normal[p].xyz, u = eye_to(position[p].xyz, cam);
            const float3 r = u - 2.0f * dot(n, u) * n;                         /* view space */
            const float3 rc = to_cube(r, v2w0, v2w1, v2w2, w2c0, w2c1, w2c2);
            __global const float4 *own = cube + (int)mat[3 * obj - 1].w * 6 * (n_cube + 2) * (n_cube + 2);
@IF ROUGH;
            /* a cone around rc: tangent frame (Duff et al. 2017), 16 points of a Vogel spiral */
            const float cone = mat[3 * obj - 2].x;
            float3 env = (float3)(0.0f);
            if (cone > 0.0f) {
                const float3 d = normalize(rc);
                const float sgn = d.z >= 0.0f ? 1.0f : -1.0f, a = -1.0f / (sgn + d.z), b = d.x * d.y * a;
                const float3 t1 = (float3)(1.0f + sgn * d.x * d.x * a, sgn * b, -sgn * d.x);
                const float3 t2 = (float3)(b, sgn + d.y * d.y * a, -d.y);
                for (int s = 0; s < OCLS_CONE_SAMPLES; ++s) {
                    const float rad = cone * sqrt(((float)s + 0.5f) / (float)OCLS_CONE_SAMPLES);
                    const float phi = (float)s * OCLS_GOLDEN_ANGLE;
                    env += ocls_cube_sample(own, n_cube, d + rad * (cos(phi) * t1 + sin(phi) * t2)).xyz;
                }
                env = env / (float)OCLS_CONE_SAMPLES;
            } else {
                env = ocls_cube_sample(own, n_cube, rc).xyz;
            }
@ELSE;
            const float3 env = ocls_cube_sample(own, n_cube, rc).xyz;
@ENDIF;
@IF FRESNEL;
            sum += schlick(mat[3 * obj - 3].w, -dot(u, n)) * mat[3 * obj - 1].xyz * env;
@ELSE;
            sum += mat[3 * obj - 1].xyz * env;
@ENDIF;
@ENDIF;
        }
    acc[i] = acc[i] + (float4)(intensity * sum / (float)(ssaa * ssaa), 0.0f);
}

__kernel void reflect_finish(const int n, __global const uchar4 *frame, __global const float4 *acc,
                             __global uchar4 *out)
{
    const int i = get_global_id(0);
    if (i >= n) return;
    const uchar4 f = frame[i];
    const float4 a = acc[i];
    if (!(a.x > 0.0f || a.y > 0.0f || a.z > 0.0f)) {
        out[i] = f;
        return;
    }
    const float3 c = (float3)(srgb_decode((float)f.x / 255.0f), srgb_decode((float)f.y / 255.0f),
                              srgb_decode((float)f.z / 255.0f)) + a.xyz;
    out[i] = (uchar4)((uchar)(255.0f * srgb_encode(c.x) + 0.5f), (uchar)(255.0f * srgb_encode(c.y) + 0.5f),
                      (uchar)(255.0f * srgb_encode(c.z) + 0.5f), f.w);
}
