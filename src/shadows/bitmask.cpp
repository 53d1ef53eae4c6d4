// Sample-based visibility (Sintorn et al. 2008): alias-free hard shadows (`bitmask-hard`, §3) and
// soft
// shadows from 128-1024 light samples per view sample (`bitmask`, §4), with no depth bias.
//
// Stages, per frame (all lights at once where memory allows):
//   bitmask/lists/*     view samples from the G-buffer into per-light, per-texel lists
//                       (kernels/shadows/viewsamples.cl: bounds, grid fit, atomic counts, int64
// scan by                       src/core/scan.cpp, scatter)
//   bitmask/triangles   every triangle against the list texels of its influence region, OR of
//                       the light samples it blocks into each view sample's mask
// (kernels/shadows/bitmask.cl)   bitmask/resolve     masks to visibility, weighted like the shading
// Masks are held for a batch of lights at a time (BitmaskOptions::maskBytes).
//
// Lights: our cap lights (half-angle alpha) are treated as disks of radius tan(alpha) at unit
// distance, infinitely far (exact by gnomonic projection; samples weighted by their solid angle).
// Polygons keep their bounding cap's disk samples inside them; ellipses map the disk onto
// themselves (bitmaskFrame); textured lights weight each sample by the texture (Sintorn et al. 2008
// §4.1).
//
// Self-shadowing without bias. Sintorn et al. 2008 §3.3 keeps only light-front-facing view samples
// and lets only light-back-facing triangles of closed casters block, so no triangle is both. Our
// view samples are the G-buffer's positions, lifted off their triangle along its camera-facing
// normal by the shadow offset the Embree reference starts its rays with
// (src/scene/shadow_offset.hpp), so every triangle, the sample's own included, is tested as the
// reference's ray meets it, and the occlusion test needs no bias (a sample exactly on another
// triangle's plane is not blocked by it: the cone it spans is flat). On open meshes (the built-in
// scene's ground grid) the back-face rule would drop every caster seen from its front (a panel lit
// from its front side would cast nothing), so there every triangle casts from both sides.
// Closed meshes (meshOrientation(), decided once per frame from the triangles) keep Sintorn et
// al.'s (2008) rule: triangles facing every light sample cast nothing (a ray from outside enters
// a closed mesh through a triangle facing away from it), which drops about half of their
// triangles. A sample seen from inside a closed mesh starts inside it, where that rule fails: its
// rays below its triangle's outward plane are blocked by kernels/shadows/bitmask.cl's
// bitmask_self, as the skipped far side would have blocked them.
#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <unordered_map>

