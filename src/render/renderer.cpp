// The frame, stage by stage: scene upload, shadow-map rasterization for every light at once,
// moments and their SATs, camera G-buffer, per-light visibility, shading.
#include "penumbra/renderer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <sstream>
#include <cstring>
#include <cstdlib>

#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/scan.hpp"
#include "common/shared.h"
#include "render/bent_normals.hpp"
#include "render/options_check.hpp"
#include "lights/light_buffers.hpp"
#include "shadows/shadow_pass.hpp"
#include "core/vec3.hpp"

namespace penumbra {


namespace {

using detail::V3;
using detail::cross;
using detail::dot;
using detail::normalize;

pb_view cameraView(const Camera& c, int w, int h) {
  CameraBasis b = cameraBasis(c, w, h);
  pb_view v{};
  for (int k = 0; k < 3; ++k) {
    v.origin[k] = b.eye[k];
    v.forward[k] = b.forward[k];
    v.right[k] = b.right[k];
    v.up[k] = b.up[k];
  }
  v.right[3] = b.tanHalfX;
  v.up[3] = b.tanHalfY;
  v.width = w;
  v.height = h;
  v.ortho = 0;
  return v;
}

// Rows of the bounding box each triangle's work is split into: large triangles (the ground) are
// shared by this many work-items.
constexpr int kStripes = 8;

}  // namespace

namespace detail {

cl::Buffer& BufferPool::buffer(const std::string& role, std::size_t bytes) {
  return ctx_.reuse(pool_, role, bytes);
}

// Orthographic shadow-map frame of a directional light, fitted to the scene's bounding box: the
// box's corners projected onto the light's axes give the map's extent and depth range (plus a
// small margin so nothing sits exactly on the near plane or the border).
pb_light lightFrame(const std::array<float, 3>& direction, float cosAlpha,
                    const std::array<float, 3>& radiance, const Bounds& b) {
  pb_light L{};
  V3 w = normalize({direction[0], direction[1], direction[2]});
  V3 ref = std::fabs(w[1]) < 0.99f ? V3{0, 1, 0} : V3{1, 0, 0};
  V3 ex = normalize(cross(ref, w));
  V3 ey = cross(w, ex);
  V3 fwd = {-w[0], -w[1], -w[2]};
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (int i = 0; i < 8; ++i) {
    V3 c = {i & 1 ? b.hi[0] : b.lo[0], i & 2 ? b.hi[1] : b.lo[1], i & 4 ? b.hi[2] : b.lo[2]};
    float p[3] = {dot(c, ex), dot(c, ey), dot(c, fwd)};
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k]);
      hi[k] = std::max(hi[k], p[k]);
    }
  }
  float margin = 1e-3f * std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-6f});
  float cx = 0.5f * (lo[0] + hi[0]), cy = 0.5f * (lo[1] + hi[1]), z0 = lo[2] - margin;
  for (int k = 0; k < 3; ++k) {
    L.dir[k] = w[k];
    L.radiance[k] = radiance[k];
    L.ex[k] = ex[k];
    L.ey[k] = ey[k];
    L.origin[k] = cx * ex[k] + cy * ey[k] + z0 * fwd[k];
  }
  L.dir[3] = cosAlpha;
  L.radiance[3] = std::acos(std::clamp(cosAlpha, -1.0f, 1.0f));
  L.ex[3] = 0.5f * (hi[0] - lo[0]) + margin;
  L.ey[3] = 0.5f * (hi[1] - lo[1]) + margin;
  L.origin[3] = hi[2] + margin - z0;
  return L;
}

pb_view orthoView(const pb_light& L, int size) {
  pb_view v{};
  for (int k = 0; k < 3; ++k) {
    v.origin[k] = L.origin[k];
    v.forward[k] = -L.dir[k];
    v.right[k] = L.ex[k];
    v.up[k] = L.ey[k];
  }
  v.right[3] = L.ex[3];
  v.up[3] = L.ey[3];
  v.width = v.height = size;
  v.ortho = 1;
  return v;
}

}  // namespace detail

using detail::BufferPool;
using detail::Cull;

