// Shared by mesh.frag and ground.frag (the renderer inserts this file after their #version line).
// Linear light throughout. Directions point from the surface towards the light (world space).
// DGV_SHADOWS 0 compiles the shadow lookup out (the renderer draws the part of the ground that
// no shadow can reach with that variant: on llvmpipe every PCF tap costs on every fragment).
// DGV_QUAD_PCF 1 (the supersampled mesh pass, n >= 2): the fragments of each 2x2 quad share
// their PCF taps through fine derivatives, two taps each instead of four (keyVisibility).
#ifndef DGV_SHADOWS
#define DGV_SHADOWS 1
#endif
#ifndef DGV_QUAD_PCF
#define DGV_QUAD_PCF 0
#endif
#if DGV_QUAD_PCF
#extension GL_ARB_derivative_control : require
#endif

uniform vec3 uKeyDir;
uniform vec3 uKeyColour;
uniform vec3 uFillDir;
uniform vec3 uFillColour;
uniform vec3 uRimDir;
uniform vec3 uRimColour;
uniform vec3 uSkyColour;     // hemisphere ambient, from above
uniform vec3 uBounceColour;  // hemisphere ambient, from below

uniform sampler2DShadow uShadowMap;
uniform mat4 uShadowFromWorld;  // world -> [0,1]^3 shadow-map coordinates (orthographic)
uniform float uShadowRadius;    // tap offset, in shadow-map texture units (~1 texel)
uniform float uNormalOffset;    // receiver offset along the normal, world units
uniform int uShadowsOn;
uniform int uFootprint;         // 1: spread the taps over the output pixel (see keyVisibility)

// Key-light visibility in [0,1]: percentage-closer filtering with 4 hardware bilinear depth
// comparisons on a fixed square (+-r, +-r). Each tap weighs a 2x2 texel footprint, so the four
// cover 4x4 texels with tent-like weights: a soft, band-free penumbra about 4 texels wide.
// No per-pixel rotation (no noise, no trigonometry per fragment); deterministic.
// Earlier versions used 12 rotated Poisson taps: 3x the cost on llvmpipe, where every tap is
// paid by every fragment (SIMD lanes run both sides of a branch).
float keyVisibility(vec3 p, vec3 n) {
#if DGV_SHADOWS == 0
    return 1.0;
#else
    if (uShadowsOn == 0) return 1.0;
    vec3 c = (uShadowFromWorld * vec4(p + n * uNormalOffset, 1.0)).xyz;
    bool inside = c.x >= 0.0 && c.x <= 1.0 && c.y >= 0.0 && c.y <= 1.0;
    float ref = min(c.z, 0.9999);
    float r = uShadowRadius;
#if DGV_QUAD_PCF
    // At n x n supersampling a 2x2 fragment quad is one output pixel (n = 2) or a quarter of
    // one (n = 4), and the pixel's value is the mean of its fragments'. So the quad shares its
    // taps: of the 16 that its four fragments would take with the 4-tap kernel each, every
    // fragment takes the two along its own diagonal (its outer and its inner corner, +-r along
    // `corner`), and the quad sums the 8 with fine derivatives (the row's pair, then the two
    // rows). All four fragments get that value: half the texture work (about -5 ms of the
    // benchmark's scene pass), and the pixel within 4/255 of the 16-tap result but for a few
    // pixels on hard shadow edges (one tap per fragment, the 4-tap kernel per pixel, saved
    // twice that but visibly stepped those edges; docs/rendering.md).
    // `corner` is -1 for the left (bottom) fragment of a pair and +1 for the other, from the
    // derivative of the pixel parity, so it holds however the quads align. Uniform control
    // flow (derivatives): helper fragments take part; the out-of-map test is a select.
    vec2 parity = vec2(ivec2(gl_FragCoord.xy) & 1) * 2.0 - 1.0;
    vec2 corner = parity * (0.5 * vec2(dFdxFine(parity.x), dFdyFine(parity.y)));
    float v = texture(uShadowMap, vec3(c.xy + r * corner, ref)) + texture(uShadowMap, vec3(c.xy - r * corner, ref));
    v = inside ? v : 2.0;
    float rowPair = 2.0 * v - corner.x * dFdxFine(v);          // left + right
    float sum = 0.5 * (2.0 * rowPair - corner.y * dFdyFine(rowPair));  // bottom pair + top pair
#else
    if (!inside) return 1.0;
    // uFootprint (the ground shaded once per output pixel): the taps also spread over the
    // pixel's footprint in the map, at its 2x2 subsample positions, so the shadow edge is
    // filtered like the supersampled meshes instead of stepping from pixel to pixel.
    vec2 dx = uFootprint != 0 ? 0.25 * dFdx(c.xy) : vec2(0.0);
    vec2 dy = uFootprint != 0 ? 0.25 * dFdy(c.xy) : vec2(0.0);
    float sum = texture(uShadowMap, vec3(c.xy - dx - dy + vec2(-r, -r), ref))
              + texture(uShadowMap, vec3(c.xy + dx - dy + vec2(r, -r), ref))
              + texture(uShadowMap, vec3(c.xy - dx + dy + vec2(-r, r), ref))
              + texture(uShadowMap, vec3(c.xy + dx + dy + vec2(r, r), ref));
#endif
    return 0.25 * sum;
#endif
}

vec3 hemisphere(vec3 n) { return mix(uBounceColour, uSkyColour, 0.5 + 0.5 * n.y); }

// x^s for the two shininess values used (24, 48) by repeated squaring: exact, and much cheaper
// than pow() (exp2(log2)) on llvmpipe; any other value falls back to pow().
float powShininess(float x, float s) {
    float x3 = x * x * x;
    float x6 = x3 * x3;
    float x12 = x6 * x6;
    float x24 = x12 * x12;
    return s == 24.0 ? x24 : (s == 48.0 ? x24 * x24 : pow(x, s));
}

// Normalised Blinn-Phong lobe with Schlick Fresnel (F0 = 0.04): a gentle dielectric highlight.
vec3 specular(vec3 n, vec3 v, vec3 l, vec3 colour, float shininess) {
    float nl = max(dot(n, l), 0.0);
    if (nl <= 0.0) return vec3(0.0);
    vec3 h = normalize(l + v);
    float nh = max(dot(n, h), 0.0);
    float vh = max(dot(v, h), 0.0);
    float m = 1.0 - vh;
    float m2 = m * m;
    float fresnel = 0.04 + 0.96 * (m2 * m2 * m);
    float lobe = (shininess + 8.0) / 25.1327412 * powShininess(nh, shininess);
    return colour * (fresnel * lobe * nl);
}