#include "shadows/bitmask.hpp"
#include "core/device_kind.hpp"
#include "penumbra/error.hpp"
#include "penumbra/scan.hpp"
#include "shadows/shadow_options.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {
namespace {

// Look-up table cells (kernels/shadows/bitmask.cl's LUT_PHI x LUT_DELTA): the band of light samples
// the table cannot decide, tested exactly, is about (pi / LUT_PHI + 1 / LUT_DELTA) disk radii wide
// on each side of a cut (the angle dominates: 128 x 128 gave ~3% of the samples and 4.2 s of
// triangle stage at 160x90, 128 samples; 512 x 128 halves the band, 3.2-3.8 s, same masks); the
// tables take 2 * 512 * 128 * samples / 8 bytes (2 MiB at 128 samples, 16 MiB at 1024).
constexpr int kLutPhi = 512, kLutDelta = 128;
// Pixels per work-item of bitmask_resolve_batch (RS_GROUP).
constexpr int kResolveGroup = 64;
// Triangle work is split over this many row stripes of its region (large ground triangles).
constexpr int kStripes = 16;

BitmaskCapture* gCapture = nullptr;

std::size_t roundUp(std::size_t v, std::size_t m) { return (v + m - 1) / m * m; }

// The two tables of kernels/shadows/bitmask.cl for `disk`: cell (ip, id) covers phi in
// [-pi + ip dphi, -pi + (ip + 1) dphi), delta in [-1 + id ddelta, -1 + (id + 1) ddelta). Sample
// (u, v) at radius rho is behind the plane iff f = u cos(phi) + v sin(phi) + delta >= 0; over the
// cell, f varies from its value at the cell's centre angle by at most rho dphi / 2 (|df/dphi| <=
// rho). A small margin on both parameters covers the kernel's float rounding of phi and delta.
// Stored interleaved per cell: lut[(cell * 2 + 0) * words + w] = in, [(cell * 2 + 1) * words + w]
// = out (one cache line per look-up at 128 samples).
void buildTables(const std::vector<std::array<float, 2>>& disk, std::vector<cl_uint>& lut) {
  const int n = int(disk.size()), words = n / 32;
  const double kPi = 3.14159265358979323846;
  const double dphi = 2 * kPi / kLutPhi, ddelta = 2.0 / kLutDelta, margin = 1e-4;
  lut.assign(std::size_t(kLutPhi) * kLutDelta * words * 2, 0u);
  // Per angle cell, each sample's two tests hold from some delta cell on (f - slack + d0 and
  // f + slack + d1 do not decrease as the cell's bounds grow), so a binary search finds where,
  // with the same expressions, and the words are built cell by cell from the samples that start
  // there: the same tables as testing every (cell, sample), in about half the time (21 against
  // 38 ms at 256 samples, most of what is left the table's first touch).
  // delta's cell bounds, as the cells' tests take them: increasing in id
  auto d0 = [&](int id) { return -1 + id * ddelta - margin; };
  auto d1 = [&](int id) { return -1 + (id + 1) * ddelta + margin; };
  // the samples whose `in` (`out`) run starts at cell id, as linked lists
  std::vector<int> headIn(kLutDelta + 1), headOut(kLutDelta + 1), nextIn(n), nextOut(n);
  std::vector<cl_uint> in(words), out(words);
  for (int ip = 0; ip < kLutPhi; ++ip) {
    double phc = -kPi + (ip + 0.5) * dphi, cp = std::cos(phc), sp = std::sin(phc);
    std::fill(headIn.begin(), headIn.end(), -1);
    std::fill(headOut.begin(), headOut.end(), -1);
    for (int k = 0; k < n; ++k) {
      double u = disk[k][0], v = disk[k][1], rho = std::sqrt(u * u + v * v);
      double f = u * cp + v * sp, slack = rho * (0.5 * dphi + margin);
      // the first cell where each test holds (it holds for every cell after: f - slack + d0
      // and f + slack + d1 do not decrease with id); kLutDelta where none
      int a = 0, b = kLutDelta;
      while (a < b) {
        int m = (a + b) / 2;
        if (f - slack + d0(m) > 1e-6) b = m; else a = m + 1;
      }
      nextIn[k] = headIn[a];
      headIn[a] = k;
      a = 0, b = kLutDelta;
      while (a < b) {
        int m = (a + b) / 2;
        if (f + slack + d1(m) >= -1e-6) b = m; else a = m + 1;
      }
      nextOut[k] = headOut[a];
      headOut[a] = k;
    }
    std::fill(in.begin(), in.end(), 0u);
    std::fill(out.begin(), out.end(), 0u);
    for (int id = 0; id < kLutDelta; ++id) {
      for (int k = headIn[id]; k >= 0; k = nextIn[k]) in[k / 32] |= 1u << (k % 32);
      for (int k = headOut[id]; k >= 0; k = nextOut[k]) out[k / 32] |= 1u << (k % 32);
      cl_uint* at = &lut[(std::size_t(ip) * kLutDelta + id) * words * 2];
      std::copy(in.begin(), in.end(), at);
      std::copy(out.begin(), out.end(), at + words);
    }
  }
}

class BitmaskPass : public ShadowPass {
 public:
  explicit BitmaskPass(bool hard) : hard_(hard) {}
  ~BitmaskPass() override {
    try {
      if (countsRead_()) countsRead_.wait();  // the read must not land in freed memory
    } catch (const cl::Error&) {
    }
  }

