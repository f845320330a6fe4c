#version 330 core
// Overlays (lines and dots): screen-space quads built on the CPU, already in clip space.
// aCorner is the quad's local coordinate in [-1,1]^2 (dots discard outside the unit disc).
layout(location = 0) in vec4 aClip;
layout(location = 1) in vec2 aCorner;

out vec2 vCorner;

void main() {
    vCorner = aCorner;
    gl_Position = aClip;
}
