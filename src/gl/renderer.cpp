// `render --gl`: GL rasterizes the camera G-buffer and one shadow map per light from the scene's
// triangles, Interop computes visibility in OpenCL and shades in GL (interop.hpp).
// One thread only (interop.hpp, "Thread safety"): every GL call below acts on the context current
// on the calling thread, so unlike Renderer there is no lock that could make sharing safe; the
// OpenCL Context it renders on may be shared.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "glfuncs.hpp"
#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/gl/interop.hpp"
#include "render/options_check.hpp"

namespace penumbra::gl {

namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}
using M4 = std::array<float, 16>;  // column-major
M4 mul(const M4& a, const M4& b) {
  M4 r{};
  for (int c = 0; c < 4; ++c)
    for (int rr = 0; rr < 4; ++rr) {
      float s = 0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + rr] * b[c * 4 + k];
      r[c * 4 + rr] = s;
    }
  return r;
}
float dot3(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
}  // namespace

struct GLRenderer::Impl {
  Context& ctx;
  Interop interop;
  detail::GLFunctions gl;
  GLuint gbufferProgram = 0, depthProgram = 0, vao = 0, vbo = 0, fbo = 0;
  GLuint gtex[4] = {0, 0, 0, 0}, gdepth = 0, output = 0;  // position, normal, geometric, albedo
  int gw = 0, gh = 0;
  std::vector<GLuint> maps;
  int mapSize = 0;
  std::vector<float> vertices, readback;

  Impl(Context& c, ProcLoader loader) : ctx(c), interop(c, loader) {
    gl.load(loader ? loader : currentContextLoader());
    gbufferProgram = gl.program("gbuffer", detail::shaderSource("gbuffer.vert"),
                                detail::shaderSource("gbuffer.frag"));
    depthProgram = gl.program("depth", detail::shaderSource("depth.vert"),
                              detail::shaderSource("depth.frag"));
    gl.GenVertexArrays(1, &vao);
    gl.GenBuffers(1, &vbo);
    gl.GenFramebuffers(1, &fbo);
    gl.check("creating the GL renderer's objects");
  }
  ~Impl() {
    if (!currentContextLoader()) return;
    gl.DeleteTextures(4, gtex);
    gl.DeleteTextures(1, &gdepth);
    gl.DeleteTextures(1, &output);
    if (!maps.empty()) gl.DeleteTextures(GLsizei(maps.size()), maps.data());
    gl.DeleteFramebuffers(1, &fbo);
    gl.DeleteBuffers(1, &vbo);
    gl.DeleteVertexArrays(1, &vao);
    gl.DeleteProgram(gbufferProgram);
    gl.DeleteProgram(depthProgram);
  }

  GLuint texture(GLenum internal, int w, int h, GLenum format, GLenum type) {
    GLuint t = 0;
    gl.GenTextures(1, &t);
    gl.BindTexture(GL_TEXTURE_2D, t);
    gl.TexImage2D(GL_TEXTURE_2D, 0, GLint(internal), w, h, 0, format, type, nullptr);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    return t;
  }

  void resize(int W, int H, int S, int nl) {
    if (W != gw || H != gh) {
      if (gw) {
        gl.DeleteTextures(4, gtex);
        gl.DeleteTextures(1, &gdepth);
        gl.DeleteTextures(1, &output);
      }
      for (GLuint& t : gtex) t = texture(GL_RGBA32F, W, H, GL_RGBA, GL_FLOAT);
      gdepth = texture(GL_DEPTH_COMPONENT32F, W, H, GL_DEPTH_COMPONENT, GL_FLOAT);
      output = texture(GL_RGBA32F, W, H, GL_RGBA, GL_FLOAT);
      gw = W;
      gh = H;
    }
    if (S != mapSize && !maps.empty()) {
      gl.DeleteTextures(GLsizei(maps.size()), maps.data());
      maps.clear();
    }
    mapSize = S;
    while (int(maps.size()) < nl)
      maps.push_back(texture(GL_DEPTH_COMPONENT32F, S, S, GL_DEPTH_COMPONENT, GL_FLOAT));
    gl.check("allocating G-buffer and shadow-map textures");
  }

  void draw(int count) {
    gl.BindVertexArray(vao);
    gl.DrawArrays(GL_TRIANGLES, 0, count);
    gl.BindVertexArray(0);
  }
};

GLRenderer::GLRenderer(Context& cl, ProcLoader loader)
    : impl_(std::make_unique<Impl>(cl, loader)) {}
GLRenderer::~GLRenderer() = default;
Interop& GLRenderer::interop() { return impl_->interop; }

