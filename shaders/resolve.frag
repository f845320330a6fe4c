#version 330 core
// Box-filter downsample of the n x n supersampled, premultiplied linear image, then either
// composite over the background (opaque) or un-premultiply (transparent). Writes linear colour
// to an RGBA16F target; the renderer encodes sRGB on the CPU with exact tables (cheaper than
// three pow() per pixel on llvmpipe). Pixels with no coverage get alpha -1: the CPU writes the
// background there exactly.
// DGV_FACTOR (n, 1..4) is compiled in. For even n the box is summed from bilinear samples at
// the centres of 2x2 texel blocks (weights exactly 1/4 each: the same box filter), because on
// llvmpipe one filtered sample costs less than four texelFetch calls (measured: 111-142 ms vs
// 155-173 ms for the 1080p resolve under the same load; docs/rendering.md).
#ifndef DGV_FACTOR
#define DGV_FACTOR 2
#endif
uniform sampler2D uColour;        // GL_LINEAR, clamp to edge
uniform sampler2D uGround;        // the ground at output size (premultiplied), when uHasGround
uniform int uHasGround;
uniform int uTransparent;
uniform vec3 uBackground;         // linear

out vec4 fragColour;

void main() {
    ivec2 base = ivec2(gl_FragCoord.xy) * DGV_FACTOR;
#if DGV_FACTOR == 2
    vec4 s = texture(uColour, (vec2(base) + 1.0) / vec2(textureSize(uColour, 0)));
#elif DGV_FACTOR == 4
    vec2 texel = 1.0 / vec2(textureSize(uColour, 0));
    vec2 c = vec2(base) + 1.0;
    vec4 s = 0.25 * (texture(uColour, c * texel) + texture(uColour, (c + vec2(2.0, 0.0)) * texel)
                   + texture(uColour, (c + vec2(0.0, 2.0)) * texel) + texture(uColour, (c + 2.0) * texel));
#else
    vec4 sum = vec4(0.0);
    for (int j = 0; j < DGV_FACTOR; ++j)
        for (int i = 0; i < DGV_FACTOR; ++i) sum += texelFetch(uColour, base + ivec2(i, j), 0);
    vec4 s = sum / float(DGV_FACTOR * DGV_FACTOR);
#endif
    if (uHasGround != 0) s += (1.0 - min(s.a, 1.0)) * texelFetch(uGround, ivec2(gl_FragCoord.xy), 0);
    if (s.a <= 0.0) {  // nothing drawn here: the CPU writes the background exactly
        fragColour = vec4(0.0, 0.0, 0.0, -1.0);
        return;
    }
    vec3 c3;
    float a;
    if (uTransparent != 0) {
        a = min(s.a, 1.0);
        c3 = s.rgb / s.a;
    } else {
        a = 1.0;
        c3 = s.rgb + (1.0 - min(s.a, 1.0)) * uBackground;
    }
    fragColour = vec4(c3, a);  // linear; sRGB-encoded on the CPU
}