  void computeVisibility(ShadowFrame& f) override {
    const BitmaskOptions& bo = f.opt.bitmask;
    validate(bo, hard_);
    const int N = hard_ ? 1 : bo.lightSamples;
    // Soft influence regions span many texels: a coarser grid walks fewer empty ones (default
    // frame at 160x90, 128 samples: 256^2 31 s, 64^2 22 s, 32^2 19 s of triangle stage on the
    // loaded 2-core machine; the image is bit-identical, as it must be).
    const int S = bo.listSize > 0 ? bo.listSize : hard_ ? f.mapSize : std::min(f.mapSize, 64);
    checkRange(bo.listSize > 0 ? "RenderOptions.bitmask.listSize" : "RenderOptions.shadowMapSize", S,
               1, 4096);
    if (f.triangleCount < 1 || !f.gids() || !f.positions() || !f.triangles())
      throw Error(ErrorKind::Internal, "bitmask: the renderer gave no triangles or ids");
    const int nl = int(f.lights.size()), npx = f.pixels, W = hard_ ? 1 : N / 32;
    const std::size_t texels = std::size_t(S) * S * nl, pairs = std::size_t(npx) * nl;
    Context& ctx = f.ctx;

    // Host work first (the samples, their tables, each light's frame and sample weights, the
    // meshes' orientation): the first upload below waits for the device's queue, so what the
    // host computes before it overlaps the previous technique's kernels.
    // --- light samples and their tables (tables of the unrotated set; a jittered frame rotates
    // the samples, and the kernels look the tables up at the rotated angle)
    const double rot = hard_ ? 0.0 : bitmaskJitterAngle(bo.jitter);
    if (tableSamples_ != N) {
      std::vector<cl_uint> lut{0u};
      if (!hard_) buildTables(bitmaskDiskSamples(N), lut);
      lut_ = ctx.upload(lut, "bitmask tables");
      tableSamples_ = N;
      diskRot_ = -1;
    }
    if (diskRot_ != rot || disk_.size() != std::size_t(N)) {
      disk_ = hard_ ? std::vector<std::array<float, 2>>{{0.0f, 0.0f}} : bitmaskDiskSamples(N, rot);
      std::vector<cl_float2> d(disk_.size());
      for (std::size_t i = 0; i < d.size(); ++i) d[i] = {{disk_[i][0], disk_[i][1]}};
      diskBuf_ = ctx.upload(d, "bitmask light samples");
      diskRot_ = rot;
    }

    // Each light's sampling frame (bitmaskFrame) and the weight of each of its samples
    // (kernels/shadows/bitmask.cl's resolve): a polygon's disk samples outside it weigh 0 (those
    // whose direction is not behind every edge's great-circle plane; lights.hpp's counter-clockwise
    // order), a textured light's weigh the texture's luminance (AreaLight::sampleWeight), all
    // others 1. An ellipse's samples are all inside it: its frame maps the disk onto it.
    std::vector<BitmaskFrame> frames(std::max(nl, 1));
    std::vector<cl_float> weights(std::size_t(std::max(nl, 1)) * N, 1.0f);
    for (int l = 0; l < nl; ++l) {
      const AreaLight* al = f.areaLights && std::size_t(l) < f.areaLights->size() && !hard_
                                ? &(*f.areaLights)[l] : nullptr;
      const pb_light& L = f.lights[l];
      frames[l] = bitmaskFrame(L, al);
      if (!al) continue;
      const bool polygon = al->shape == LightShape::Polygon && al->outline != AreaLight::Outline::Ellipse;
      if (!polygon && al->texture.empty()) continue;
      const float c = L.dir[3];
      const float ta = std::sqrt(std::max(1.0f - c * c, 0.0f)) / std::max(c, 1e-6f);
      std::vector<std::array<float, 3>> dirs(N);
      for (int k = 0; k < N; ++k)
        dirs[k] = bitmaskSampleDirection(L, ta, frames[l], disk_[k][0], disk_[k][1]);
      const std::vector<float> tw = lightSampleWeights(*al, dirs);
      const std::size_t nv = al->vertices.size();
      double kept = 0;  // the weight left to the light's samples
      for (int k = 0; k < N; ++k) {
        const auto& d = dirs[k];
        bool in = true;
        for (std::size_t v = 0; polygon && v < nv && in; ++v) {
          const auto& a = al->vertices[v];
          const auto& b = al->vertices[(v + 1) % nv];
          const float e[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                              a[0] * b[1] - a[1] * b[0]};
          in = e[0] * d[0] + e[1] * d[1] + e[2] * d[2] >= 0.0f;
        }
        weights[std::size_t(l) * N + k] = in ? tw[k] : 0.0f;
        kept += in ? tw[k] : 0.0f;
      }
      // Every weight 0 would leave the light unshadowed (the resolve's empty sum reads as lit).
      if (!(kept > 0))
        badInput("light " + std::to_string(l) + ": none of its " + std::to_string(N) +
                 " bitmask light samples falls inside " +
                 (polygon ? "the polygon" : "a lit texel of its texture") +
                 " (a light too thin for them); raise RenderOptions.bitmask.lightSamples");
    }
    std::vector<cl_float4> frameData(frames.size() * 2);
    for (std::size_t l = 0; l < frames.size(); ++l)
      for (int c = 0; c < 4; ++c) {
        frameData[2 * l].s[c] = frames[l].e1[c];
        frameData[2 * l + 1].s[c] = frames[l].e2[c];
      }
    const std::vector<cl_int> orientHost = orientation(f);

    // --- view samples and lists (Sintorn et al. 2008 §3.1, §4.3)
    std::vector<cl_int> init(std::size_t(nl) * 8);
    for (int l = 0; l < nl; ++l) {
      const cl_int b[8] = {INT_MAX, INT_MIN, INT_MAX, INT_MIN, INT_MIN, 0, 0, 0};
      std::copy(b, b + 8, init.begin() + std::size_t(l) * 8);
    }
    cl::Buffer& bounds = f.pool.upload("bitmask bounds", init);
    cl::Buffer& grids = f.pool.buffer("bitmask grids", std::size_t(nl) * sizeof(pb_list_grid));
    cl::Buffer& counts = f.pool.buffer("bitmask list lengths", texels * sizeof(cl_int));
    cl::Buffer& ends = f.pool.buffer("bitmask list ends", texels * sizeof(cl_long));
    cl::Buffer& slot = f.pool.buffer("bitmask sample slots", pairs * sizeof(cl_int));
    cl::Buffer& lists = f.pool.buffer("bitmask lists", pairs * sizeof(cl_int));
    cl::Buffer& zfar = f.pool.buffer("bitmask list far depths", texels * sizeof(cl_int));
    // the list stages' CPU forms on CPU devices (viewsamples.cl, vs_bounds_batch and
    // vs_count_batch: the same bounds, lengths and far depths), kListGroup pixels a work-item
    constexpr int kListGroup = 64;
    if (useCpuBatching(ctx)) {
      cl::Kernel k = ctx.kernel("viewsamples.cl", "vs_bounds_batch",
                                cpuFormOptions(ctx, "VS_GROUP", kListGroup));
      ctx.launchWith("bitmask/lists/bounds", k,
                     cl::NDRange(cpuFormItems(std::size_t(npx), kListGroup), nl), cl::NullRange,
                     f.gpos, f.gnrm, f.lightBuffer, cl_int(npx), bounds);
    } else {
      cl::Kernel k;
      std::size_t wg = 0;
      for (std::size_t t = 256; t >= 1; t /= 2) {
        if (t > ctx.info().maxWorkGroupSize) continue;
        k = ctx.kernel("viewsamples.cl", "vs_bounds", "-DVS_WG=" + std::to_string(t));
        if (ctx.workGroupSize(k, t) >= t) {
          wg = t;
          break;
        }
      }
      ctx.launchWith("bitmask/lists/bounds", k, cl::NDRange(roundUp(npx, wg), nl),
                     cl::NDRange(wg, 1), f.gpos, f.gnrm, f.lightBuffer, cl_int(npx), bounds);
    }
    {
      cl::Kernel k = ctx.kernel("viewsamples.cl", "vs_fit");
      ctx.launchWith("bitmask/lists/fit", k, cl::NDRange(nl), cl::NullRange, bounds, f.lightBuffer,
                     cl_int(nl), cl_int(S), cl_int(hard_ ? 1 : 0), grids);
    }
    const cl_int zero = 0;
    ctx.fill(counts, &zero, sizeof zero, texels * sizeof(cl_int), "bitmask list lengths");
    const cl_int lowest = INT_MIN;
    ctx.fill(zfar, &lowest, sizeof lowest, texels * sizeof(cl_int), "bitmask list far depths");
    {
      KernelForm k =
          kernelForm(ctx, "viewsamples.cl", "vs_count", "VS_GROUP", kListGroup, std::size_t(npx));
      ctx.launchWith("bitmask/lists/count", k.kernel, cl::NDRange(k.items, nl), cl::NullRange,
                     f.gpos, f.gnrm, f.lightBuffer, grids, cl_int(npx), counts, slot, zfar);
    }
    {
      cl::Kernel k = ctx.kernel("viewsamples.cl", "vs_widen");
      ctx.launchWith("bitmask/lists/widen", k, cl::NDRange(texels), cl::NullRange, counts,
                     cl_long(texels), ends);
    }
    summedAreaTable(ctx, ends, ScanType::Long, S * S, 1, nl, "bitmask/lists/scan");
    {
      cl::Kernel k = ctx.kernel("viewsamples.cl", "vs_scatter");
      ctx.launchWith("bitmask/lists/scatter", k, cl::NDRange(npx, nl), cl::NullRange, f.gpos,
                     f.lightBuffer, grids, cl_int(npx), counts, ends, slot, lists);
    }

    BitmaskCapture* cap = gCapture;
    // The lists' statistics read the lengths back: queued after the triangles, and waited for
    // only when frameStats() asks, so the device is not left idle mid-frame; a capture reads
    // the lists (and waits) before the batch loop below.
    if (cap) collect(f, counts, grids, slot, nl, S, W, cap);
    cl::Buffer& orient = f.pool.upload("bitmask mesh orientation", orientHost);

    // --- triangles and resolve, a batch of lights at a time
    const std::size_t perLight = hard_ ? (std::size_t(npx) + 31) / 32 * 4 : std::size_t(npx) * W * 4;
    const int batch = int(std::clamp<std::size_t>(bo.maskBytes / perLight, 1, std::size_t(nl)));
    const std::size_t maskWords = hard_ ? (std::size_t(batch) * npx + 31) / 32 : std::size_t(batch) * npx * W;
    cl::Buffer& masks = f.pool.buffer("bitmask masks", maskWords * 4);
    heldBytesPerTexel_ = double(maskWords) * 4 / (double(S) * S * std::max(nl, 1)) + 12.0;
    // What the technique holds on the device: the list grid (length, int64 end, far depth per
    // texel), the lists (one pixel index per view sample) and sample slots, and the masks of one
    // batch.
    heldBytes_ = texels * (4 + 8 + 4) + pairs * (4 + 4) + maskWords * 4;
    listSize_ = S;
    const std::string opts = "-DLUT_PHI=" + std::to_string(kLutPhi) + " -DLUT_DELTA=" +
                             std::to_string(kLutDelta) + " -DWORDS=" + std::to_string(W) +
                             (hard_ ? " -DHARD" : "") +
                             cpuFormOptions(ctx, "RS_GROUP", kResolveGroup);
    cl::Buffer& frameBuf = f.pool.upload("bitmask light frames", frameData);
    cl::Buffer& weightBuf = f.pool.upload("bitmask sample weights", weights);
    if (cap) {
      cap->frames.assign(frames.begin(), frames.begin() + nl);
      cap->weights.assign(weights.begin(), weights.begin() + std::size_t(nl) * N);
    }
    cl::Kernel tk = ctx.kernel("bitmask.cl", "bitmask_triangles", opts);
    // the resolve's CPU form on CPU devices (soft masks only; the hard resolve reads one bit)
    const bool cpuResolve = !hard_ && useCpuBatching(ctx);
    cl::Kernel rk =
        ctx.kernel("bitmask.cl", cpuResolve ? "bitmask_resolve_batch" : "bitmask_resolve", opts);
    cl::Kernel sk = ctx.kernel("bitmask.cl", "bitmask_self", opts);
    for (int l0 = 0; l0 < nl; l0 += batch) {
      const int count = std::min(batch, nl - l0);
      // hard masks pack 32 pixels a word, so they are emptied here; soft ones by bitmask_self
      const cl_uint z = 0;
      if (hard_) ctx.fill(masks, &z, 4, maskWords * 4, "bitmask masks");
      ctx.launchWith("bitmask/self", sk, cl::NDRange(npx, count), cl::NullRange, f.positions,
                     f.triangles, orient, f.gids, f.ggeo, f.lightBuffer, grids, cl_int(l0), slot,
                     diskBuf_, cl_int(npx), masks, frameBuf);
      ctx.launchWith("bitmask/triangles", tk, cl::NDRange(f.triangleCount, kStripes, count),
                     cl::NullRange, f.positions, f.triangles, cl_int(f.triangleCount),
                     f.lightBuffer, grids, cl_int(l0), counts, ends, lists, f.gpos, cl_int(npx),
                     lut_, diskBuf_, cl_int(kStripes), zfar, masks, orient, cl_float(rot),
                     frameBuf);
      ctx.launchWith("bitmask/resolve", rk,
                     cpuResolve ? cl::NDRange(cpuFormItems(std::size_t(npx), kResolveGroup), count)
                                : cl::NDRange(npx, count),
                     cl::NullRange, f.gnrm,
                     f.lightBuffer, grids, cl_int(l0), slot, diskBuf_, cl_int(npx), masks, f.vis,
                     weightBuf, frameBuf);
      if (cap) {
        auto m = ctx.download<cl_uint>(masks, maskWords, "bitmask masks");
        for (int b = 0; b < count; ++b)
          for (int px = 0; px < npx; ++px)
            for (int w = 0; w < W; ++w) {
              std::size_t at = (std::size_t(l0 + b) * npx + px) * W + w;
              if (hard_) {
                std::size_t bit = std::size_t(b) * npx + px;
                cap->masks[at] = (m[bit >> 5] >> (bit & 31)) & 1u;
              } else {
                cap->masks[at] = m[(std::size_t(b) * npx + px) * W + w];
              }
            }
      }
    }
    if (!cap) collect(f, counts, grids, slot, nl, S, W, nullptr);
  }

