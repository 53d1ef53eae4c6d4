// GL interop: application textures in, OpenCL visibility, GL shading out (interop.hpp).
#include "penumbra/gl/interop.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "lights/light_buffers.hpp"
#include "render/visibility.hpp"
#include "scene/shadow_offset.hpp"
#include "shadows/shadow_pass.hpp"
#include "glfuncs.hpp"
#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"

namespace penumbra::gl {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

const char* formatName(GLint f) {
  switch (f) {
    case GL_DEPTH_COMPONENT16: return "GL_DEPTH_COMPONENT16";
    case GL_DEPTH_COMPONENT24: return "GL_DEPTH_COMPONENT24";
    case GL_DEPTH_COMPONENT32: return "GL_DEPTH_COMPONENT32";
    case GL_DEPTH_COMPONENT32F: return "GL_DEPTH_COMPONENT32F";
    case GL_RGBA32F: return "GL_RGBA32F";
    case GL_RGBA16F: return "GL_RGBA16F";
    case GL_RGBA8: return "GL_RGBA8";
    case GL_RGB32F: return "GL_RGB32F";
    case GL_RGBA: return "GL_RGBA";
    case GL_RGB8: return "GL_RGB8";
    case GL_R32F: return "GL_R32F";
    default: return "another format";
  }
}

// The interop has depth textures but no triangles: a technique that asks for more depth maps is
// refused (shade() already refuses those techniques by name; this names what was asked for).
class NoRasterizer : public penumbra::detail::DepthRasterizer {
 public:
  void depthMaps(const std::vector<pb_view>&, cl::Buffer&, const std::string& prefix) override {
    badInput("GL interop: " + prefix + " needs depth maps rasterized from the scene");
  }
};

}  // namespace

struct Interop::Impl {
  Context& ctx;
  detail::GLFunctions gl;
  penumbra::detail::BufferPool pool;
  penumbra::detail::Visibility visibility;
  std::vector<std::pair<std::string, double>> timings;
  GLuint programs[2] = {0, 0}, program = 0;  // shade.frag without, with polygon lights
  GLuint vao = 0, fbo = 0, sampler = 0, lightUbo = 0;
  // The ambient irradiance map's sampler: bilinear between texel centres, wrapping in longitude,
  // clamped in latitude, as shared.h's pb_ambient_map_taps reads it in OpenCL.
  GLuint ambientSampler = 0;
  int maxLights = PB_MAX_LIGHTS;
  GLuint visTex = 0, envTex = 0, polyTex = 0, ambientTex = 0;
  int visW = 0, visH = 0, visL = 0;
  std::vector<float> hostGL, hostVis;

