#version 330 core
// Box-filter downsample of the n x n supersampled, premultiplied linear image, then either
// composite over the background (opaque) or un-premultiply (transparent), then encode with the
// exact sRGB curve. Writes to an RGBA16 (unorm) target that is read back as 16-bit samples.
uniform sampler2D uColour;
uniform int uFactor;
uniform int uTransparent;
uniform vec3 uBackground;         // linear
uniform vec4 uBackgroundEncoded;  // sRGB-encoded on the CPU (exact), alpha 1

out vec4 fragColour;

float encodeSrgb(float x) {
    x = clamp(x, 0.0, 1.0);
    return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

void main() {
    ivec2 base = ivec2(gl_FragCoord.xy) * uFactor;
    vec4 sum = vec4(0.0);
    for (int j = 0; j < uFactor; ++j)
        for (int i = 0; i < uFactor; ++i) sum += texelFetch(uColour, base + ivec2(i, j), 0);
    vec4 s = sum / float(uFactor * uFactor);
    if (s.a <= 0.0) {  // nothing drawn here: the background exactly
        fragColour = uTransparent != 0 ? vec4(0.0) : uBackgroundEncoded;
        return;
    }
    vec3 c;
    float a;
    if (uTransparent != 0) {
        a = min(s.a, 1.0);
        c = s.rgb / s.a;
    } else {
        a = 1.0;
        c = s.rgb + (1.0 - min(s.a, 1.0)) * uBackground;
    }
    fragColour = vec4(encodeSrgb(c.r), encodeSrgb(c.g), encodeSrgb(c.b), a);
}
