#version 330 core
// Phong shading with a headlight-like key light and a fill light. With two-sided
// lighting, back faces (the inside of an open mesh) are lit with a flipped normal and
// a darker colour so they stay visible instead of going black.
in vec3 vPositionEye;
in vec3 vNormalEye;
in vec3 vColor;

uniform bool uTwoSided;
uniform vec3 uBackColor;
uniform bool uWire;
uniform vec3 uWireColor;
uniform float uShininess;
uniform vec3 uKeyLightEye;  // positional key light, eye space (follows the camera)

out vec4 fragColor;

vec3 light(vec3 n, vec3 v, vec3 l, vec3 base, float strength) {
  float diff = max(dot(n, l), 0.0);
  vec3 r = reflect(-l, n);
  float spec = diff > 0.0 ? pow(max(dot(r, v), 0.0), uShininess) : 0.0;
  return strength * (diff * base + 0.35 * spec * vec3(1.0));
}

void main() {
  if (uWire) {
    fragColor = vec4(uWireColor, 1.0);
    return;
  }
  vec3 n = normalize(vNormalEye);
  vec3 base = vColor;
  if (!gl_FrontFacing) {
    if (uTwoSided) {
      n = -n;
      base = uBackColor;
    } else {
      base = vec3(0.05);
    }
  }
  vec3 v = normalize(-vPositionEye);
  vec3 key = normalize(uKeyLightEye - vPositionEye);
  vec3 fill = normalize(vec3(0.6, -0.3, 0.5));
  vec3 c = 0.22 * base + light(n, v, key, base, 0.85) + light(n, v, fill, base, 0.25);
  fragColor = vec4(pow(c, vec3(1.0 / 1.1)), 1.0);
}