  // List grid (int length + int64 end) plus the masks held at once, per list texel per light.
  std::size_t bytesPerTexel(const RenderOptions&) const override {
    return std::size_t(std::ceil(heldBytesPerTexel_ > 0 ? heldBytesPerTexel_ : 12.0));
  }
  // The technique never reads the standard shadow maps: its own lists replace them.
  bool usesShadowMaps() const override { return false; }
  bool lightFromShadowMap(int) const override { return false; }  // exact: tests triangles
  std::size_t frameBytes(const RenderOptions&, std::size_t) const override { return heldBytes_; }
  std::vector<std::pair<std::string, double>> frameStats() const override {
    settleStats();
    const BitmaskStats& st = stats_;
    return {{"list_size", double(listSize_)},
            {"view_samples", double(st.viewSamples)},
            {"list_texels", double(st.texels)},
            {"occupied_texels", double(st.occupiedTexels)},
            {"mean_list_length", st.meanList},
            {"max_list_length", double(st.maxList)},
            {"light_samples", double(disk_.size())}};
  }

 private:
  // Per-mesh orientation of the frame's triangles (meshOrientation), from the renderer's host
  // copy of the scene as uploaded (ShadowFrame::hostTriangles, hostPositions).
  std::vector<cl_int> orientation(ShadowFrame& f) {
    if (!f.hostTriangles || !f.hostPositions)
      throw Error(ErrorKind::Internal, "bitmask: the renderer gave no host copy of the scene");
    const std::vector<cl_int4>& t4 = *f.hostTriangles;
    std::vector<std::array<int, 4>> tris(t4.size());
    int maxV = -1, meshes = 0;
    for (std::size_t i = 0; i < t4.size(); ++i) {
      tris[i] = {t4[i].s[0], t4[i].s[1], t4[i].s[2], t4[i].s[3]};
      maxV = std::max({maxV, tris[i][0], tris[i][1], tris[i][2]});
      meshes = std::max(meshes, tris[i][3] + 1);
    }
    const std::vector<cl_float4>& p4 = *f.hostPositions;
    std::vector<std::array<float, 3>> pos(std::size_t(maxV + 1));
    for (std::size_t i = 0; i < pos.size(); ++i) pos[i] = {p4[i].s[0], p4[i].s[1], p4[i].s[2]};
    std::vector<int> o = meshOrientation(pos, tris, meshes);
    return std::vector<cl_int>(o.begin(), o.end());
  }

