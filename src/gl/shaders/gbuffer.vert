#version 330 core
// Camera G-buffer of `render --gl`: triangles drawn unindexed, each vertex with its triangle's
// geometric normal and its mesh's albedo (penumbra's raster.cl gbuffer_resolve, by rasterization).
layout(location = 0) in vec3 aPos;
layout(location = 1) in vec4 aNrm;  // w = 1: the mesh has vertex normals
layout(location = 2) in vec3 aGeo;
layout(location = 3) in vec3 aAlb;
uniform mat4 uViewProj;
out vec3 vPos;
out vec4 vNrm;
flat out vec3 vGeo;
flat out vec3 vAlb;
void main() {
  vPos = aPos;
  vNrm = aNrm;
  vGeo = aGeo;
  vAlb = aAlb;
  gl_Position = uViewProj * vec4(aPos, 1.0);
}
