#version 330 core
// As gbuffer_resolve: geometric normal facing the camera; the interpolated vertex normal, kept on
// the visible side, where every vertex has one. Depth is the distance from the eye over the far
// plane's, linear: the nearest surface along each pixel's ray wins as in raster.cl's ray casting
// (a perspective depth buffer with a near plane small enough for any scene resolves surfaces a
// few mm apart in the wrong order, which swapped whole pixels in the default frame).
in vec3 vPos;
in vec4 vNrm;
flat in vec3 vGeo;
flat in vec3 vAlb;
uniform vec3 uEye;
uniform float uFar;
layout(location = 0) out vec4 oPos;
layout(location = 1) out vec4 oNrm;
layout(location = 2) out vec4 oGeo;
layout(location = 3) out vec4 oAlb;
void main() {
  vec3 g = normalize(vGeo);
  if (dot(g, vPos - uEye) > 0.0) g = -g;
  vec3 n = g;
  if (vNrm.w > 0.999 && length(vNrm.xyz) > 1e-12) {
    n = normalize(vNrm.xyz);
    if (dot(n, g) < 0.0) n = -n;
  }
  gl_FragDepth = clamp(length(vPos - uEye) / uFar, 0.0, 1.0);
  oPos = vec4(vPos, 1.0);
  oNrm = vec4(n, 0.0);
  oGeo = vec4(g, 0.0);
  oAlb = vec4(vAlb, 1.0);
}