  // Statistics from the list lengths read back (countsHost_): without a capture the read is
  // queued (countsRead_) and summed by settleStats() when frameStats() asks; with one it is
  // waited for here, and the capture also takes the lists and the G-buffer.
  void collect(ShadowFrame& f, cl::Buffer& counts, cl::Buffer& grids, cl::Buffer& slot, int nl,
               int S, int W, BitmaskCapture* cap) {
    Context& ctx = f.ctx;
    const std::size_t texels = std::size_t(S) * S * nl, pairs = std::size_t(f.pixels) * nl;
    settleStats();  // an earlier frame's read, if still pending, is done with countsHost_
    countsHost_.resize(texels);
    countsRead_ = ctx.readAsync(counts, countsHost_.data(), texels * sizeof(cl_int),
                                "bitmask list lengths");
    if (!cap) return;
    settleStats();
    const std::vector<cl_int>& c = countsHost_;
    const BitmaskStats st = stats_;
    cap->hard = hard_;
    cap->pixels = f.pixels;
    cap->words = W;
    cap->lights = f.lights;
    cap->grids = ctx.download<pb_list_grid>(grids, nl, "bitmask grids");
    cap->disk = disk_;
    cap->slot = ctx.download<cl_int>(slot, pairs, "bitmask sample slots");
    cap->counts.assign(c.begin(), c.end());
    cap->masks.assign(pairs * W, 0u);
    auto four = [&](cl::Buffer& b) {
      auto v = ctx.download<cl_float4>(b, std::size_t(f.pixels), "bitmask capture");
      std::vector<std::array<float, 4>> o(v.size());
      for (std::size_t i = 0; i < v.size(); ++i) o[i] = {v[i].s[0], v[i].s[1], v[i].s[2], v[i].s[3]};
      return o;
    };
    cap->gpos = four(f.gpos);
    cap->ggeo = four(f.ggeo);
    cap->gnrm = four(f.gnrm);
    cap->gids = ctx.download<cl_uint>(f.gids, std::size_t(f.pixels), "bitmask capture");
    cap->stats = st;
  }

