// How an OpenGL renderer uses penumbra's GL interop: it keeps its own context, meshes, shaders and
// textures; penumbra computes soft-shadow visibility in OpenCL and shades into a texture the
// renderer then samples. Usage: gl_integration OUT.png [OUT.exr] [WIDTHxHEIGHT]
// (The built-in scene and sky stand in for the application's own.)
#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include <penumbra/gl/interop.hpp>
#include <penumbra/penumbra.hpp>

using namespace penumbra;

static GLuint shader(const char* vs, const char* fs) {
  GLuint p = glCreateProgram();
  for (auto [type, src] : {std::pair{GL_VERTEX_SHADER, vs}, std::pair{GL_FRAGMENT_SHADER, fs}}) {
    GLuint s = glCreateShader(type);
    glShaderSource(s, 1, &src, nullptr);
    glCompileShader(s);
    glAttachShader(p, s);
  }
  GLint ok = 0;
  glLinkProgram(p), glGetProgramiv(p, GL_LINK_STATUS, &ok);
  return ok ? p : throw std::runtime_error("shader failed to link");
}

static GLuint texture(GLenum internal, int w, int h, GLenum format, GLenum type) {
  GLuint t;
  glGenTextures(1, &t), glBindTexture(GL_TEXTURE_2D, t);
  glTexImage2D(GL_TEXTURE_2D, 0, internal, w, h, 0, format, type, nullptr);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  return t;
}

// The application's shaders: a G-buffer pass (world position, normal, albedo) and a depth pass.
const char* kGBufferVS = R"(#version 330 core
layout(location = 0) in vec3 aPos; layout(location = 1) in vec3 aNrm; layout(location = 2) in vec3 aAlb;
uniform mat4 uViewProj; out vec3 vPos, vNrm, vAlb;
void main() { vPos = aPos; vNrm = aNrm; vAlb = aAlb; gl_Position = uViewProj * vec4(aPos, 1.0); })";
const char* kGBufferFS = R"(#version 330 core
in vec3 vPos, vNrm, vAlb; uniform vec3 uEye; uniform float uFar;
layout(location = 0) out vec4 oPos; layout(location = 1) out vec4 oNrm; layout(location = 2) out vec4 oAlb;
void main() {
  vec3 n = normalize(vNrm);
  if (dot(n, uEye - vPos) < 0.0) n = -n;  // facing the camera
  gl_FragDepth = length(vPos - uEye) / uFar;  // linear: surfaces millimetres apart stay ordered
  oPos = vec4(vPos, 1.0); oNrm = vec4(n, 0.0); oAlb = vec4(vAlb, 1.0);
})";
const char* kDepthVS = R"(#version 330 core
layout(location = 0) in vec3 aPos; uniform mat4 uViewProj;
void main() { gl_Position = uViewProj * vec4(aPos, 1.0); })";
const char* kDepthFS = "#version 330 core\nvoid main() {}";
// Sampling penumbra's result: a display pass (Reinhard tone map) as a renderer's final blit.
const char* kDisplayVS = R"(#version 330 core
void main() { gl_Position = vec4(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0, 0.0, 1.0); })";
const char* kDisplayFS = R"(#version 330 core
uniform sampler2D uShaded; uniform vec2 uSize; out vec4 o;
void main() { vec3 c = texture(uShaded, gl_FragCoord.xy / uSize).rgb; o = vec4(c / (1.0 + c), 1.0); })";

static std::array<float, 16> mul(const std::array<float, 16>& a, const std::array<float, 16>& b) {
  std::array<float, 16> r{};
  for (int c = 0; c < 4; ++c)
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 4; ++k) r[c * 4 + i] += a[k * 4 + i] * b[c * 4 + k];
  return r;
}

