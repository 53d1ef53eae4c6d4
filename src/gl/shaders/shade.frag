#version 330 core
// The final shading of kernels/render/shade.cl as a GL fragment shader, term for term: every
// light's irradiance (a cap: Kneiphof 2017 eqs. 15-18 with the horizon-clipped closed form of
// Snyder
// 1996, pb_cap_irradiance in kernels/common/shared.h; a polygon: Lambert's formula on the polygon
// clipped at the horizon, pb_polygon_irradiance) times the visibility OpenCL computed, plus the
// unshadowed ambient residual (its pre-integrated irradiance map, Arbree et al. 2005 §3, or its
// SH9,
// Ramamoorthi & Hanrahan 2001 eqs. 3, 7-9: pb_sh9, PB_SH_AHAT),
// clamped at 0, times albedo / pi; background pixels show the environment's nearest texel with
// alpha 0. Texel (x, y) of the G-buffer textures is GL's (bottom-up); visibility rows are
// penumbra's (top-down), so they are read at row H - 1 - y.
uniform sampler2D uPos, uNrm, uAlb;
uniform sampler2DArray uVis;    // R32F, W x H x lights
// PB_POLYGONS (defined when the program is built): 1 in the variant for light sets with polygon
// lights. llvmpipe runs the polygon code (its local array) at 7x the cost of the cap-only loop
// even where no pixel takes that branch: 850 vs 130 ms at 640x360, 32 cap lights.
// Per light (dir, cos alpha), (radiance, polygon vertex count: 0 for a cap); PB_MAX_LIGHTS is
// defined from shared.h when the program is built. A uniform block, not a texture: llvmpipe reads
// it without going through its texture sampler, for every light at every pixel.
layout(std140) uniform Lights { vec4 uLight[2 * PB_MAX_LIGHTS]; };
uniform sampler2D uEnv;         // RGB32F equirect
uniform sampler2D uPolys;       // RGBA32F, PB_MAX_POLY_VERTS x lights: polygon vertices
uniform int uLightCount, uBackground, uEnvW, uEnvH, uWidth, uHeight;
uniform float uEnvShift;
uniform vec3 uFwd, uRight, uUp;  // camera basis; uTan: tan of the half-angles
uniform vec2 uTan;
uniform vec3 uAmbient[9];
// The ambient's pre-integrated irradiance map (uAmbientMapW x H RGB32F; 0: use uAmbient's SH9):
// GL_LINEAR, GL_REPEAT in s, clamped in t, read at pb_ambient_map_taps's coordinates.
uniform sampler2D uAmbientMap;
uniform int uAmbientMapW, uAmbientMapH;
out vec4 fragColor;

const float PI = 3.14159265358979323846;

float capIrradiance(float cos_alpha, float cos_beta) {  // pb_cap_irradiance
  float sin2a = 1.0 - cos_alpha * cos_alpha;
  float sin_a = sqrt(max(sin2a, 0.0));
  if (cos_beta >= sin_a) return PI * sin2a * cos_beta;
  if (cos_beta <= -sin_a) return 0.0;
  float sin_b = sqrt(max(0.0, 1.0 - cos_beta * cos_beta));
  float x = cos_alpha / sin_a;
  float y = clamp(-x * cos_beta / sin_b, -1.0, 1.0);
  float sy = sqrt(1.0 - y * y);
  float e = (cos_beta * acos(y) - x * sin_b * sy) * sin2a + atan(sin_b * sy / x);
  return max(e, 0.0);
}

#if PB_POLYGONS
// pb_polygon_irradiance: the polygon (unit vertices, counter-clockwise) clipped by the tangent
// plane, then E = 1/2 sum over edges of theta_e (n . g_e / |g_e|), g_e = a x b, theta_e the angle
// between a and b (Lambert's formula for a polygon of unit radiance).
float polygonIrradiance(int l, int nv, vec3 n) {
  vec3 c[PB_MAX_POLY_VERTS + 1];
  int nc = 0;
  for (int i = 0; i < nv; ++i) {
    int j = i + 1 == nv ? 0 : i + 1;
    vec3 a = texelFetch(uPolys, ivec2(i, l), 0).xyz, b = texelFetch(uPolys, ivec2(j, l), 0).xyz;
    float da = dot(n, a), db = dot(n, b);
    if (da >= 0.0 && nc < PB_MAX_POLY_VERTS + 1) c[nc++] = a;
    if ((da >= 0.0) != (db >= 0.0) && nc < PB_MAX_POLY_VERTS + 1)
      c[nc++] = (da > db ? 1.0 : -1.0) * (b * da - a * db);  // the edge's point on the horizon
  }
  if (nc < 3) return 0.0;
  float e = 0.0;
  for (int i = 0; i < nc; ++i) {
    vec3 a = c[i], b = c[i + 1 == nc ? 0 : i + 1];
    vec3 g = cross(a, b);
    float len = length(g);
    if (len <= 0.0) continue;
    e += atan(len, dot(a, b)) * dot(n, g) / len;
  }
  return max(0.5 * e, 0.0);
}
#endif

