// Shared by mesh.frag and ground.frag (the renderer inserts this file after their #version line).
// Linear light throughout. Directions point from the surface towards the light (world space).
// DGV_SHADOWS 0 compiles the shadow lookup out (the renderer draws the part of the ground that
// no shadow can reach with that variant: on llvmpipe every PCF tap costs on every fragment).
// DGV_QUAD_PCF 1 (the supersampled mesh pass, n >= 2): the fragments of each 2x2 quad share
// their PCF taps through fine derivatives, two taps each instead of four (keyVisibility).
// DGV_SOFT_SHADOWS 1 (render.shadow_softness > 0): percentage-closer soft shadows from a key
// light of angular radius theta (blockerSearch, softVisibility; docs/rendering.md, "Soft
// shadows"). DGV_QUAD_SEARCH 1 shares the blocker search over each 2x2 quad (the default with
// DGV_QUAD_PCF; the ground at output size sets it alone).
#ifndef DGV_SHADOWS
#define DGV_SHADOWS 1
#endif
#ifndef DGV_QUAD_PCF
#define DGV_QUAD_PCF 0
#endif
#ifndef DGV_SOFT_SHADOWS
#define DGV_SOFT_SHADOWS 0
#endif
#ifndef DGV_QUAD_SEARCH
#define DGV_QUAD_SEARCH DGV_QUAD_PCF
#endif
#if DGV_QUAD_PCF || DGV_QUAD_SEARCH
#extension GL_ARB_derivative_control : require
#endif
#if DGV_SOFT_SHADOWS
#extension GL_ARB_texture_gather : require
#endif

// The lights (RenderSettings::lights, in world space): each a direction towards it (w = 0) or a
// position (w = 1: its colour falls off as 1/d²), a colour with its intensity, a specular
// exponent (0: none) and whether it lights the floor. uShadowLight: the light whose shadow map
// keyVisibility reads (-1: none).
#define DGV_MAX_LIGHTS 8
uniform int uLightCount;
uniform vec4 uLightVector[DGV_MAX_LIGHTS];
uniform vec3 uLightColour[DGV_MAX_LIGHTS];
uniform float uLightShininess[DGV_MAX_LIGHTS];
uniform int uLightFloor[DGV_MAX_LIGHTS];
uniform int uShadowLight;
uniform vec3 uSkyColour;     // hemisphere ambient, from above
uniform vec3 uBounceColour;  // hemisphere ambient, from below
// render.environment (render/environment.hpp): 1: the ambient light is the environment's nine
// spherical-harmonic coefficients' (y up), else the sky and bounce hemisphere above.
uniform int uEnvironment;
uniform vec3 uEnvironmentSH[9];

uniform sampler2DShadow uShadowMap;
uniform mat4 uShadowFromWorld;  // world -> [0,1]^3 shadow-map coordinates (orthographic)
uniform float uShadowRadius;    // tap offset, in shadow-map texture units (~1 texel)
uniform float uNormalOffset;    // receiver offset along the normal, world units
uniform int uShadowsOn;
uniform int uFootprint;         // 1: spread the taps over the output pixel (see keyVisibility)
// Soft shadows (DGV_SOFT_SHADOWS 1): the key light is a disc of angular radius theta, so a
// shadow's penumbra widens with the distance from its blocker (contact hardening).
uniform sampler2D uShadowDepth;  // the same map read as depths (no comparison): blocker search
uniform float uPenumbraPerDepth; // filter radius (texture units) per unit of map depth: 2 tan(theta)
uniform float uSearchRadius;     // the largest filter radius, texture units
uniform float uBlockerNear;      // the map depth of the scene's nearest point to the light

// The hard kernel (the key light as a point; with soft shadows, where the penumbra is narrower
// than this kernel): percentage-closer filtering with 4 hardware bilinear depth comparisons
// on a fixed square (+-r, +-r). Each tap weighs a 2x2 texel footprint, so the four
// cover 4x4 texels with tent-like weights: a soft, band-free penumbra about 4 texels wide.
// No per-pixel rotation (no noise, no trigonometry per fragment); deterministic.
// Earlier versions used 12 rotated Poisson taps: 3x the cost on llvmpipe, where every tap is
// paid by every fragment (SIMD lanes run both sides of a branch).
float hardVisibility(vec3 c, bool inside, float ref) {
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
}

