/* compose.cl — the final frame from a G-buffer: albedo x (sun + sky), sRGB 8-bit.
 *
 *   linear = albedo.rgb * (sun.w * max(dot(n, s), 0) * shadow + sky.rgb * ao)    (hit pixels)
 *   linear = background.rgb                                                       (empty pixels)
 *   out    = round(255 * srgb(clamp(linear, 0, 1))), alpha 255
 * with n the view-space normal, s the view-space unit vector towards the sun,
 * shadow the shadow coefficient (1 = lit; paper 000 eq. 1 or a screen-space
 * pass) and ao the ambient-occlusion factor (1 = unoccluded; paper 001).
 * Both are 1 when their option is off (absent from the program).
 *
 * ABI
 *   compose(position, normal, albedo, n, sun, sky, background, [shadow], [ao], out)
 *   global size >= n (1-D), any local size; one work-item per pixel.
 *     __global const float4 *position, *normal, *albedo   G-buffer fields (oclshade/gbuffer.py)
 *     int n                    pixel count
 *     float4 sun               view-space unit vector to the sun (xyz), intensity (w)
 *     float4 sky               ambient sky radiance (rgb)
 *     float4 background        linear colour of empty pixels (rgb)
 *     __global const float *shadow   n floats, only with -D OCLS_SHADOW
 *     __global const float *ao       n floats, only with -D OCLS_AO
 *     __global uchar4 *out     n sRGB pixels (r, g, b, 255)
 *   -D options: OCLS_SHADOW, OCLS_AO.
 */
#include "common.h"

OCLS_INLINE float srgb_encode(float c)
{
    c = clamp(c, 0.0f, 1.0f);
    return c <= 0.0031308f ? 12.92f * c : 1.055f * exp2(log2(c) * (1.0f / 2.4f)) - 0.055f;
}

__kernel void compose(__global const float4 *position, __global const float4 *normal,
                      __global const float4 *albedo, const int n, const float4 sun, const float4 sky,
                      const float4 background,
#ifdef OCLS_SHADOW
                      __global const float *shadow,
#endif
#ifdef OCLS_AO
                      __global const float *ao,
#endif
                      __global uchar4 *out)
{
    const int i = get_global_id(0);
    if (i >= n) return;
    float3 c = background.xyz;
    if (position[i].w > 0.5f) {
        float lit = sun.w * fmax(dot(normal[i].xyz, sun.xyz), 0.0f);
        float amb = 1.0f;
#ifdef OCLS_SHADOW
        lit = lit * shadow[i];
#endif
#ifdef OCLS_AO
        amb = ao[i];
#endif
        c = albedo[i].xyz * (lit + sky.xyz * amb);
    }
    out[i] = (uchar4)((uchar)(255.0f * srgb_encode(c.x) + 0.5f), (uchar)(255.0f * srgb_encode(c.y) + 0.5f),
                      (uchar)(255.0f * srgb_encode(c.z) + 0.5f), (uchar)255);
}
