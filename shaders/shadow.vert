#version 330 core
// Depth-only pass from the key light (orthographic).
layout(location = 0) in vec3 aPosition;

uniform mat4 uLightClipFromWorld;

void main() { gl_Position = uLightClipFromWorld * vec4(aPosition, 1.0); }
