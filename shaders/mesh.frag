#version 330 core
// (lighting.glsl is inserted here)
// DGV_SCALAR 0: the variant for meshes without a highlight scalar (the renderer picks it per
// mesh); vScalar is then not read, and the linker drops it from mesh.vert's outputs.
#ifndef DGV_SCALAR
#define DGV_SCALAR 1
#endif
in vec3 vPosition;
in vec3 vNormal;
#if DGV_SCALAR
in float vScalar;
#endif

uniform vec3 uEye;
uniform vec3 uAlbedo;
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

void main() {
    float len = length(vNormal);
    vec3 n = len > 0.0 ? vNormal / len : vec3(0.0, 1.0, 0.0);
    if (!gl_FrontFacing) n = -n;  // two-sided: open meshes show their inside lit too
    vec3 v = normalize(uEye - vPosition);

    vec3 albedo = uAlbedo;
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
                + specular(n, v, keyDir, uLightColour[0], uLightShininess[0]) * key
                + specular(n, v, rimDir, uLightColour[2], uLightShininess[2])
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
        colour += specular(n, v, l, c, uLightShininess[i]) * (i == uShadowLight ? key : 1.0);
    }
    colour += emitted;
#endif
    fragColour = vec4(colour * uOpacity, uOpacity);  // premultiplied
#ifdef DGV_CONTACT_OUT
    fragContact = vec4(highlighted * uOpacity, 0.0, 0.0, uOpacity);
#endif
}
