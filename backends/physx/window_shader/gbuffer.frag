#version 450
// The PhysX window's one pass: the material's base colour, lit by one light fixed to the
// camera (above and left of it) plus an ambient term. The face normal comes from the
// screen-space derivatives of the view-space position, so every shape (primitives and meshes
// with or without normals) is shaded flat and two-sided. No shadows, no textures: SAPIEN's
// own lit shaders took 24-37 s to compile on Mesa's lavapipe before the first frame; this one
// about 1 s.

layout(set = 0, binding = 0) uniform CameraBuffer {
  mat4 viewMatrix;
  mat4 projectionMatrix;
  mat4 viewMatrixInverse;
  mat4 projectionMatrixInverse;
  float width;
  float height;
} cameraBuffer;

layout(set = 1, binding = 0) uniform ObjectTransformBuffer {
  mat4 modelMatrix;
} objectTransformBuffer;

layout(set = 1, binding = 1) uniform ObjectDataBuffer {
  uvec4 segmentation;
  float transparency;
  int shadeFlat;
} objectDataBuffer;

layout(set = 2, binding = 0) uniform MaterialBuffer {
  vec4 emission;
  vec4 baseColor;
  float fresnel;
  float roughness;
  float metallic;
  float transmission;
  float ior;
  float transmissionRoughness;
  int textureMask;
  int padding1;
  vec4 textureTransforms[6];
} materialBuffer;

layout(set = 2, binding = 1) uniform sampler2D colorTexture;
layout(set = 2, binding = 2) uniform sampler2D roughnessTexture;
layout(set = 2, binding = 3) uniform sampler2D normalTexture;
layout(set = 2, binding = 4) uniform sampler2D metallicTexture;
layout(set = 2, binding = 5) uniform sampler2D emissionTexture;

struct PointLight {
  vec4 position;
  vec4 emission;
};

struct DirectionalLight {
  vec4 direction;
  vec4 emission;
};

struct SpotLight {
  vec4 position;
  vec4 direction;
  vec4 emission;
};

layout(set = 3, binding = 0) uniform SceneBuffer {
  vec4 ambientLight;
  DirectionalLight directionalLights[3];
  SpotLight spotLights[10];
  PointLight pointLights[10];
  SpotLight texturedLights[1];
} sceneBuffer;

layout(location = 0) in vec4 inPosition;
layout(location = 1) in flat uvec4 inSeg;

layout(location = 0) out vec4 outColor;
layout(location = 1) out vec4 outPosition;
layout(location = 2) out uvec4 outSegmentation;

const vec3 LIGHT = normalize(vec3(-0.3, 0.6, 1.0));  // towards the light, in view space
const float AMBIENT = 0.4;

void main() {
  outPosition = inPosition;
  outSegmentation = inSeg;
  vec3 n = normalize(cross(dFdx(inPosition.xyz), dFdy(inPosition.xyz)));
  float light = AMBIENT + (1.0 - AMBIENT) * abs(dot(n, LIGHT));
  outColor = vec4(materialBuffer.baseColor.rgb * light, materialBuffer.baseColor.a);
}