int main(int argc, char** argv) try {
  std::string png = argc > 1 ? argv[1] : "gl_integration.png", exr = argc > 2 ? argv[2] : "";
  // penumbra's defaults: 64 lights, `auto` (the 24 brightest MSSM4, the rest hard), maps of
  // opt.shadowMapSize texels a side (a map size of the application's own works as well)
  RenderOptions opt;
  int W = 320, H = 180, S = opt.shadowMapSize;
  if (argc > 3) std::sscanf(argv[3], "%dx%d", &W, &H);
  Context cl;  // OpenCL (PoCL here)
  gl::HeadlessContext context(gl::Backend::EGL);          // or the application's own context
  Scene scene = builtinScene();
  Environment env = builtinEnvironment();
  LightSet lights = extractLights(cl, env, ExtractOptions{});  // 64 lights + ambient residual
  Camera camera = frameCamera(scene, float(W) / float(H));

  // The application's vertex buffer: position, normal, albedo per vertex, unindexed.
  std::vector<float> v;
  for (const Mesh& m : scene.meshes)
    for (auto& t : m.triangles) {
      Vec3 a = m.positions[t[0]], e1, e2, fn;  // the face normal where the mesh has no normals
      for (int c = 0; c < 3; ++c) e1[c] = m.positions[t[1]][c] - a[c], e2[c] = m.positions[t[2]][c] - a[c];
      for (int c = 0; c < 3; ++c) fn[c] = e1[(c + 1) % 3] * e2[(c + 2) % 3] - e1[(c + 2) % 3] * e2[(c + 1) % 3];
      for (int k : t) {
        Vec3 p = m.positions[k], n = m.normals.size() == m.positions.size() ? m.normals[k] : fn;
        v.insert(v.end(), {p[0], p[1], p[2], n[0], n[1], n[2], m.albedo[0], m.albedo[1], m.albedo[2]});
      }
    }
  GLuint vao, vbo, fbo;
  glGenVertexArrays(1, &vao), glGenBuffers(1, &vbo), glGenFramebuffers(1, &fbo);
  glBindVertexArray(vao);
  glBindBuffer(GL_ARRAY_BUFFER, vbo);
  glBufferData(GL_ARRAY_BUFFER, v.size() * 4, v.data(), GL_STATIC_DRAW);
  for (int i = 0; i < 3; ++i)
    glVertexAttribPointer(i, 3, GL_FLOAT, GL_FALSE, 36, reinterpret_cast<void*>(std::size_t(i) * 12)), glEnableVertexAttribArray(i);
  const GLsizei count = GLsizei(v.size() / 9);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);

  // Shadow maps: one depth texture per light, in the frames penumbra gives.
  gl::Interop interop(cl);
  std::vector<gl::LightView> views = interop.lightViews(lights, scene.bounds(), S);
  std::vector<gl::TextureId> maps;
  GLuint depthProg = shader(kDepthVS, kDepthFS);
  glUseProgram(depthProg), glDrawBuffer(GL_NONE), glViewport(0, 0, S, S), glEnable(GL_DEPTH_TEST);
  for (auto& lv : views) {
    maps.push_back(texture(GL_DEPTH_COMPONENT32F, S, S, GL_DEPTH_COMPONENT, GL_FLOAT));
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, maps.back(), 0);
    glClear(GL_DEPTH_BUFFER_BIT);
    auto vp = mul(lv.projection, lv.view);
    glUniformMatrix4fv(glGetUniformLocation(depthProg, "uViewProj"), 1, GL_FALSE, vp.data());
    glDrawArrays(GL_TRIANGLES, 0, count);
  }

  // G-buffer: the camera of penumbra's Camera (cameraBasis) as a GL perspective projection.
  CameraBasis b = cameraBasis(camera, W, H);
  Vec3 c = scene.bounds().center();
  const float f = 2 * (std::hypot(b.eye[0] - c[0], b.eye[1] - c[1], b.eye[2] - c[2]) + scene.bounds().radius()), n = f * 1e-4f;
  std::array<float, 16> view{}, proj{};
  for (int c = 0; c < 3; ++c) {
    view[c * 4 + 0] = b.right[c];
    view[c * 4 + 1] = b.up[c];
    view[c * 4 + 2] = -b.forward[c];
    view[12] -= b.right[c] * b.eye[c];
    view[13] -= b.up[c] * b.eye[c];
    view[14] += b.forward[c] * b.eye[c];
  }
  view[15] = 1;
  proj[0] = 1 / b.tanHalfX, proj[5] = 1 / b.tanHalfY;
  proj[10] = -(f + n) / (f - n), proj[11] = -1, proj[14] = -2 * f * n / (f - n);
  gl::GBuffer g;
  g.position = texture(GL_RGBA32F, W, H, GL_RGBA, GL_FLOAT), g.normal = texture(GL_RGBA32F, W, H, GL_RGBA, GL_FLOAT);
  g.albedo = texture(GL_RGBA8, W, H, GL_RGBA, GL_UNSIGNED_BYTE);
  GLuint depth = texture(GL_DEPTH_COMPONENT24, W, H, GL_DEPTH_COMPONENT, GL_FLOAT);
  GLuint gbufProg = shader(kGBufferVS, kGBufferFS);
  glUseProgram(gbufProg);
  GLenum bufs[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
  gl::TextureId targets[3] = {g.position, g.normal, g.albedo};
  for (int i = 0; i < 3; ++i)
    glFramebufferTexture2D(GL_FRAMEBUFFER, bufs[i], GL_TEXTURE_2D, targets[i], 0);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth, 0);
  glDrawBuffers(3, bufs);
  glViewport(0, 0, W, H);
  glClearColor(0, 0, 0, 0);  // position alpha 0: background
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  auto vp = mul(proj, view);
  glUniformMatrix4fv(glGetUniformLocation(gbufProg, "uViewProj"), 1, GL_FALSE, vp.data());
  glUniform3f(glGetUniformLocation(gbufProg, "uEye"), b.eye[0], b.eye[1], b.eye[2]);
  glUniform1f(glGetUniformLocation(gbufProg, "uFar"), f);
  glDrawArrays(GL_TRIANGLES, 0, count);

  // penumbra: visibility (OpenCL) and shading (GL) into the application's texture; the scene's
  // ground lets it take off the part of each low light that the ground hides.
  GLuint shaded = texture(GL_RGBA16F, W, H, GL_RGBA, GL_FLOAT), display = texture(GL_RGBA8, W, H, GL_RGBA, GL_UNSIGNED_BYTE);
  interop.shade(maps, g, shaded, camera, lights, scene.bounds(), env, opt, findGround(scene));

  // Sample it: the display pass into an 8-bit target, read back for the PNG.
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  for (int i = 0; i < 3; ++i) glFramebufferTexture2D(GL_FRAMEBUFFER, bufs[i], GL_TEXTURE_2D, 0, 0);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, display, 0);
  glDrawBuffers(1, bufs), glDisable(GL_DEPTH_TEST);
  GLuint dispProg = shader(kDisplayVS, kDisplayFS);
  glUseProgram(dispProg), glActiveTexture(GL_TEXTURE0), glBindTexture(GL_TEXTURE_2D, shaded);
  glUniform2f(glGetUniformLocation(dispProg, "uSize"), float(W), float(H));
  glDrawArrays(GL_TRIANGLES, 0, 3);
  std::vector<unsigned char> rgba(std::size_t(W) * H * 4);
  glReadPixels(0, 0, W, H, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  Image out(W, H, 3);
  for (int y = 0; y < H; ++y)  // GL rows go bottom-up, images top-down; Reinhard undone, as
    for (int x = 0; x < W; ++x)  // writeImage tone-maps itself
      for (int c = 0; c < 3; ++c) {
        float s = rgba[(std::size_t(H - 1 - y) * W + x) * 4 + c] / 255.0f;
        out.at(x, y, c) = s < 1.0f ? s / (1.0f - s) : 1e3f;
      }
  writeImage(png, out, 1.0f);
  if (!exr.empty()) {  // the linear result itself, for comparison with `penumbra render`
    Image lin(W, H, 4);
    std::vector<float> px(std::size_t(W) * H * 4);
    glBindTexture(GL_TEXTURE_2D, shaded);
    glGetTexImage(GL_TEXTURE_2D, 0, GL_RGBA, GL_FLOAT, px.data());
    for (int y = 0; y < H; ++y)
      std::copy_n(&px[std::size_t(H - 1 - y) * W * 4], std::size_t(W) * 4, &lin.pixels[std::size_t(y) * W * 4]);
    writeImage(exr, lin);
  }
  if (glGetError() != GL_NO_ERROR) throw std::runtime_error("a GL call failed");
  std::printf("gl_integration: wrote %s (%dx%d, %zu lights, %s)\n", png.c_str(), W, H,
              lights.lights.size(), context.description().c_str());
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "gl_integration: %s\n", e.what());
  return 1;
}
