#version 330 core
// (lighting.glsl is inserted here)
// A neutral grey floor that fades out radially into the background (a studio "infinity"
// floor), lit by the key light with its shadow. In catcher mode (transparent background) it
// keeps only the shadow: black with alpha = shadow strength, for compositing.
in vec3 vPosition;

uniform vec3 uGroundCentre;
uniform float uFadeInner;   // full floor inside this radius
uniform float uFadeOuter;   // nothing beyond this radius (alpha exactly 0)
uniform vec3 uGroundAlbedo;
uniform int uCatcher;

out vec4 fragColour;

void main() {
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
    vec3 irradiance = uKeyColour * (max(uKeyDir.y, 0.0) * key)
                    + uFillColour * max(uFillDir.y, 0.0)
                    + hemisphere(n);
    vec3 colour = uGroundAlbedo * irradiance;
    fragColour = vec4(colour * fade, fade);  // premultiplied
}