  // Waits for the queued read of the list lengths, if any, and sums them into stats_.
  void settleStats() const {
    if (!countsRead_()) return;
    try {
      countsRead_.wait();
    } catch (const cl::Error& e) {
      countsRead_ = cl::Event();
      stats_ = BitmaskStats{};  // not the previous frame's figures, should stats be asked again
      rethrowCl(e, "bitmask: reading back the list lengths");
    }
    countsRead_ = cl::Event();
    BitmaskStats st;
    st.texels = std::int64_t(countsHost_.size());
    for (cl_int v : countsHost_) {
      st.viewSamples += v;
      if (v > 0) ++st.occupiedTexels;
      st.maxList = std::max(st.maxList, int(v));
    }
    st.meanList = st.occupiedTexels ? double(st.viewSamples) / double(st.occupiedTexels) : 0.0;
    stats_ = st;
  }

  bool hard_;
  std::vector<std::array<float, 2>> disk_;
  cl::Buffer diskBuf_, lut_;
  double heldBytesPerTexel_ = 0;
  int tableSamples_ = 0;
  double diskRot_ = -1;
  std::size_t heldBytes_ = 0;
  int listSize_ = 0;
  // the last frame's, reported by frameStats(); summed from countsHost_ once countsRead_ is done
  mutable BitmaskStats stats_;
  std::vector<cl_int> countsHost_;
  mutable cl::Event countsRead_;
};

}  // namespace

