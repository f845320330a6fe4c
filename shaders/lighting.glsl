// Shared by mesh.frag and ground.frag (the renderer inserts this file after their #version line).
// Linear light throughout. Directions point from the surface towards the light (world space).
// DGV_SHADOWS 0 compiles the shadow lookup out (the renderer draws the part of the ground that
// no shadow can reach with that variant: on llvmpipe every PCF tap costs on every fragment).
#ifndef DGV_SHADOWS
#define DGV_SHADOWS 1
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
uniform float uShadowRadius;    // PCF kernel radius, in shadow-map texture units
uniform float uNormalOffset;    // receiver offset along the normal, world units
uniform int uShadowsOn;

// 12-tap Poisson disc (unit radius).
const vec2 kPoisson[12] = vec2[](
    vec2(-0.326, -0.406), vec2(-0.840, -0.074), vec2(-0.696, 0.457), vec2(-0.203, 0.621),
    vec2(0.962, -0.195), vec2(0.473, -0.480), vec2(0.519, 0.767), vec2(0.185, -0.893),
    vec2(0.507, 0.064), vec2(0.896, 0.412), vec2(-0.322, -0.933), vec2(-0.792, -0.598));

// Key-light visibility in [0,1]: percentage-closer filtering over a rotated Poisson disc with
// bilinear depth comparisons. The rotation is a hash of the pixel position: deterministic, and
// averaged away by the supersampling.
float keyVisibility(vec3 p, vec3 n) {
#if DGV_SHADOWS == 0
    return 1.0;
#else
    if (uShadowsOn == 0) return 1.0;
    vec3 c = (uShadowFromWorld * vec4(p + n * uNormalOffset, 1.0)).xyz;
    if (c.x < 0.0 || c.x > 1.0 || c.y < 0.0 || c.y > 1.0) return 1.0;
    float ref = min(c.z, 0.9999);
    float h = fract(sin(dot(floor(gl_FragCoord.xy), vec2(12.9898, 78.233))) * 43758.5453);
    float a = 6.2831853 * h;
    mat2 rot = mat2(cos(a), sin(a), -sin(a), cos(a));
    float sum = 0.0;
    for (int i = 0; i < 12; ++i) {
        sum += texture(uShadowMap, vec3(c.xy + rot * kPoisson[i] * uShadowRadius, ref));
    }
    return sum / 12.0;
#endif
}

vec3 hemisphere(vec3 n) { return mix(uBounceColour, uSkyColour, 0.5 + 0.5 * n.y); }

// Normalised Blinn-Phong lobe with Schlick Fresnel (F0 = 0.04): a gentle dielectric highlight.
vec3 specular(vec3 n, vec3 v, vec3 l, vec3 colour, float shininess) {
    float nl = max(dot(n, l), 0.0);
    if (nl <= 0.0) return vec3(0.0);
    vec3 h = normalize(l + v);
    float nh = max(dot(n, h), 0.0);
    float vh = max(dot(v, h), 0.0);
    float fresnel = 0.04 + 0.96 * pow(1.0 - vh, 5.0);
    float lobe = (shininess + 8.0) / 25.1327412 * pow(nh, shininess);
    return colour * (fresnel * lobe * nl);
}
