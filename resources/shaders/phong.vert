#version 330 core
// Per-fragment (Phong) lighting in eye space; see phong.frag.
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in float aKind;  // 0 tissue surface, 1 cut wall (tissue interior)

uniform mat4 uModelView;
uniform mat4 uProjection;
uniform mat3 uNormalMatrix;
uniform vec3 uTissueColor;
uniform vec3 uInteriorColor;

out vec3 vPositionEye;
out vec3 vNormalEye;
out vec3 vColor;

void main() {
  vec4 p = uModelView * vec4(aPosition, 1.0);
  vPositionEye = p.xyz;
  vNormalEye = uNormalMatrix * aNormal;
  vColor = aKind > 0.5 ? uInteriorColor : uTissueColor;
  gl_Position = uProjection * p;
}