#if DGV_SOFT_SHADOWS
// 16 points of a Poisson disc of radius 1 (fixed: every run gives the same pixels), written
// out as literals: a constant array indexed in a loop that llvmpipe cannot unroll is built
// per fragment and read lane by lane, which cost more than the taps themselves.
#define DGV_DISC_0 vec2(-0.9420, -0.3991)
#define DGV_DISC_1 vec2(0.9456, -0.7689)
#define DGV_DISC_2 vec2(-0.0942, -0.9294)
#define DGV_DISC_3 vec2(0.3450, 0.2939)
#define DGV_DISC_4 vec2(-0.9159, 0.4577)
#define DGV_DISC_5 vec2(-0.8154, -0.8791)
#define DGV_DISC_6 vec2(-0.3828, 0.2768)
#define DGV_DISC_7 vec2(0.9748, 0.7565)
#define DGV_DISC_8 vec2(0.4432, -0.9751)
#define DGV_DISC_9 vec2(0.5374, -0.4737)
#define DGV_DISC_10 vec2(-0.2650, -0.4189)
#define DGV_DISC_11 vec2(0.7920, 0.1909)
#define DGV_DISC_12 vec2(-0.2419, 0.9971)
#define DGV_DISC_13 vec2(-0.8141, 0.9144)
#define DGV_DISC_14 vec2(0.1998, 0.7864)
#define DGV_DISC_15 vec2(0.1438, -0.1410)
// The disc's four turns, (cos, sin) of 0, 22.5, 45 and 67.5 degrees, and the disc turned and scaled.
#define DGV_TURN_0 vec2(1.0, 0.0)
#define DGV_TURN_1 vec2(0.9238795, 0.3826834)
#define DGV_TURN_2 vec2(0.7071068, 0.7071068)
#define DGV_TURN_3 vec2(0.3826834, 0.9238795)
mat2 turnedDisc(vec2 cs, float radius) { return mat2(cs.x, cs.y, -cs.y, cs.x) * radius; }
#define DGV_DISC_TAPS(TAP) \
    TAP(DGV_DISC_0) TAP(DGV_DISC_1) TAP(DGV_DISC_2) TAP(DGV_DISC_3) \
    TAP(DGV_DISC_4) TAP(DGV_DISC_5) TAP(DGV_DISC_6) TAP(DGV_DISC_7) \
    TAP(DGV_DISC_8) TAP(DGV_DISC_9) TAP(DGV_DISC_10) TAP(DGV_DISC_11) \
    TAP(DGV_DISC_12) TAP(DGV_DISC_13) TAP(DGV_DISC_14) TAP(DGV_DISC_15)

// One gather's blockers: (sum of the blocking depths, their count) among its 2x2 depths.
vec2 gatherBlockers(vec2 at, float limit) {
    vec4 d = textureGather(uShadowDepth, at);
    vec4 isBlocker = vec4(lessThan(d, vec4(limit)));
    return vec2(dot(d, isBlocker), dot(isBlocker, vec4(1.0)));
}