  Impl(Context& c, ProcLoader loader) : ctx(c), pool(c), visibility(c, pool) {
    gl.load(loader ? loader : currentContextLoader());
    // The lights' uniform block holds 32 bytes a light; GL 3.3 guarantees 16 KiB blocks.
    GLint blockBytes = 16384;
    gl.GetIntegerv(GL_MAX_UNIFORM_BLOCK_SIZE, &blockBytes);
    maxLights = std::min<int>(PB_MAX_LIGHTS, blockBytes / 32);
    for (int polygons = 0; polygons < 2; ++polygons) {
      std::string frag = detail::shaderSource("shade.frag");
      frag.insert(frag.find('\n') + 1,
                  "#define PB_MAX_POLY_VERTS " + std::to_string(PB_MAX_POLY_VERTS) +
                      "\n#define PB_MAX_LIGHTS " + std::to_string(maxLights) +
                      "\n#define PB_POLYGONS " + std::to_string(polygons) + "\n");
      programs[polygons] =
          gl.program("shade", detail::shaderSource("fullscreen.vert"), frag);
      gl.UniformBlockBinding(programs[polygons],
                             gl.GetUniformBlockIndex(programs[polygons], "Lights"), 0);
    }
    gl.GenVertexArrays(1, &vao);
    gl.GenFramebuffers(1, &fbo);
    gl.GenSamplers(1, &sampler);
    gl.GenBuffers(1, &lightUbo);
    // texelFetch through a sampler whose filter needs no mip levels: an application texture
    // with only level 0 and the default GL_NEAREST_MIPMAP_LINEAR would otherwise be incomplete
    // and read as zeros.
    gl.SamplerParameteri(sampler, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.SamplerParameteri(sampler, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl.GenSamplers(1, &ambientSampler);
    gl.SamplerParameteri(ambientSampler, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    gl.SamplerParameteri(ambientSampler, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    gl.SamplerParameteri(ambientSampler, GL_TEXTURE_WRAP_S, GL_REPEAT);
    gl.SamplerParameteri(ambientSampler, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    GLuint t[4];
    gl.GenTextures(4, t);
    visTex = t[0];
    envTex = t[1];
    polyTex = t[2];
    ambientTex = t[3];
    gl.check("creating the interop's GL objects");
  }
  ~Impl() {
    // The context may be gone already (an application tearing down in another order); deleting
    // names then is harmless to skip, so only do it while some context is current.
    if (!currentContextLoader()) return;
    GLuint t[4] = {visTex, envTex, polyTex, ambientTex};
    gl.DeleteTextures(4, t);
    gl.DeleteSamplers(1, &sampler);
    gl.DeleteSamplers(1, &ambientSampler);
    gl.DeleteBuffers(1, &lightUbo);
    gl.DeleteFramebuffers(1, &fbo);
    gl.DeleteVertexArrays(1, &vao);
    gl.DeleteProgram(programs[0]);
    gl.DeleteProgram(programs[1]);
  }

  struct TexInfo {
    int width = 0, height = 0;
    GLint format = 0;
  };
  TexInfo inspect(TextureId id, const std::string& what) {
    while (gl.GetError() != GL_NO_ERROR) {
    }
    if (id == 0 || !gl.IsTexture(id))
      badInput("GL interop: " + what + " (texture " + std::to_string(id) +
               ") is not a GL texture name");
    gl.BindTexture(GL_TEXTURE_2D, id);
    if (gl.GetError() != GL_NO_ERROR)
      badInput("GL interop: " + what + " (texture " + std::to_string(id) +
               ") is not a GL_TEXTURE_2D");
    TexInfo t;
    gl.GetTexLevelParameteriv(GL_TEXTURE_2D, 0, GL_TEXTURE_WIDTH, &t.width);
    gl.GetTexLevelParameteriv(GL_TEXTURE_2D, 0, GL_TEXTURE_HEIGHT, &t.height);
    gl.GetTexLevelParameteriv(GL_TEXTURE_2D, 0, GL_TEXTURE_INTERNAL_FORMAT, &t.format);
    gl.check("inspecting " + what);
    return t;
  }
  static std::string describe(const std::string& what, TextureId id, const TexInfo& t) {
    return "GL interop: " + what + " (texture " + std::to_string(id) + ", " +
           std::to_string(t.width) + "x" + std::to_string(t.height) + " " +
           formatName(t.format) + ")";
  }
  void expect(const std::string& what, TextureId id, int w, int h,
              std::initializer_list<GLint> formats, const char* formatList) {
    TexInfo t = inspect(id, what);
    if (std::find(formats.begin(), formats.end(), t.format) == formats.end())
      badInput(describe(what, id, t) + " has the wrong format; expected " + formatList);
    if (t.width != w || t.height != h)
      badInput(describe(what, id, t) + " has the wrong size; expected " + std::to_string(w) +
               "x" + std::to_string(h));
  }

  // glGetTexImage into host memory, then clEnqueueWriteBuffer: the host-copy path.
  void upload(TextureId id, GLenum format, std::size_t floats, cl::Buffer& dst,
              std::size_t offsetFloats, const std::string& what) {
    if (hostGL.size() < floats) hostGL.resize(floats);
    gl.BindTexture(GL_TEXTURE_2D, id);
    gl.PixelStorei(GL_PACK_ALIGNMENT, 4);
    gl.GetTexImage(GL_TEXTURE_2D, 0, format, GL_FLOAT, hostGL.data());
    gl.check("reading back " + what);
    try {
      ctx.queue().enqueueWriteBuffer(dst, CL_TRUE, offsetFloats * 4, floats * 4, hostGL.data());
    } catch (const cl::Error& e) {
      rethrowCl(e, "uploading " + what);
    }
  }

  void bind(int unit, GLenum target, GLuint tex, const char* name, GLuint withSampler = 0) {
    gl.ActiveTexture(GL_TEXTURE0 + unit);
    gl.BindTexture(target, tex);
    gl.BindSampler(unit, withSampler ? withSampler : sampler);
    gl.Uniform1i(gl.GetUniformLocation(program, name), unit);
  }
};

Interop::Interop(Context& cl, ProcLoader loader) : impl_(std::make_unique<Impl>(cl, loader)) {}
Interop::~Interop() = default;

const std::vector<std::pair<std::string, double>>& Interop::timingsMs() const {
  return impl_->timings;
}

const std::vector<std::pair<std::string, double>>& Interop::stats() const {
  return impl_->visibility.stats();
}

std::vector<LightView> Interop::lightViews(const LightSet& lights, const Bounds& bounds,
                                           int size) const {
  std::vector<LightView> out;
  for (auto& l : lights.lights) {
    pb_light L = penumbra::detail::lightFrame(l.direction, l.cosAlpha, l.radiance, bounds);
    LightView v;
    // Eye space: x along ex, y along ey, z along dir (GL looks down -z, the light's forward is
    // -dir), origin at the centre of the map's near plane; so eye z = -(distance from it).
    const float* axes[3] = {L.ex, L.ey, L.dir};
    for (int r = 0; r < 3; ++r) {
      float t = 0;
      for (int c = 0; c < 3; ++c) {
        v.view[c * 4 + r] = axes[r][c];
        t -= axes[r][c] * L.origin[c];
      }
      v.view[12 + r] = t;
    }
    v.view[15] = 1;
    // Orthographic: x / half-width, y / half-height (raster.cl's ortho view_ray), window depth =
    // distance / range (z_ndc = 2 d / range - 1 with d = -z_eye).
    v.range = L.origin[3];
    v.projection[0] = 1.0f / L.ex[3];
    v.projection[5] = 1.0f / L.ey[3];
    v.projection[10] = -2.0f / v.range;
    v.projection[14] = -1.0f;
    v.projection[15] = 1.0f;
    v.size = size;
    out.push_back(v);
  }
  return out;
}

void Interop::shade(const std::vector<TextureId>& depthMaps, const GBuffer& g, TextureId output,
                    const Camera& camera, const LightSet& lightSet, const Bounds& bounds,
                    const Environment& env, const RenderOptions& options,
                    const std::optional<GroundPlane>& ground) {
  Impl& m = *impl_;
  auto& gl = m.gl;
  Context& ctx = m.ctx;
  m.timings.clear();
  const int nl = int(lightSet.lights.size());
  if (int(depthMaps.size()) != nl)
    badInput("GL interop: " + std::to_string(depthMaps.size()) + " shadow-map textures for " +
             std::to_string(nl) + " lights (one depth texture per light)");
  switch (options.shadows) {
    case ShadowTechnique::None: case ShadowTechnique::Hard: case ShadowTechnique::PCSS:
    case ShadowTechnique::CSSM: case ShadowTechnique::MSSM4: case ShadowTechnique::MSSM6:
      break;
    case ShadowTechnique::Auto:  // its choices but the exact one run on the maps given
      if (options.autoChoice.exactLights != 0)
        badInput("GL interop: RenderOptions.autoChoice.exactLights is " +
                 std::to_string(options.autoChoice.exactLights) +
                 "; exact visibility needs the scene's triangles, which the interop does not "
                 "have: set it to 0 (--auto-exact 0) for auto with GL");
      break;
    default:
      badInput(std::string("GL interop: RenderOptions.shadows ") + toString(options.shadows) +
               " rasterizes more depth maps from the scene's triangles; with GL use none, "
               "hard, pcss, cssm, mssm4, mssm6 or auto (with no exact light)");
  }
  if (nl > m.maxLights)
    badInput("GL interop: " + std::to_string(nl) + " lights; this GL context's uniform blocks " +
             "hold at most " + std::to_string(m.maxLights));
  if (options.frontBackFaces)
    badInput("GL interop: RenderOptions.frontBackFaces needs back-face depth maps, which the "
             "interop does not take");
  if (options.bentNormals)
    badInput("GL interop: RenderOptions.bentNormals needs the scene's triangles and the OpenCL "
             "shading, which the interop does not take; render without GL");
  if (env.equirect.empty()) badInput("environment map is empty");

  // --- formats and sizes: the output texture fixes W x H, the first depth map S
  Impl::TexInfo out = m.inspect(output, "output texture");
  if (out.format != GL_RGBA32F && out.format != GL_RGBA16F)
    badInput(Impl::describe("output texture", output, out) +
             " has the wrong format; expected GL_RGBA32F or GL_RGBA16F");
  const int W = out.width, H = out.height, npx = W * H;
  if (W < 1 || H < 1) badInput(Impl::describe("output texture", output, out) + " is empty");
  m.expect("G-buffer position texture", g.position, W, H, {GL_RGBA32F, GL_RGBA16F},
           "GL_RGBA32F or GL_RGBA16F");
  m.expect("G-buffer normal texture", g.normal, W, H, {GL_RGBA32F, GL_RGBA16F},
           "GL_RGBA32F or GL_RGBA16F");
  m.expect("G-buffer albedo texture", g.albedo, W, H, {GL_RGBA8, GL_RGBA16F, GL_RGBA32F},
           "GL_RGBA8, GL_RGBA16F or GL_RGBA32F");
  if (g.geometricNormal)
    m.expect("G-buffer geometric-normal texture", g.geometricNormal, W, H,
             {GL_RGBA32F, GL_RGBA16F}, "GL_RGBA32F or GL_RGBA16F");
  int S = options.shadowMapSize;
  for (int i = 0; i < nl; ++i) {
    std::string what = "shadow map " + std::to_string(i);
    if (i == 0) {
      Impl::TexInfo t = m.inspect(depthMaps[0], what);
      S = t.width;
      if (t.width != t.height || S < 1 || S > 4096)
        badInput(Impl::describe(what, depthMaps[0], t) +
                 " must be square, between 1x1 and 4096x4096");
    }
    m.expect(what, depthMaps[i], S, S,
             {GL_DEPTH_COMPONENT16, GL_DEPTH_COMPONENT24, GL_DEPTH_COMPONENT32,
              GL_DEPTH_COMPONENT32F},
             "GL_DEPTH_COMPONENT16, 24, 32 or 32F");
  }
  RenderOptions opt = options;
  opt.width = W;
  opt.height = H;
  opt.shadowMapSize = S;

  const std::vector<pb_light> lights = penumbra::detail::lightFrames(lightSet, bounds, S).lights;
  cl::Buffer lightB = m.pool.upload("lights", lights);

  // --- GL -> host -> device
  auto t0 = Clock::now();
  const std::size_t texels = std::size_t(S) * S * nl;
  cl::Buffer& rawDepth = m.pool.buffer("GL depth maps", std::max<std::size_t>(1, texels) * 4);
  for (int i = 0; i < nl; ++i)
    m.upload(depthMaps[i], GL_DEPTH_COMPONENT, std::size_t(S) * S, rawDepth,
             std::size_t(i) * S * S, "shadow map " + std::to_string(i));
  cl::Buffer& rawPos = m.pool.buffer("GL positions", std::size_t(npx) * 16);
  cl::Buffer& rawNrm = m.pool.buffer("GL normals", std::size_t(npx) * 16);
  cl::Buffer& rawGeo = m.pool.buffer("GL geometric normals", std::size_t(npx) * 16);
  m.upload(g.position, GL_RGBA, std::size_t(npx) * 4, rawPos, 0, "G-buffer position texture");
  m.upload(g.normal, GL_RGBA, std::size_t(npx) * 4, rawNrm, 0, "G-buffer normal texture");
  if (g.geometricNormal)
    m.upload(g.geometricNormal, GL_RGBA, std::size_t(npx) * 4, rawGeo, 0,
             "G-buffer geometric-normal texture");
  m.timings.emplace_back("interop/upload", msSince(t0));

  // --- conversion into penumbra's encodings, visibility
  t0 = Clock::now();
  cl::Buffer& gpos = m.pool.buffer("G-buffer positions", std::size_t(npx) * 16);
  cl::Buffer& gnrm = m.pool.buffer("G-buffer normals", std::size_t(npx) * 16);
  cl::Buffer& ggeo = m.pool.buffer("G-buffer geometric normals", std::size_t(npx) * 16);
  cl::Buffer& depth = m.pool.buffer("shadow maps", std::max<std::size_t>(1, texels) * 4);
  {
    cl::Kernel k = ctx.kernel("gl_interop.cl", "gl_flip_gbuffer");
    auto flip = [&](cl::Buffer& src, int kind, cl::Buffer& dst) {
      ctx.launchWith("interop/convert", k, cl::NDRange(W, H), cl::NullRange, src, cl_int(W),
                     cl_int(H), cl_int(kind), dst);
    };
    flip(rawPos, 0, gpos);
    flip(rawNrm, 1, gnrm);
    flip(g.geometricNormal ? rawGeo : rawNrm, 1, ggeo);
    cl::Kernel lift = ctx.kernel("gl_interop.cl", "gl_lift_positions");
    ctx.launchWith("interop/convert", lift, cl::NDRange(std::size_t(npx)), cl::NullRange, gpos,
                   ggeo, cl_int(npx),
                   cl_float(penumbra::detail::shadowRayOffset(bounds.lo.data(), bounds.hi.data())));
    if (nl > 0) {
      cl::Kernel d = ctx.kernel("gl_interop.cl", "gl_depth_to_distance");
      ctx.launchWith("interop/convert", d, cl::NDRange(S, S, nl), cl::NullRange, rawDepth, lightB,
                     cl_int(S), cl_int(nl), depth);
    }
  }
  m.visibility.begin(opt.shadow, opt.shadows, npx, nl);
  NoRasterizer noRaster;
  penumbra::detail::ShadowFrame sf(ctx, m.pool, opt, lights);
  sf.width = W;
  sf.height = H;
  sf.pixels = npx;
  sf.mapSize = S;
  sf.lightBuffer = lightB;
  sf.gpos = gpos;
  sf.gnrm = gnrm;
  sf.ggeo = ggeo;
  sf.depth = depth;
  sf.rasterizer = &noRaster;
  sf.areaLights = &lightSet.lights;
  sf.ground = penumbra::detail::groundRect(ground, bounds);
  m.visibility.compute(sf);
  ctx.finish();
  m.timings.emplace_back("interop/visibility", msSince(t0));

  // --- device -> host -> GL
  t0 = Clock::now();
  const int layers = std::max(nl, 1);
  m.hostVis.assign(std::size_t(npx) * layers, 1.0f);
  if (nl > 0) ctx.read(m.visibility.buffer(), m.hostVis.data(), std::size_t(npx) * nl * 4, "visibility");
  while (gl.GetError() != GL_NO_ERROR) {
  }
  gl.ActiveTexture(GL_TEXTURE0);
  gl.BindTexture(GL_TEXTURE_2D_ARRAY, m.visTex);
  gl.PixelStorei(GL_UNPACK_ALIGNMENT, 4);
  if (m.visW != W || m.visH != H || m.visL != layers) {
    gl.TexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_R32F, W, H, layers, 0, GL_RED, GL_FLOAT,
                  m.hostVis.data());
    m.visW = W;
    m.visH = H;
    m.visL = layers;
  } else {
    gl.TexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, 0, W, H, layers, GL_RED, GL_FLOAT,
                     m.hostVis.data());
  }
  gl.check("uploading visibility");
  gl.Finish();
  m.timings.emplace_back("interop/download", msSince(t0));

  // --- shading: a fragment shader into the output texture
  t0 = Clock::now();
  // Lights: (dir, cos alpha), (radiance, polygon vertex count: 0 for a cap). Polygon lights'
  // vertices as renderer.cpp hands them to shade.cl: PB_MAX_POLY_VERTS per light.
  const std::vector<cl_float4> blocks = penumbra::detail::polygonVertexBlocks(lightSet.lights);
  std::vector<float> lightTexels(std::size_t(2) * 4 * std::max(nl, 1), 0.0f);
  std::vector<float> polys(blocks.size() * 4);
  for (std::size_t i = 0; i < blocks.size(); ++i)
    for (int c = 0; c < 4; ++c) polys[i * 4 + c] = blocks[i].s[c];
  for (int l = 0; l < nl; ++l) {
    for (int c = 0; c < 4; ++c) lightTexels[std::size_t(l) * 8 + c] = lights[l].dir[c];
    for (int c = 0; c < 3; ++c) lightTexels[std::size_t(l) * 8 + 4 + c] = lights[l].radiance[c];
    lightTexels[std::size_t(l) * 8 + 7] = blocks[std::size_t(l) * PB_MAX_POLY_VERTS].s[3];
  }
  lightTexels.resize(std::size_t(2) * 4 * m.maxLights, 0.0f);  // the block's declared size
  GLint prevUbo = 0;
  gl.GetIntegerv(GL_UNIFORM_BUFFER_BINDING, &prevUbo);
  gl.BindBuffer(GL_UNIFORM_BUFFER, m.lightUbo);
  gl.BufferData(GL_UNIFORM_BUFFER, GLsizeiptr(lightTexels.size() * 4), lightTexels.data(),
                GL_STREAM_DRAW);
  gl.BindBuffer(GL_UNIFORM_BUFFER, GLuint(prevUbo));
  gl.BindTexture(GL_TEXTURE_2D, m.polyTex);
  gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, PB_MAX_POLY_VERTS, std::max(nl, 1), 0, GL_RGBA,
                GL_FLOAT, polys.data());
  gl.BindTexture(GL_TEXTURE_2D, m.envTex);
  gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, env.equirect.width, env.equirect.height, 0, GL_RGB,
                GL_FLOAT, env.equirect.pixels.data());
  // The ambient's irradiance map (LightSet::ambientMap), a 1x1 black texel when it has none.
  const bool amap = lightSet.hasAmbient && !lightSet.ambientMap.empty();
  if (amap) lightSet.ambientMap.check();
  const float black[3] = {0, 0, 0};
  gl.BindTexture(GL_TEXTURE_2D, m.ambientTex);
  gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, amap ? lightSet.ambientMap.width : 1,
                amap ? lightSet.ambientMap.height : 1, 0, GL_RGB, GL_FLOAT,
                amap ? lightSet.ambientMap.rgb.data() : black);
  gl.check("uploading lights and environment");

