#version 450
// The PhysX window's one pass (backends/physx/window.py): each vertex placed by the camera and
// its object's transform; the view-space position goes on to the fragment stage, which shades
// from it. The blocks and inputs are the ones SAPIEN's renderer binds.

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

layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec2 uv;
layout(location = 3) in vec3 tangent;
layout(location = 4) in vec3 bitangent;

layout(location = 0) out vec4 outPosition;
layout(location = 1) out flat uvec4 outSeg;

void main() {
  outSeg = objectDataBuffer.segmentation;
  outPosition = cameraBuffer.viewMatrix * (objectTransformBuffer.modelMatrix * vec4(position, 1));
  gl_Position = cameraBuffer.projectionMatrix * outPosition;
}