void sh9(vec3 n, out float b[9]) {  // pb_sh9
  b[0] = 0.282094791773878;
  b[1] = 0.488602511902920 * n.y;
  b[2] = 0.488602511902920 * n.z;
  b[3] = 0.488602511902920 * n.x;
  b[4] = 1.092548430592079 * n.x * n.y;
  b[5] = 1.092548430592079 * n.y * n.z;
  b[6] = 0.315391565252520 * (3.0 * n.z * n.z - 1.0);
  b[7] = 1.092548430592079 * n.x * n.z;
  b[8] = 0.546274215296040 * (n.x * n.x - n.y * n.y);
}

int envColumn(float s, float shift, int width) {  // pb_env_column
  float whole = floor(shift), frac = shift - whole;
  int c = int(floor(s + frac));
  if (c >= width) c = frac > 0.0 ? c - width : width - 1;
  if (c < 0) c = 0;
  c += int(whole);
  return c >= width ? c - width : c;
}

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 pos = texelFetch(uPos, p, 0);
  if (pos.w <= 0.5) {
    vec3 rgb = vec3(0.0);
    if (uBackground != 0) {
      // the camera ray of penumbra pixel (x, H - 1 - y): sy = 1 - 2 (H - 1 - y + 0.5) / H
      float sx = 2.0 * (float(p.x) + 0.5) / float(uWidth) - 1.0;
      float sy = 2.0 * (float(p.y) + 0.5) / float(uHeight) - 1.0;
      vec3 d = uFwd + sx * uTan.x * uRight + sy * uTan.y * uUp;
      // pb_dir_equirect
      float cy = clamp(d.y / length(d), -1.0, 1.0);
      float s = (atan(d.x, -d.z) / (2.0 * PI) + 0.5) * float(uEnvW);
      float t = acos(cy) / PI * float(uEnvH);
      int si = envColumn(s, uEnvShift, uEnvW);
      int ti = clamp(int(floor(t)), 0, uEnvH - 1);
      rgb = texelFetch(uEnv, ivec2(si, ti), 0).rgb;
    }
    fragColor = vec4(rgb, 0.0);
    return;
  }
  vec3 n = texelFetch(uNrm, p, 0).xyz;
  vec3 acc = vec3(0.0);
  int row = uHeight - 1 - p.y;
  for (int l = 0; l < uLightCount; ++l) {
    vec4 dir = uLight[2 * l], rad = uLight[2 * l + 1];
#if PB_POLYGONS
    int nv = int(rad.w);
    float e = nv >= 3 ? polygonIrradiance(l, min(nv, PB_MAX_POLY_VERTS), n)
                      : capIrradiance(dir.w, dot(n, dir.xyz));
#else
    float e = capIrradiance(dir.w, dot(n, dir.xyz));
#endif
    if (e <= 0.0) continue;
    float V = texelFetch(uVis, ivec3(p.x, row, l), 0).r;
    acc += e * V * rad.rgb;
  }
  if (uAmbientMapW > 0) {
    // pb_ambient_map_taps: column s = (phi / 2 pi + 0.5) W (texel centres at i + 0.5, as GL's),
    // node row v = theta / pi (H - 1), which is GL's texel centre v + 0.5.
    float cy = clamp(n.y / length(n), -1.0, 1.0);
    // atan(0, 0) is undefined in GLSL (OpenCL's atan2 gives pi): at the poles every column of the
    // node row holds the same value, so any s will do.
    float s = (n.x == 0.0 && n.z == 0.0) ? 0.5 : atan(n.x, -n.z) / (2.0 * PI) + 0.5;
    float v = uAmbientMapH > 1 ? acos(cy) / PI * float(uAmbientMapH - 1) : 0.0;
    acc += texture(uAmbientMap, vec2(s, (v + 0.5) / float(uAmbientMapH))).rgb;
  } else {
    float Y[9];
    sh9(n, Y);
    for (int k = 0; k < 9; ++k) {
      float ahat = k == 0 ? 3.14159265358979 : (k < 4 ? 2.09439510239320 : 0.785398163397448);
      acc += ahat * Y[k] * uAmbient[k];
    }
  }
  acc = max(acc, vec3(0.0));
  fragColor = vec4(acc * texelFetch(uAlb, p, 0).rgb * (1.0 / PI), 1.0);
}
