#version 330 core
// The ground quad (world space, y = the scene's lowest point).
layout(location = 0) in vec3 aPosition;

uniform mat4 uClipFromWorld;

out vec3 vPosition;

void main() {
    vPosition = aPosition;
    gl_Position = uClipFromWorld * vec4(aPosition, 1.0);
}