std::vector<std::array<float, 2>> bitmaskDiskSamples(int n, double rotation) {
  std::vector<std::array<float, 2>> d(std::max(n, 0));
  for (int k = 0; k < n; ++k) {
    const auto p = fibonacciDiskPoint(k, n, rotation);
    d[k] = {float(p[0]), float(p[1])};
  }
  return d;
}

std::array<float, 3> bitmaskSampleDirection(const pb_light& L, float tanAlpha, float u, float v) {
  return bitmaskSampleDirection(L, tanAlpha, bitmaskFrame(L, nullptr), u, v);
}

BitmaskFrame bitmaskFrame(const pb_light& L, const AreaLight* al) {
  BitmaskFrame fr{{L.ex[0], L.ex[1], L.ex[2], 1.0f}, {L.ey[0], L.ey[1], L.ey[2], 1.0f}};
  if (!al || al->shape != LightShape::Polygon || al->outline != AreaLight::Outline::Ellipse) return fr;
  const float c = L.dir[3];
  const float ta = std::sqrt(std::max(1.0f - c * c, 0.0f)) / std::max(c, 1e-6f);
  // the ellipse's axes, made orthogonal to the kernels' light direction (the same up to rounding)
  std::array<float, 3> w = {L.dir[0], L.dir[1], L.dir[2]}, u = al->axisU;
  const float wu = w[0] * u[0] + w[1] * u[1] + w[2] * u[2];
  for (int i = 0; i < 3; ++i) u[i] -= wu * w[i];
  const float ul = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  for (float& x : u) x /= ul;
  // axisV = axisU x direction (lights.hpp)
  const std::array<float, 3> v = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                                  u[0] * w[1] - u[1] * w[0]};
  // the bounding cap holds the ellipse (its polygon's vertices lie outside it), so f <= 1
  fr.e1 = {u[0], u[1], u[2], std::min(al->tanHalf[0] / ta, 1.0f)};
  fr.e2 = {v[0], v[1], v[2], std::min(al->tanHalf[1] / ta, 1.0f)};
  return fr;
}