// The blocker search: (sum of the blocking depths, their count) among 64 depths, 16 gathers on
// a 4x4 grid at (+-s/3, +-s) over the largest penumbra this receiver can have, radius s (its
// depth below the scene's nearest point to the light). The grid reaches as far as the filter
// can (radius s at most), so where the search finds no blocker the filter would find none
// either and the shadow stays continuous there; with gathers reaching only half way the
// filter's disc showed as lobes round a far blocker's shadow. With DGV_QUAD_PCF each fragment
// of a 2x2 quad takes the quarter of the grid on its own side and the quad sums the four (fine
// derivatives, as the hard kernel does): 4 gathers a fragment instead of 16. The ground at
// output size shares its search the same way (DGV_QUAD_SEARCH without DGV_QUAD_PCF): the mean
// blocker depth over 2x2 pixels is as good as over one, where a shared filter would show as
// 2x2 blocks. Uniform control flow with DGV_QUAD_SEARCH.
vec2 blockerSearch(vec3 c, float ref) {
    float s = clamp(uPenumbraPerDepth * (ref - uBlockerNear), uShadowRadius, uSearchRadius);
    float limit = ref - 2.0 * uShadowRadius;
#if DGV_QUAD_SEARCH
    vec2 parity = vec2(ivec2(gl_FragCoord.xy) & 1) * 2.0 - 1.0;
    vec2 side = parity * (0.5 * vec2(dFdxFine(parity.x), dFdyFine(parity.y))) * s;
    vec2 v = gatherBlockers(c.xy + side * vec2(1.0 / 3.0, 1.0 / 3.0), limit)
           + gatherBlockers(c.xy + side * vec2(1.0, 1.0 / 3.0), limit)
           + gatherBlockers(c.xy + side * vec2(1.0 / 3.0, 1.0), limit)
           + gatherBlockers(c.xy + side, limit);
    vec2 rowPair = 2.0 * v - sign(side.x) * dFdxFine(v);
    return 2.0 * rowPair - sign(side.y) * dFdyFine(rowPair);
#else
    vec2 v = vec2(0.0);
    for (int k = 0; k < 16; ++k) {
        vec2 o = (vec2(float(k & 3), float(k >> 2)) * (2.0 / 3.0) - 1.0) * s;
        v += gatherBlockers(c.xy + o, limit);
    }
    return v;
#endif
}

// Percentage-closer soft shadows. The blocker search's mean blocking depth gives the filter
// radius, its distance to the receiver times 2 tan(theta); the filter is the disc's 16 bilinear
// comparisons at that radius. Returns (soft visibility, its weight against the hard kernel):
// weight 0 where the search finds no blocker (lit, or a blocker the sparse search missed,
// which the hard kernel sees) or where the penumbra is no wider than the hard kernel's; rising
// to 1 by twice that width.
// Every fragment pays for the filter: llvmpipe runs both sides of a branch and the first trip
// of a loop for its whole block of fragments, so skipping the filter where it is not needed
// saves nothing there. Hence the filter is cheap everywhere instead: with DGV_QUAD_PCF each
// fragment of a 2x2 quad takes a quarter of the disc (4 taps) and the quad sums the four with
// fine derivatives, 16 taps an output pixel at 2x2 supersampling for the price of 4; the disc
// turns with the output pixel's parity (0, 22.5, 45, 67.5 degrees), so neighbouring pixels
// sample different points and a wide penumbra shows no contours. Without it (the ground at
// output size, 1x supersampling) a fragment takes the 16 taps at all four turns: turned by its
// parity the ground showed the 2x2 pattern as grain, unturned the taps as contour lines.
vec2 softVisibility(vec3 c, float ref, vec2 blocker) {
    float blockerSum = blocker.x, blockers = blocker.y;
    float radius = min(uPenumbraPerDepth * (ref - blockerSum / max(blockers, 1.0)), uSearchRadius);
    float weight = smoothstep(1.5, 3.0, radius / uShadowRadius);
    bool penumbra = blockers > 0.0 && weight > 0.0;
    ivec2 frag = ivec2(gl_FragCoord.xy);
#if DGV_QUAD_PCF
    int pixel = ((frag.x >> 1) & 1) + 2 * ((frag.y >> 1) & 1);
    mat2 rot = turnedDisc(pixel == 0 ? DGV_TURN_0 : pixel == 1 ? DGV_TURN_1 : pixel == 2 ? DGV_TURN_2 : DGV_TURN_3, radius);
    vec2 side = vec2(frag & 1) * 2.0 - 1.0;
    int quarter = (frag.x & 1) + 2 * (frag.y & 1);  // takes the disc's points quarter, quarter + 4, ...
    vec2 o0 = quarter == 0 ? DGV_DISC_0 : quarter == 1 ? DGV_DISC_1 : quarter == 2 ? DGV_DISC_2 : DGV_DISC_3;
    vec2 o1 = quarter == 0 ? DGV_DISC_4 : quarter == 1 ? DGV_DISC_5 : quarter == 2 ? DGV_DISC_6 : DGV_DISC_7;
    vec2 o2 = quarter == 0 ? DGV_DISC_8 : quarter == 1 ? DGV_DISC_9 : quarter == 2 ? DGV_DISC_10 : DGV_DISC_11;
    vec2 o3 = quarter == 0 ? DGV_DISC_12 : quarter == 1 ? DGV_DISC_13 : quarter == 2 ? DGV_DISC_14 : DGV_DISC_15;
    float v = texture(uShadowMap, vec3(c.xy + rot * o0, ref)) + texture(uShadowMap, vec3(c.xy + rot * o1, ref))
            + texture(uShadowMap, vec3(c.xy + rot * o2, ref)) + texture(uShadowMap, vec3(c.xy + rot * o3, ref));
    float rowPair = 2.0 * v - side.x * dFdxFine(v);
    float sum = 2.0 * rowPair - side.y * dFdyFine(rowPair);
#else
    float sum = 0.0;
    mat2 rot;
#define DGV_TAP(o) sum += texture(uShadowMap, vec3(c.xy + rot * o, ref));
    rot = turnedDisc(DGV_TURN_0, radius);
    DGV_DISC_TAPS(DGV_TAP)
    rot = turnedDisc(DGV_TURN_2, radius);
    DGV_DISC_TAPS(DGV_TAP)
    rot = turnedDisc(DGV_TURN_1, radius);
    DGV_DISC_TAPS(DGV_TAP)
    rot = turnedDisc(DGV_TURN_3, radius);
    DGV_DISC_TAPS(DGV_TAP)
#undef DGV_TAP
    sum *= 0.25;
#endif
    return penumbra ? vec2(sum / 16.0, weight) : vec2(1.0, 0.0);
}
#endif

