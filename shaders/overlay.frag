#version 330 core
// Flat, unlit overlay colour (linear, opaque). uRound: a dot (discard outside the unit disc).
in vec2 vCorner;

uniform vec3 uColour;
uniform int uRound;

out vec4 fragColour;

void main() {
    if (uRound != 0 && dot(vCorner, vCorner) > 1.0) discard;
    fragColour = vec4(uColour, 1.0);
}
