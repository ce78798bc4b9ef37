#version 330 core
// Per-fragment (Phong) lighting in eye space; see phong.frag.
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in vec3 aColor;  // a constant attribute unless colours are given

uniform mat4 uModelView;
uniform mat4 uProjection;
uniform mat3 uNormalMatrix;

out vec3 vPositionEye;
out vec3 vNormalEye;
out vec3 vColor;

void main() {
  vec4 p = uModelView * vec4(aPosition, 1.0);
  vPositionEye = p.xyz;
  vNormalEye = uNormalMatrix * aNormal;
  vColor = aColor;
  gl_Position = uProjection * p;
}