  // The application's state this pass changes, restored after it.
  GLint prevFbo = 0, prevViewport[4] = {0, 0, 0, 0}, prevProgram = 0, prevVao = 0, prevUnit = 0;
  gl.GetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &prevFbo);
  gl.GetIntegerv(GL_VIEWPORT, prevViewport);
  gl.GetIntegerv(GL_CURRENT_PROGRAM, &prevProgram);
  gl.GetIntegerv(GL_VERTEX_ARRAY_BINDING, &prevVao);
  gl.GetIntegerv(GL_ACTIVE_TEXTURE, &prevUnit);
  const bool prevDepthTest = gl.IsEnabled(GL_DEPTH_TEST), prevBlend = gl.IsEnabled(GL_BLEND);
  gl.BindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, output, 0);
  GLenum buf = GL_COLOR_ATTACHMENT0;
  gl.DrawBuffers(1, &buf);
  if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    gl.BindFramebuffer(GL_FRAMEBUFFER, GLuint(prevFbo));
    badInput("GL interop: output texture " + std::to_string(output) +
             " cannot be rendered to (framebuffer incomplete)");
  }
  gl.Viewport(0, 0, W, H);
  gl.Disable(GL_DEPTH_TEST);
  gl.Disable(GL_BLEND);
  bool anyPolygon = false;
  for (auto& l : lightSet.lights) anyPolygon |= l.shape == LightShape::Polygon;
  m.program = m.programs[anyPolygon ? 1 : 0];
  gl.UseProgram(m.program);
  m.bind(0, GL_TEXTURE_2D, g.position, "uPos");
  m.bind(1, GL_TEXTURE_2D, g.normal, "uNrm");
  m.bind(2, GL_TEXTURE_2D, g.albedo, "uAlb");
  m.bind(3, GL_TEXTURE_2D_ARRAY, m.visTex, "uVis");
  gl.BindBufferBase(GL_UNIFORM_BUFFER, 0, m.lightUbo);
  m.bind(5, GL_TEXTURE_2D, m.envTex, "uEnv");
  m.bind(6, GL_TEXTURE_2D, m.polyTex, "uPolys");
  m.bind(7, GL_TEXTURE_2D, m.ambientTex, "uAmbientMap", m.ambientSampler);
  auto loc = [&](const char* n) { return gl.GetUniformLocation(m.program, n); };
  gl.Uniform1i(loc("uLightCount"), nl);
  gl.Uniform1i(loc("uBackground"), opt.environmentBackground ? 1 : 0);
  gl.Uniform1i(loc("uEnvW"), env.equirect.width);
  gl.Uniform1i(loc("uEnvH"), env.equirect.height);
  gl.Uniform1i(loc("uWidth"), W);
  gl.Uniform1i(loc("uHeight"), H);
  gl.Uniform1f(loc("uEnvShift"), env.rotationColumns());
  CameraBasis b = cameraBasis(camera, W, H);
  gl.Uniform3f(loc("uFwd"), b.forward[0], b.forward[1], b.forward[2]);
  gl.Uniform3f(loc("uRight"), b.right[0], b.right[1], b.right[2]);
  gl.Uniform3f(loc("uUp"), b.up[0], b.up[1], b.up[2]);
  gl.Uniform2f(loc("uTan"), b.tanHalfX, b.tanHalfY);
  float amb[27] = {0};
  for (int i = 0; i < 9 && lightSet.hasAmbient; ++i)
    for (int c = 0; c < 3; ++c) amb[i * 3 + c] = lightSet.ambientSH[i][c];
  gl.Uniform3fv(loc("uAmbient"), 9, amb);
  gl.Uniform1i(loc("uAmbientMapW"), amap ? lightSet.ambientMap.width : 0);
  gl.Uniform1i(loc("uAmbientMapH"), amap ? lightSet.ambientMap.height : 0);
  gl.BindVertexArray(m.vao);
  gl.DrawArrays(GL_TRIANGLES, 0, 3);
  gl.BindVertexArray(GLuint(prevVao));
  for (int u = 7; u >= 0; --u) gl.BindSampler(u, 0);
  gl.ActiveTexture(GLenum(prevUnit));
  gl.UseProgram(GLuint(prevProgram));
  gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, 0, 0);
  gl.BindFramebuffer(GL_FRAMEBUFFER, GLuint(prevFbo));
  gl.Viewport(prevViewport[0], prevViewport[1], prevViewport[2], prevViewport[3]);
  if (prevDepthTest) gl.Enable(GL_DEPTH_TEST);
  if (prevBlend) gl.Enable(GL_BLEND);
  gl.check("shading");
  gl.Finish();
  m.timings.emplace_back("gl/shade", msSince(t0));
}

std::vector<float> Interop::lastVisibility() { return impl_->visibility.download(); }

}  // namespace penumbra::gl
