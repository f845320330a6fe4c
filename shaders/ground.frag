#version 330 core
// (lighting.glsl is inserted here)
// A neutral grey floor that fades out radially into the background (a studio "infinity"
// floor), lit by the lights that light it (RenderSettings::lights), with the shadow map's shadow. In catcher mode (transparent background) it
// keeps only the shadow: black with alpha = shadow strength, for compositing.
in vec3 vPosition;

uniform vec3 uGroundCentre;
uniform float uFadeInner;   // full floor inside this radius
uniform float uFadeOuter;   // nothing beyond this radius (alpha exactly 0)
uniform vec3 uGroundAlbedo;
uniform int uCatcher;
// Ground marks (FrameScene::groundMarks), rasterised on the CPU into a texture over the
// rectangle uDecalRect = (x0, z0, 1/width, 1/depth): premultiplied linear colour, alpha =
// coverage; the colour is also emitted, times uDecalGlow.
uniform sampler2D uDecal;
uniform float uDecalGlow;
uniform vec4 uDecalRect;
uniform int uHasDecal;

#ifdef DGV_CONTACT_OUT
// RenderSettings::linearPlanes: the contact matte is the ground marks' coverage (footprints),
// times the floor's fade, as its colour.
layout(location = 0) out vec4 fragColour;
layout(location = 1) out vec4 fragContact;
#else
out vec4 fragColour;
#endif

void main() {
#ifdef DGV_CONTACT_OUT
    fragContact = vec4(0.0);
#endif
    float r = length(vPosition.xz - uGroundCentre.xz);
    float fade = 1.0 - smoothstep(uFadeInner, uFadeOuter, r);
    if (fade <= 0.0) {
        fragColour = vec4(0.0);
        return;
    }
    vec3 n = vec3(0.0, 1.0, 0.0);
    float key = keyVisibility(vPosition, n);
    if (uCatcher != 0) {
        float a = 0.85 * (1.0 - key) * fade;
        fragColour = vec4(0.0, 0.0, 0.0, a);
        return;
    }
#if DGV_STUDIO_RIG
    vec3 irradiance = uLightColour[0] * (max(uLightVector[0].y, 0.0) * key)
                    + uLightColour[1] * max(uLightVector[1].y, 0.0)
                    + hemisphere(n);  // the rim (light 2) leaves the floor alone
#else
    vec3 irradiance = vec3(0.0);
    for (int i = 0; i < uLightCount; ++i) {
        if (uLightFloor[i] == 0) continue;
        vec3 l, c;
        lightAt(i, vPosition, l, c);
        irradiance += c * (max(l.y, 0.0) * (i == uShadowLight ? key : 1.0));
    }
    irradiance += hemisphere(n);
#endif
    vec3 albedo = uGroundAlbedo;
    vec3 emitted = vec3(0.0);
    float marked = 0.0;
    if (uHasDecal != 0) {
        vec2 t = (vPosition.xz - uDecalRect.xy) * uDecalRect.zw;
        if (all(greaterThanEqual(t, vec2(0.0))) && all(lessThanEqual(t, vec2(1.0)))) {
            vec4 d = texture(uDecal, t);
            albedo = albedo * (1.0 - d.a) + d.rgb;
            emitted = uDecalGlow * d.rgb;
            marked = d.a;
        }
    }
    vec3 colour = albedo * irradiance + emitted;
    fragColour = vec4(colour * fade, fade);  // premultiplied
#ifdef DGV_CONTACT_OUT
    fragContact = vec4(marked * fade, 0.0, 0.0, fade);
#endif
}
