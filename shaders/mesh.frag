#version 330 core
// (lighting.glsl is inserted here)
in vec3 vPosition;
in vec3 vNormal;

uniform vec3 uEye;
uniform vec3 uAlbedo;

out vec4 fragColour;

void main() {
    float len = length(vNormal);
    vec3 n = len > 0.0 ? vNormal / len : vec3(0.0, 1.0, 0.0);
    if (!gl_FrontFacing) n = -n;  // two-sided: open meshes show their inside lit too
    vec3 v = normalize(uEye - vPosition);

    float key = keyVisibility(vPosition, n);
    vec3 irradiance = uKeyColour * (max(dot(n, uKeyDir), 0.0) * key)
                    + uFillColour * max(dot(n, uFillDir), 0.0)
                    + uRimColour * max(dot(n, uRimDir), 0.0)
                    + hemisphere(n);
    vec3 colour = uAlbedo * irradiance
                + specular(n, v, uKeyDir, uKeyColour, 48.0) * key
                + specular(n, v, uRimDir, uRimColour, 24.0);
    fragColour = vec4(colour, 1.0);  // premultiplied, opaque
}
