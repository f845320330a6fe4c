#version 330 core
// (lighting.glsl is inserted here)
// DGV_SCALAR 0: the variant for meshes without a highlight scalar (the renderer picks it per
// mesh); vScalar is then not read, and the linker drops it from mesh.vert's outputs.
#ifndef DGV_SCALAR
#define DGV_SCALAR 1
#endif
in vec3 vPosition;
in vec3 vNormal;
in vec2 vUv;
#if DGV_SCALAR
in float vScalar;
#endif

uniform vec3 uEye;
uniform vec3 uAlbedo;
// The material (DrawMesh::materials): uAlbedo times the base-colour map at vUv where uTextured
// (an sRGB texture, so samples are linear); a highlight exponent of its own for every light that
// has one (uSurfaceShininess > 0, from its roughness); its metalness, which tints the highlights
// with the albedo (Schlick's F0) and takes the diffuse away. All at their defaults: the plain look.
uniform int uTextured;
uniform sampler2D uBaseColourMap;
uniform float uSurfaceShininess;
uniform float uMetallic;
// Highlight ramp (render/renderer.hpp, ScalarRamp): where the scalar is > 0 the albedo is
// mix(uRampLow, uRampHigh, clamp((s - uRampMin) * uRampInvSpan, 0, 1)).
uniform vec3 uRampLow;
uniform vec3 uRampHigh;
uniform float uRampMin;
uniform float uRampInvSpan;
uniform float uRampGlow;
// The contact matte (DGV_CONTACT_OUT) where the scalar is > 0: 1, or the ramp's position where
// the ramp starts at the surface's own colour (a footprint, a fading contact), so the matte
// follows what shows.
uniform int uMatteAlongRamp;
uniform float uOpacity;  // 1: opaque; below, drawn blended after the opaque meshes (DrawMesh::opacity)

#ifdef DGV_CONTACT_OUT
// RenderSettings::linearPlanes: the contact matte beside the colour (R: highlighted, times the
// opacity, blended as the colour is).
layout(location = 0) out vec4 fragColour;
layout(location = 1) out vec4 fragContact;
#else
out vec4 fragColour;
#endif

float shininessFor(float lightShininess) {
    return uSurfaceShininess > 0.0 && lightShininess > 0.0 ? uSurfaceShininess : lightShininess;
}

// specular() with a coloured F0 (a metal's).
vec3 specularF0(vec3 n, vec3 v, vec3 l, vec3 colour, float shininess, vec3 f0) {
    float nl = max(dot(n, l), 0.0);
    if (nl <= 0.0) return vec3(0.0);
    vec3 h = normalize(l + v);
    float nh = max(dot(n, h), 0.0);
    float m = 1.0 - max(dot(v, h), 0.0);
    float m2 = m * m;
    vec3 fresnel = f0 + (1.0 - f0) * (m2 * m2 * m);
    float lobe = (shininess + 8.0) / 25.1327412 * powShininess(nh, shininess);
    return colour * fresnel * (lobe * nl);
}

vec3 surfaceSpecular(vec3 n, vec3 v, vec3 l, vec3 colour, float lightShininess, vec3 f0) {
    float s = shininessFor(lightShininess);
    return uMetallic > 0.0 ? specularF0(n, v, l, colour, s, f0) : specular(n, v, l, colour, s);
}

void main() {
    float len = length(vNormal);
    vec3 n = len > 0.0 ? vNormal / len : vec3(0.0, 1.0, 0.0);
    if (!gl_FrontFacing) n = -n;  // two-sided: open meshes show their inside lit too
    vec3 v = normalize(uEye - vPosition);

    vec3 albedo = uAlbedo;
    if (uTextured != 0) albedo *= texture(uBaseColourMap, vUv).rgb;
    vec3 emitted = vec3(0.0);
    float highlighted = 0.0;
#if DGV_SCALAR
    if (vScalar > 0.0) {
        float t = clamp((vScalar - uRampMin) * uRampInvSpan, 0.0, 1.0);
        highlighted = uMatteAlongRamp != 0 ? t : 1.0;
        albedo = mix(uRampLow, uRampHigh, t);
        emitted = (uRampGlow * sqrt(t)) * uRampHigh;  // grows with the ramp: no step where it starts
    }
#endif

    vec3 f0 = vec3(0.04);
    if (uMetallic > 0.0 && highlighted == 0.0) {
        f0 = mix(vec3(0.04), albedo, uMetallic);
        albedo *= 1.0 - uMetallic;
        emitted += uMetallic * f0 * hemisphere(reflect(-v, n));  // the sky in the metal
    }
    // Diffuse from every light and the sky, then each light's highlight: the sums in this order.
    float key = keyVisibility(vPosition, n);
#if DGV_STUDIO_RIG
    // defaultLightRig() (key 0 with the shadows, fill 1, rim 2), unrolled: the rig's own sums,
    // bit for bit the frames it has always made.
    vec3 keyDir = uLightVector[0].xyz, fillDir = uLightVector[1].xyz, rimDir = uLightVector[2].xyz;
    vec3 irradiance = uLightColour[0] * (max(dot(n, keyDir), 0.0) * key)
                    + uLightColour[1] * max(dot(n, fillDir), 0.0)
                    + uLightColour[2] * max(dot(n, rimDir), 0.0)
                    + hemisphere(n);
    vec3 colour = albedo * irradiance
                + surfaceSpecular(n, v, keyDir, uLightColour[0], uLightShininess[0], f0) * key
                + surfaceSpecular(n, v, rimDir, uLightColour[2], uLightShininess[2], f0)
                + emitted;
#else
    vec3 irradiance = vec3(0.0);
    for (int i = 0; i < uLightCount; ++i) {
        vec3 l, c;
        lightAt(i, vPosition, l, c);
        irradiance += c * (max(dot(n, l), 0.0) * (i == uShadowLight ? key : 1.0));
    }
    irradiance += hemisphere(n);
    vec3 colour = albedo * irradiance;
    for (int i = 0; i < uLightCount; ++i) {
        if (uLightShininess[i] <= 0.0) continue;
        vec3 l, c;
        lightAt(i, vPosition, l, c);
        colour += surfaceSpecular(n, v, l, c, uLightShininess[i], f0) * (i == uShadowLight ? key : 1.0);
    }
    colour += emitted;
#endif
    fragColour = vec4(colour * uOpacity, uOpacity);  // premultiplied
#ifdef DGV_CONTACT_OUT
    fragContact = vec4(highlighted * uOpacity, 0.0, 0.0, uOpacity);
#endif
}
