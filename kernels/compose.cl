/* compose.cl — the final frame from a G-buffer: albedo x (sun + sky), box-filtered, sRGB 8-bit.
 *
 * Per G-buffer sample (a pixel of the frame, or a sub-pixel with supersampling):
 *   linear = albedo.rgb * (sun.w * max(n.s, 0) * shadow                      (direct sun)
 *                          + sky.rgb * ao * (1 + n.up) / 2)                  (sky)         hit
 *   linear = background.rgb                                                                empty
 * with n the view-space shading normal (the G-buffer's normal field, or a smooth shading
 * normal bound in its place: oclshade/frames.py), s the view-space unit vector towards the
 * sun, up the view-space unit vector of world up, shadow the cast-shadow coefficient
 * (1 = lit; paper 000 eq. 1 or a screen-space pass) and ao the ambient-occlusion factor
 * (1 = unoccluded; paper 001).  Both are 1 when their option is off (absent from the program).
 * Sky: the irradiance of a uniform sky on a plane tilted by beta from the horizontal is
 * E_horizontal (1 + cos beta) / 2 (the sky dome's view factor); sky.rgb is E_horizontal.  AO
 * scales the sky term only: the sun is a point source, its occlusion is the shadow.
 * Output pixel (y, x) is the box filter of the ssaa x ssaa samples (y ssaa + j, x ssaa + k),
 * j, k = 0..ssaa-1, each clamped to [0, 1] (what the display shows of it), averaged as
 *   c0 + sum_k (c_k - c0) / ssaa^2
 * (c0 the first sample: a region of one colour keeps its value bit for bit), then encoded:
 *   out = round(255 * srgb(mean)), alpha 255.
 * With -D OCLS_LINEAR the samples are not clamped and the mean is written as linear light,
 *   out = (mean, 1)  (float4; high dynamic range: what generated cube maps store, paper 002).
 * With -D OCLS_POINT_LIGHT the light is a point light (docs/meshes.md "Point lights"): sun.xyz
 * is its view-space position L, and per sample, p the sample's view-space position,
 *   d2 = |L - p|^2,  s = (L - p) / sqrt(d2),
 *   direct = sun.w * g * max(n.s, 0) * shadow,  g = falloff / d2 if falloff > 0, else 1
 * (falloff = r0^2: sun.w is the irradiance on a plane facing the light r0 metres away,
 * inverse-square beyond; 0: no falloff); direct = 0 where d2 = 0.  Without the option the
 * program is the sun's, token for token (the sun's frames bit for bit).
 *
 * ABI
 *   compose(position, normal, albedo, width, height, ssaa, sun, sky, up, background,
 *           [falloff], [shadow], [ao], out)
 *   global size >= width * height (1-D), any local size; one work-item per output pixel.
 *     __global const float4 *position, *normal, *albedo   G-buffer fields (oclshade/gbuffer.py),
 *                              (height ssaa) x (width ssaa) samples, row-major
 *     int width, height        output size in pixels
 *     int ssaa                 samples per pixel along each axis (>= 1)
 *     float4 sun               view-space unit vector to the sun (xyz), intensity (w)
 *     float4 sky               sky irradiance on a horizontal plane (rgb)
 *     float4 up                view-space unit vector of world up (xyz)
 *     float4 background        linear colour of empty samples (rgb)
 *     float falloff            r0^2 of the point light's falloff (0: none), only with
 *                              -D OCLS_POINT_LIGHT (then sun = view-space position, intensity)
 *     __global const float *shadow   one float per sample, only with -D OCLS_SHADOW
 *     __global const float *ao       one float per sample, only with -D OCLS_AO
 *     __global uchar4 *out     width * height sRGB pixels (r, g, b, 255); with -D OCLS_LINEAR
 *                              __global float4 *out, width * height linear pixels (r, g, b, 1)
 *   -D options: OCLS_SHADOW, OCLS_AO, OCLS_LINEAR, OCLS_POINT_LIGHT (C: oclshade_compose_params
 *   point_light, linear).
 */
#include "common.h"

OCLS_INLINE float srgb_encode(float c)
{
    c = clamp(c, 0.0f, 1.0f);
    return c <= 0.0031308f ? 12.92f * c : 1.055f * exp2(log2(c) * (1.0f / 2.4f)) - 0.055f;
}

__kernel void compose(__global const float4 *position, __global const float4 *normal,
                      __global const float4 *albedo, const int width, const int height, const int ssaa,
                      const float4 sun, const float4 sky, const float4 up, const float4 background,
#ifdef OCLS_POINT_LIGHT
                      const float falloff,
#endif
#ifdef OCLS_SHADOW
                      __global const float *shadow,
#endif
#ifdef OCLS_AO
                      __global const float *ao,
#endif
#ifdef OCLS_LINEAR
                      __global float4 *out)
#else
                      __global uchar4 *out)
#endif
{
    const int i = get_global_id(0);
    if (i >= width * height) return;
    const int y = i / width, x = i - y * width, row = width * ssaa;
    float3 c0 = (float3)(0.0f), acc = (float3)(0.0f);
    for (int j = 0; j < ssaa; ++j)
        for (int k = 0; k < ssaa; ++k) {
            const int p = (y * ssaa + j) * row + x * ssaa + k;
            float3 c = background.xyz;
            if (position[p].w > 0.5f) {
                const float3 n = normal[p].xyz;
#ifdef OCLS_POINT_LIGHT
                const float3 l = sun.xyz - position[p].xyz;
                const float d2 = dot(l, l);
                float direct = 0.0f;
                if (d2 > 0.0f)
                    direct = sun.w * (falloff > 0.0f ? falloff / d2 : 1.0f) * fmax(dot(n, l / sqrt(d2)), 0.0f);
#else
                float direct = sun.w * fmax(dot(n, sun.xyz), 0.0f);
#endif
                float diffuse = 0.5f * (1.0f + dot(n, up.xyz));
#ifdef OCLS_SHADOW
                direct = direct * shadow[p];
#endif
#ifdef OCLS_AO
                diffuse = diffuse * ao[p];
#endif
                c = albedo[p].xyz * (direct + sky.xyz * diffuse);
            }
#ifndef OCLS_LINEAR
            c = clamp(c, 0.0f, 1.0f);
#endif
            if (j == 0 && k == 0) c0 = c;
            else acc = acc + (c - c0);
        }
    const float3 m = c0 + acc / (float)(ssaa * ssaa);
#ifdef OCLS_LINEAR
    out[i] = (float4)(m, 1.0f);
#else
    out[i] = (uchar4)((uchar)(255.0f * srgb_encode(m.x) + 0.5f), (uchar)(255.0f * srgb_encode(m.y) + 0.5f),
                      (uchar)(255.0f * srgb_encode(m.z) + 0.5f), (uchar)255);
#endif
}