Frame GLRenderer::render(const Scene& scene, const Camera& camera, const LightSet& lights,
                         const Environment& env, const RenderOptions& opt) {
  auto tStart = Clock::now();
  Impl& m = *impl_;
  auto& gl = m.gl;
  // The OpenCL renderer's checks, with the same field-named messages.
  penumbra::detail::validateFrameInputs(scene, camera, lights, env, opt);
  const int W = opt.width, H = opt.height, S = opt.shadowMapSize;
  const int nl = int(lights.lights.size());
  std::vector<std::pair<std::string, double>> glTimes;
  while (gl.GetError() != GL_NO_ERROR) {
  }

  // --- scene: unindexed triangles, 13 floats a vertex (position, normal + has-normal flag,
  // geometric normal, albedo)
  auto t0 = Clock::now();
  m.vertices.clear();
  for (const Mesh& mesh : scene.meshes) {
    bool hasN = mesh.normals.size() == mesh.positions.size();
    for (auto& t : mesh.triangles) {
      const Vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
      Vec3 e1{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      Vec3 gn{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
              e1[0] * e2[1] - e1[1] * e2[0]};
      for (int k = 0; k < 3; ++k) {
        const Vec3& p = mesh.positions[t[k]];
        Vec3 n = hasN ? mesh.normals[t[k]] : Vec3{0, 0, 0};
        float v[13] = {p[0], p[1], p[2], n[0], n[1], n[2], hasN ? 1.0f : 0.0f, gn[0], gn[1], gn[2],
                       mesh.albedo[0], mesh.albedo[1], mesh.albedo[2]};
        m.vertices.insert(m.vertices.end(), v, v + 13);
      }
    }
  }
  const int count = int(m.vertices.size() / 13);
  gl.BindVertexArray(m.vao);
  gl.BindBuffer(GL_ARRAY_BUFFER, m.vbo);
  gl.BufferData(GL_ARRAY_BUFFER, GLsizeiptr(m.vertices.size() * 4), m.vertices.data(),
                GL_DYNAMIC_DRAW);
  const int offsets[4] = {0, 3, 7, 10}, sizes[4] = {3, 4, 3, 3};
  for (int i = 0; i < 4; ++i) {
    gl.VertexAttribPointer(i, sizes[i], GL_FLOAT, GL_FALSE, 13 * 4,
                           reinterpret_cast<const void*>(std::size_t(offsets[i]) * 4));
    gl.EnableVertexAttribArray(i);
  }
  gl.BindVertexArray(0);
  m.resize(W, H, S, nl);
  gl.check("uploading the scene");
  gl.Finish();
  glTimes.emplace_back("gl/scene", msSince(t0));

  // --- camera G-buffer: penumbra's camera (scene.hpp cameraBasis) as a GL perspective; near and
  // far planes bracket the scene's bounds
  t0 = Clock::now();
  CameraBasis cb = cameraBasis(camera, W, H);
  Bounds bounds = scene.bounds();
  float zmax = 0;
  for (int i = 0; i < 8; ++i) {
    Vec3 c = {i & 1 ? bounds.hi[0] : bounds.lo[0], i & 2 ? bounds.hi[1] : bounds.lo[1],
              i & 4 ? bounds.hi[2] : bounds.lo[2]};
    zmax = std::max(zmax, dot3({c[0] - cb.eye[0], c[1] - cb.eye[1], c[2] - cb.eye[2]}, cb.forward));
  }
  float farZ = std::max(zmax * 1.01f, 1e-3f), nearZ = std::max(farZ * 1e-5f, 1e-5f);
  M4 view{}, proj{};
  const Vec3* axes[3] = {&cb.right, &cb.up, &cb.forward};
  for (int r = 0; r < 3; ++r) {
    float sign = r == 2 ? -1.0f : 1.0f;  // eye z = -forward
    for (int c = 0; c < 3; ++c) view[c * 4 + r] = sign * (*axes[r])[c];
    view[12 + r] = -sign * dot3(*axes[r], cb.eye);
  }
  view[15] = 1;
  proj[0] = 1.0f / cb.tanHalfX;
  proj[5] = 1.0f / cb.tanHalfY;
  proj[10] = -(farZ + nearZ) / (farZ - nearZ);
  proj[11] = -1.0f;
  proj[14] = -2.0f * farZ * nearZ / (farZ - nearZ);
  M4 viewProj = mul(proj, view);
  GLint prevFbo = 0;
  gl.GetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &prevFbo);
  gl.BindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  for (int i = 0; i < 4; ++i)
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + i, GL_TEXTURE_2D, m.gtex[i], 0);
  gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, m.gdepth, 0);
  GLenum bufs[4] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2,
                    GL_COLOR_ATTACHMENT3};
  gl.DrawBuffers(4, bufs);
  if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw Error(ErrorKind::Device, "OpenGL: G-buffer framebuffer incomplete");
  gl.Viewport(0, 0, W, H);
  const float zero[4] = {0, 0, 0, 0}, up[4] = {0, 1, 0, 0}, one = 1.0f;
  gl.ClearBufferfv(GL_COLOR, 0, zero);  // as gbuffer_resolve writes empty pixels
  gl.ClearBufferfv(GL_COLOR, 1, up);
  gl.ClearBufferfv(GL_COLOR, 2, up);
  gl.ClearBufferfv(GL_COLOR, 3, zero);
  gl.ClearBufferfv(GL_DEPTH, 0, &one);
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_LESS);
  gl.DepthMask(GL_TRUE);
  gl.Disable(GL_CULL_FACE);
  gl.UseProgram(m.gbufferProgram);
  gl.UniformMatrix4fv(gl.GetUniformLocation(m.gbufferProgram, "uViewProj"), 1, GL_FALSE,
                      viewProj.data());
  gl.Uniform3f(gl.GetUniformLocation(m.gbufferProgram, "uEye"), cb.eye[0], cb.eye[1], cb.eye[2]);
  gl.Uniform1f(gl.GetUniformLocation(m.gbufferProgram, "uFar"), farZ * 2.0f);
  m.draw(count);
  for (int i = 0; i < 4; ++i)
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + i, GL_TEXTURE_2D, 0, 0);
  gl.check("rasterizing the G-buffer");
  gl.Finish();
  glTimes.emplace_back("gl/gbuffer", msSince(t0));

  // --- shadow maps, one depth texture per light, penumbra's light frames
  t0 = Clock::now();
  std::vector<LightView> views = m.interop.lightViews(lights, bounds, S);
  GLenum noColor = GL_NONE;
  gl.DrawBuffers(1, &noColor);
  gl.Viewport(0, 0, S, S);
  gl.UseProgram(m.depthProgram);
  GLint vp = gl.GetUniformLocation(m.depthProgram, "uViewProj");
  for (int l = 0; l < nl; ++l) {
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, m.maps[l], 0);
    if (l == 0 && gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw Error(ErrorKind::Device, "OpenGL: shadow-map framebuffer incomplete");
    gl.ClearBufferfv(GL_DEPTH, 0, &one);
    M4 lvp = mul(views[l].projection, views[l].view);
    gl.UniformMatrix4fv(vp, 1, GL_FALSE, lvp.data());
    m.draw(count);
  }
  gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, 0, 0);
  gl.UseProgram(0);
  gl.Disable(GL_DEPTH_TEST);
  gl.BindFramebuffer(GL_FRAMEBUFFER, GLuint(prevFbo));
  gl.check("rasterizing the shadow maps");
  gl.Finish();
  glTimes.emplace_back("gl/shadow-maps", msSince(t0));

  // --- visibility (OpenCL) and shading (GL)
  std::vector<TextureId> mapIds(m.maps.begin(), m.maps.begin() + nl);
  GBuffer g{m.gtex[0], m.gtex[1], m.gtex[3], m.gtex[2]};
  m.interop.shade(mapIds, g, m.output, camera, lights, bounds, env, opt, findGround(scene));

  // --- the shaded texture back to the host (what a GL application would not do: it samples it)
  t0 = Clock::now();
  Frame frame;
  frame.image = Image(W, H, 4);
  m.readback.resize(std::size_t(W) * H * 4);
  gl.BindTexture(GL_TEXTURE_2D, m.output);
  gl.PixelStorei(GL_PACK_ALIGNMENT, 4);
  gl.GetTexImage(GL_TEXTURE_2D, 0, GL_RGBA, GL_FLOAT, m.readback.data());
  gl.check("reading back the frame");
  for (int y = 0; y < H; ++y)
    std::copy_n(m.readback.data() + std::size_t(H - 1 - y) * W * 4, std::size_t(W) * 4,
                frame.image.pixels.data() + std::size_t(y) * W * 4);
  glTimes.emplace_back("gl/readback", msSince(t0));

  frame.timingsMs = m.ctx.stageTimesMs();
  for (auto& t : glTimes) frame.timingsMs.insert(frame.timingsMs.end() - 0, t);
  for (auto& t : m.interop.timingsMs()) frame.timingsMs.push_back(t);
  frame.timingsMs.emplace_back("total", msSince(tStart));
  frame.stats = m.interop.stats();
  return frame;
}

}  // namespace penumbra::gl