struct Renderer::Impl {
  Context& ctx;
  BufferPool pool;
  std::unique_ptr<detail::ShadowPass> pass;  // nullptr for ShadowTechnique::None
  ShadowTechnique passKind = ShadowTechnique::None;
  int lastPixels = 0, lastLights = 0;
  cl::Buffer vis;
  explicit Impl(Context& c) : ctx(c), pool(c) {}
};

Renderer::Renderer(Context& ctx) : impl_(std::make_unique<Impl>(ctx)) {}
Renderer::~Renderer() = default;

Frame Renderer::render(const Scene& scene, const Camera& camera, const LightSet& lightSet,
                       const Environment& env, const RenderOptions& opt) {
  auto t0 = std::chrono::steady_clock::now();
  Context& ctx = impl_->ctx;
  detail::validateFrameInputs(scene, env, opt);

  // --- scene upload
  std::vector<cl_float4> pos, nrm, alb;
  std::vector<cl_int4> tris;
  for (std::size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const Mesh& m = scene.meshes[mi];
    int base = int(pos.size());
    bool hasN = m.normals.size() == m.positions.size();
    for (std::size_t i = 0; i < m.positions.size(); ++i) {
      auto& p = m.positions[i];
      pos.push_back({{p[0], p[1], p[2], 1.0f}});
      if (hasN)
        nrm.push_back({{m.normals[i][0], m.normals[i][1], m.normals[i][2], 1.0f}});
      else
        nrm.push_back({{0, 0, 0, 0}});
    }
    for (auto& t : m.triangles) tris.push_back({{base + t[0], base + t[1], base + t[2], int(mi)}});
    alb.push_back({{m.albedo[0], m.albedo[1], m.albedo[2], 1.0f}});
  }
  const int ntris = int(tris.size());
  cl::Buffer posB = impl_->pool.upload("vertex positions", pos);
  cl::Buffer nrmB = impl_->pool.upload("vertex normals", nrm);
  cl::Buffer triB = impl_->pool.upload("triangles", tris);
  cl::Buffer albB = impl_->pool.upload("albedo", alb);

  const int W = opt.width, H = opt.height, npx = W * H;
  const int nl = int(lightSet.lights.size());
  const int S = opt.shadowMapSize;
  Bounds bounds = scene.bounds();
  std::vector<pb_light> lights;
  std::vector<pb_view> lviews;
  for (auto& l : lightSet.lights) {
    lights.push_back(detail::lightFrame(l.direction, l.cosAlpha, l.radiance, bounds));
    lviews.push_back(detail::orthoView(lights.back(), S));
  }
  std::vector<pb_view> cview{cameraView(camera, W, H)};
  cl::Buffer camB = impl_->pool.upload("camera", cview);
  cl::Buffer lightB = impl_->pool.upload("lights", lights);

  cl::Kernel raster = ctx.kernel("raster.cl", "raster_triangles");
  auto rasterize = [&](cl::Buffer& views, int nviews, int pass, Cull cull, cl::Buffer& depth,
                       cl::Buffer& ids, const std::string& stage) {
    raster.setArg(0, posB);
    raster.setArg(1, triB);
    raster.setArg(2, cl_int(ntris));
    raster.setArg(3, views);
    raster.setArg(4, cl_int(kStripes));
    raster.setArg(5, cl_int(pass));
    raster.setArg(6, depth);
    raster.setArg(7, ids);
    raster.setArg(8, cl_int(cull));
    ctx.launch(stage, raster, cl::NDRange(ntris, kStripes, nviews));
  };

  // --- camera G-buffer
  cl::Buffer cdepth = impl_->pool.buffer("camera depth", std::size_t(npx) * 4);
  cl::Buffer cids = impl_->pool.buffer("camera triangle ids", std::size_t(npx) * 4);
  cl_uint emptyDepth = PB_DEPTH_EMPTY, emptyId = PB_ID_EMPTY;
  ctx.fill(cdepth, &emptyDepth, 4, std::size_t(npx) * 4, "camera depth");
  ctx.fill(cids, &emptyId, 4, std::size_t(npx) * 4, "camera triangle ids");
  rasterize(camB, 1, 0, Cull::None, cdepth, cids, "gbuffer/depth");
  rasterize(camB, 1, 1, Cull::None, cdepth, cids, "gbuffer/ids");
  cl::Buffer gpos = impl_->pool.buffer("G-buffer positions", std::size_t(npx) * 16);
  cl::Buffer gnrm = impl_->pool.buffer("G-buffer normals", std::size_t(npx) * 16);
  cl::Buffer ggeo = impl_->pool.buffer("G-buffer geometric normals", std::size_t(npx) * 16);
  cl::Buffer galb = impl_->pool.buffer("G-buffer albedo", std::size_t(npx) * 16);
  {
    cl::Kernel k = ctx.kernel("raster.cl", "gbuffer_resolve");
    k.setArg(0, posB);
    k.setArg(1, nrmB);
    k.setArg(2, triB);
    k.setArg(3, albB);
    k.setArg(4, camB);
    k.setArg(5, cids);
    k.setArg(6, gpos);
    k.setArg(7, gnrm);
    k.setArg(8, ggeo);
    k.setArg(9, galb);
    ctx.launch("gbuffer/resolve", k, cl::NDRange(W, H));
  }
  // What the shading needs to bend normals (seed 001 §4.3), or small stand-ins it never reads.
  const detail::BentBuffers bent =
      opt.bentNormals && nl > 0
          ? detail::bentNormals(ctx, impl_->pool, pos, nrm, tris, posB, nrmB, lightB, nl, cids,
                                gpos, gnrm, npx)
          : detail::BentBuffers{impl_->pool.buffer("bent normals off", 16),
                                impl_->pool.buffer("bent normals off", 16),
                                impl_->pool.buffer("bent normals off", 16)};

  // --- visibility per light
  const std::size_t visBytes = std::max<std::size_t>(1, std::size_t(npx) * std::max(nl, 1)) * 4;
  impl_->vis = impl_->pool.buffer("visibility buffer", visBytes);
  impl_->lastPixels = npx;
  impl_->lastLights = nl;
  Frame frame;
  // The pass is kept between frames of the same technique: passes hold what depends only on
  // their options (the bitmask's light samples and look-up tables), not on the frame.
  if (!impl_->pass || impl_->passKind != opt.shadows) {
    impl_->pass = detail::makeShadowPass(opt.shadows);
    impl_->passKind = opt.shadows;
  }
  detail::ShadowPass* pass = impl_->pass.get();
  if (nl > 0 && pass) {
    // Every depth map of the frame (the lights' and any a technique adds) goes through here, so
    // --front-back applies to all of them alike: nearest surface, or the average of the front-
    // and back-facing surfaces' depths (seed 003 §4.2.3).
    auto rasterizeDepth = [&](const std::vector<pb_view>& views, cl::Buffer& out,
                              const std::string& prefix) {
      cl::Buffer& vb = impl_->pool.upload("views " + prefix, views);
      const std::size_t texels = views.size() * std::size_t(S) * S;
      auto one = [&](Cull cull, cl::Buffer& dst, const std::string& stage) {
        ctx.fill(dst, &emptyDepth, 4, texels * 4, stage);
        rasterize(vb, int(views.size()), 0, cull, dst, dst, stage);
      };
      if (!opt.frontBackFaces) {
        one(Cull::None, out, prefix + "/raster");
        return;
      }
      cl::Buffer& back = impl_->pool.buffer("back-face maps " + prefix, texels * 4);
      one(Cull::KeepFront, out, prefix + "/raster-front");
      one(Cull::KeepBack, back, prefix + "/raster-back");
      cl::Kernel k = ctx.kernel("raster.cl", "combine_front_back");
      k.setArg(0, out);
      k.setArg(1, back);
      k.setArg(2, cl_int(texels));
      ctx.launch(prefix + "/front-back", k, cl::NDRange(texels));
    };
    const std::size_t texels = std::size_t(S) * S * nl;
    // Techniques with their own light-space structures (the bitmask's lists) never read them.
    const bool maps = pass->usesShadowMaps();
    cl::Buffer& ldepth = impl_->pool.buffer("shadow maps", maps ? texels * 4 : 4);
    if (maps) rasterizeDepth(lviews, ldepth, "shadow-maps");
    detail::ShadowFrame sf{ctx,  impl_->pool, opt,   W,    H,     npx,  S,    lights,         lightB,
                           gpos, gnrm,        ggeo,  ldepth, impl_->vis, rasterizeDepth,
                           cids, posB,        triB,  ntris};
    sf.areaLights = &lightSet.lights;
    pass->computeVisibility(sf);
    frame.shadowMapBytes = pass->frameBytes(opt, texels);
    frame.stats = pass->frameStats();
  } else if (nl > 0) {
    cl_float one = 1.0f;
    ctx.fill(impl_->vis, &one, 4, std::size_t(npx) * nl * 4, "visibility buffer");
  }

  // --- shading
  cl::Buffer envB = impl_->pool.upload("environment map", env.equirect.pixels);
  cl::Buffer outB = impl_->pool.buffer("frame", std::size_t(npx) * 16);
  {
    cl::Kernel k = ctx.kernel("shade.cl", "shade");
    std::size_t wg = ctx.workGroupSize(k, 64);
    k.setArg(0, gpos);
    k.setArg(1, gnrm);
    k.setArg(2, galb);
    k.setArg(3, lightB);
    k.setArg(4, cl_int(nl));
    k.setArg(5, impl_->vis);
    k.setArg(6, cl_int(npx));
    k.setArg(7, camB);
    k.setArg(8, envB);
    k.setArg(9, cl_int(env.equirect.width));
    k.setArg(10, cl_int(env.equirect.height));
    k.setArg(11, cl_float(env.rotationColumns()));
    k.setArg(12, cl_int(opt.environmentBackground ? 1 : 0));
    k.setArg(13, outB);
    // The ambient residual, added unshadowed (zeros when the light set has none).
    std::vector<cl_float4> amb(9, cl_float4{{0, 0, 0, 0}});
    for (int i = 0; i < 9 && lightSet.hasAmbient; ++i)
      for (int c = 0; c < 3; ++c) amb[i].s[c] = lightSet.ambientSH[i][c];
    k.setArg(14, impl_->pool.upload("ambient SH", amb));
    // Polygon lights' vertices (src/light_buffers.hpp); the shading uses the polygon's exact
    // irradiance (shared.h).
    const std::vector<cl_float4> poly = detail::polygonVertexBlocks(lightSet.lights);
    k.setArg(15, impl_->pool.upload("polygon light vertices", poly));
    // The ambient's irradiance map when it has one (else amap_w = 0: the SH9 above).
    const bool amap = lightSet.hasAmbient && !lightSet.ambientMap.empty();
    if (amap) lightSet.ambientMap.check();
    k.setArg(16, impl_->pool.upload("ambient irradiance map",
                                    amap ? lightSet.ambientMap.rgb : std::vector<float>(3, 0.0f)));
    k.setArg(17, cl_int(amap ? lightSet.ambientMap.width : 0));
    k.setArg(18, cl_int(amap ? lightSet.ambientMap.height : 0));
    k.setArg(19, bent.vert);
    k.setArg(20, bent.weight);
    k.setArg(21, bent.bend);
    k.setArg(22, cl_int(opt.bentNormals && nl > 0 ? 1 : 0));
    k.setArg(23, cl_float(opt.bentNormalsScale));
    ctx.launch("shade", k, cl::NDRange((npx + wg - 1) / wg * wg), cl::NDRange(wg));
  }
  frame.image = Image(W, H, 4);
  ctx.read(outB, frame.image.pixels.data(), std::size_t(npx) * 16, "frame");
  frame.timingsMs = ctx.stageTimesMs();
  double total =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  frame.timingsMs.emplace_back("total", total);
  return frame;
}

std::vector<float> Renderer::lastVisibility() {
  return impl_->ctx.download<float>(impl_->vis, std::size_t(impl_->lastPixels) * impl_->lastLights,
                                    "visibility");
}

}  // namespace penumbra
