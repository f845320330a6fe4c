#version 330 core
// Surfaces in world space; normals come per vertex from the CPU (area-weighted).
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aNormal;

uniform mat4 uClipFromWorld;

out vec3 vPosition;
out vec3 vNormal;

void main() {
    vPosition = aPosition;
    vNormal = aNormal;
    gl_Position = uClipFromWorld * vec4(aPosition, 1.0);
}