// Key-light visibility in [0,1] (1: lit).
float keyVisibility(vec3 p, vec3 n) {
#if DGV_SHADOWS == 0
    return 1.0;
#else
    if (uShadowsOn == 0) return 1.0;
    vec3 c = (uShadowFromWorld * vec4(p + n * uNormalOffset, 1.0)).xyz;
    bool inside = c.x >= 0.0 && c.x <= 1.0 && c.y >= 0.0 && c.y <= 1.0;
    float ref = min(c.z, 0.9999);
    float hard = hardVisibility(c, inside, ref);  // derivatives inside: uniform control flow
#if DGV_SOFT_SHADOWS
    vec2 blocker = blockerSearch(c, ref);        // uniform control flow (derivatives)
    vec2 soft = softVisibility(c, ref, blocker);  // likewise
    if (inside) return mix(hard, soft.x, soft.y);
#endif
    return hard;
#endif
}

// Light i as seen from p: the unit direction towards it, and its colour there.
void lightAt(int i, vec3 p, out vec3 l, out vec3 c) {
    vec4 v = uLightVector[i];
    c = uLightColour[i];
    if (v.w == 0.0) {
        l = v.xyz;
        return;
    }
    vec3 d = v.xyz - p;
    float r2 = max(dot(d, d), 1e-12);
    l = d * inversesqrt(r2);
    c /= r2;
}

vec3 hemisphere(vec3 n) {
    if (uEnvironment != 0) {
        return uEnvironmentSH[0] * 0.282095
             + (uEnvironmentSH[1] * n.x + uEnvironmentSH[2] * n.y + uEnvironmentSH[3] * n.z) * 0.488603
             + (uEnvironmentSH[4] * (n.x * n.z) + uEnvironmentSH[5] * (n.x * n.y) + uEnvironmentSH[7] * (n.y * n.z)) * 1.092548
             + uEnvironmentSH[6] * (0.315392 * (3.0 * n.y * n.y - 1.0))
             + uEnvironmentSH[8] * (0.546274 * (n.z * n.z - n.x * n.x));
    }
    return mix(uBounceColour, uSkyColour, 0.5 + 0.5 * n.y);
}

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
