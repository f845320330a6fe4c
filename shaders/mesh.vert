#version 330 core
// Surfaces in world space; normals come per vertex from the CPU (area-weighted, split at
// creases). aScalar is the optional per-vertex highlight value (contact ramp), 0 when unused;
// aUv the material texture's coordinate (t from the image's top row), 0 when unused.
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in float aScalar;
layout(location = 3) in vec2 aUv;

uniform mat4 uClipFromWorld;

out vec3 vPosition;
out vec3 vNormal;
out float vScalar;
out vec2 vUv;

void main() {
    vPosition = aPosition;
    vNormal = aNormal;
    vScalar = aScalar;
    vUv = aUv;
    gl_Position = uClipFromWorld * vec4(aPosition, 1.0);
}