std::array<float, 3> bitmaskSampleDirection(const pb_light& L, float tanAlpha,
                                            const BitmaskFrame& fr, float u, float v) {
  std::array<float, 3> d;
  const float a = tanAlpha * fr.e1[3] * u, b = tanAlpha * fr.e2[3] * v;
  for (int i = 0; i < 3; ++i) d[i] = L.dir[i] + a * fr.e1[i] + b * fr.e2[i];
  float len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  for (float& x : d) x /= len;
  return d;
}

std::vector<int> meshOrientation(const std::vector<std::array<float, 3>>& positions,
                                 const std::vector<std::array<int, 4>>& triangles, int meshes) {
  // Weld vertices by exact position, so meshes with split vertices (a box's faces) count as
  // closed where their surface is.
  std::map<std::array<std::uint32_t, 3>, int> weld;
  std::vector<int> id(positions.size());
  for (std::size_t i = 0; i < positions.size(); ++i) {
    std::array<std::uint32_t, 3> key;
    for (int c = 0; c < 3; ++c) {
      float v = positions[i][c] == 0.0f ? 0.0f : positions[i][c];  // -0 welds with +0
      std::memcpy(&key[c], &v, 4);
    }
    id[i] = weld.emplace(key, int(weld.size())).first->second;
  }
  std::vector<int> out(std::max(meshes, 0), 1);
  std::vector<double> volume(out.size(), 0.0);
  std::vector<std::unordered_map<std::uint64_t, int>> edges(out.size());
  auto edgeKey = [](int a, int b) { return (std::uint64_t(std::uint32_t(a)) << 32) | std::uint32_t(b); };
  for (const auto& t : triangles) {
    if (t[3] < 0 || t[3] >= meshes) continue;
    const int m = t[3];
    int v[3];
    bool bad = false;
    for (int k = 0; k < 3; ++k) {
      if (t[k] < 0 || std::size_t(t[k]) >= positions.size()) { bad = true; break; }
      v[k] = id[t[k]];
    }
    if (bad || v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) {
      out[m] = 0;
      continue;
    }
    for (int k = 0; k < 3; ++k) ++edges[m][edgeKey(v[k], v[(k + 1) % 3])];
    const auto &a = positions[t[0]], &b = positions[t[1]], &c = positions[t[2]];
    // signed volume of the tetrahedron (origin, a, b, c), times 6
    volume[m] += double(a[0]) * (double(b[1]) * c[2] - double(b[2]) * c[1]) -
                 double(a[1]) * (double(b[0]) * c[2] - double(b[2]) * c[0]) +
                 double(a[2]) * (double(b[0]) * c[1] - double(b[1]) * c[0]);
  }
  for (std::size_t m = 0; m < out.size(); ++m) {
    if (out[m] == 0 || edges[m].empty()) {
      out[m] = 0;
      continue;
    }
    for (const auto& [key, n] : edges[m]) {
      auto rev = edges[m].find((key << 32) | (key >> 32));
      if (n != 1 || rev == edges[m].end() || rev->second != 1) {
        out[m] = 0;
        break;
      }
    }
    if (out[m] != 0) out[m] = volume[m] > 0 ? 1 : volume[m] < 0 ? -1 : 0;
  }
  return out;
}

double bitmaskJitterAngle(int jitter) {
  if (jitter <= 0) return 0.0;
  // 2 pi frac(j / golden ratio): any run of consecutive frames spreads its rotations evenly
  const double g = 0.61803398874989484820, t = std::fmod(jitter * g, 1.0);
  return 2 * 3.14159265358979323846 * t;
}

void validate(const BitmaskOptions& o, bool hard) {
  if (!hard && (o.lightSamples < 32 || o.lightSamples > 1024 || o.lightSamples % 32 != 0))
    badOption("RenderOptions.bitmask.lightSamples",
              "be a multiple of 32 in [32, 1024] (128, 256, 512, 1024)", o.lightSamples);
  if (o.jitter < 0) badOption("RenderOptions.bitmask.jitter", "be >= 0", o.jitter);
}

void setBitmaskCapture(BitmaskCapture* capture) { gCapture = capture; }

std::unique_ptr<ShadowPass> makeBitmaskPass(bool hard) { return std::make_unique<BitmaskPass>(hard); }

}  // namespace penumbra::detail
