// Contact shadows (ShadowOptions::contactShadows, kernels/render/contact.cl): both kernels (the
// camera's triangles, contact_shadows; the lights' maps, contact_map) against plain C++ loops on
// awkward image sizes, the leak at a contact that a large depth bias opens and contact shadows
// close (with its negative control), an occluder off screen that only the lights' maps find
// (with its), open ground left exactly as the technique made it, which techniques get them, the
// option's checks, and the kernels under oclgrind.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "common.hpp"
#include "render/contact.hpp"
#include "support/planar_penumbra.hpp"
#include "support/scoped_env.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

using D3 = std::array<double, 3>;
D3 d3(const cl_float4& v) { return {v.s[0], v.s[1], v.s[2]}; }
D3 sub(D3 a, D3 b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
D3 cross(D3 a, D3 b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(D3 a, D3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// A synthetic frame: random triangles in the unit box, every pixel on one of them (or on nothing),
// random lights. block > 1: the pixels of each block x block square share their triangle (or the
// background), so that a pixel inside a block has only its own triangle around it (the camera
// side's CPU form skips those); nlights lights.
struct Synthetic {
  int w, h;
  std::vector<cl_float4> pos, gpos, ggeo;
  std::vector<cl_int4> tris;
  std::vector<cl_uint> ids;
  std::vector<pb_light> lights;
  std::vector<float> vis;
};

Synthetic synthetic(int w, int h, unsigned seed, int block = 1, int nlights = 5) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Synthetic s{w, h, {}, {}, {}, {}, {}, {}, {}};
  const int ntri = 40;
  for (int t = 0; t < ntri; ++t) {
    // Small triangles (side ~0.3) around a random centre: many hits, many misses.
    const float cx = u(rng), cy = u(rng), cz = u(rng);
    const int base = int(s.pos.size());
    for (int k = 0; k < 3; ++k)
      s.pos.push_back({{cx + 0.3f * (u(rng) - 0.5f), cy + 0.3f * (u(rng) - 0.5f),
                        cz + 0.3f * (u(rng) - 0.5f), 1.0f}});
    s.tris.push_back({{base, base + 1, base + 2, 0}});
  }
  const int bw = (w + block - 1) / block, bh = (h + block - 1) / block;
  std::vector<int> blockTri(block > 1 ? std::size_t(bw) * bh : 0);  // -1: the background
  for (int& t : blockTri) t = u(rng) < 0.1f ? -1 : int(u(rng) * ntri) % ntri;
  for (int p = 0; p < w * h; ++p) {
    const int bt = block > 1 ? blockTri[std::size_t(p / w / block) * bw + (p % w) / block] : 0;
    if (block > 1 ? bt < 0 : u(rng) < 0.1f) {  // background
      s.ids.push_back(PB_ID_EMPTY);
      s.gpos.push_back({{0, 0, 0, 0}});
      s.ggeo.push_back({{0, 1, 0, 0}});
      continue;
    }
    const int t = block > 1 ? bt : int(u(rng) * ntri) % ntri;
    const cl_int4 tr = s.tris[std::size_t(t)];
    float a = u(rng), b = u(rng);
    if (a + b > 1) { a = 1 - a; b = 1 - b; }
    D3 A = d3(s.pos[tr.s[0]]), B = d3(s.pos[tr.s[1]]), C = d3(s.pos[tr.s[2]]);
    D3 n = cross(sub(B, A), sub(C, A));
    const double len = std::sqrt(dot(n, n));
    if (u(rng) < 0.5f) n = {-n[0], -n[1], -n[2]};  // either side faces the camera
    s.ids.push_back(cl_uint(t));
    s.gpos.push_back({{float(A[0] + a * (B[0] - A[0]) + b * (C[0] - A[0])),
                       float(A[1] + a * (B[1] - A[1]) + b * (C[1] - A[1])),
                       float(A[2] + a * (B[2] - A[2]) + b * (C[2] - A[2])), 1.0f}});
    s.ggeo.push_back({{float(n[0] / len), float(n[1] / len), float(n[2] / len), 0.0f}});
  }
  for (int l = 0; l < nlights; ++l) {
    pb_light L{};
    D3 d{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5};
    const double dl = std::sqrt(dot(d, d));
    for (int k = 0; k < 3; ++k) L.dir[k] = float(d[k] / dl);
    L.dir[3] = 0.95f;
    L.ex[3] = 0.5f + u(rng);  // half-extents: a texel of 2 * max / map_size
    L.ey[3] = 0.5f + u(rng);
    s.lights.push_back(L);
  }
  const float levels[] = {1.0f, 0.25f, 0.0f};
  for (int i = 0; i < w * h * int(s.lights.size()); ++i) s.vis.push_back(levels[rng() % 3]);
  return s;
}

// The kernel's rule in double precision. Returns the expected buffer and, per entry, whether the
// answer is too close to call (a hit within 1e-4 of a triangle's edge or of the ray's end), where
// float and double may disagree.
void reference(const Synthetic& s, float texels, int mapSize, bool maskLight2,
               std::vector<float>& out, std::vector<char>& close) {
  out = s.vis;
  close.assign(s.vis.size(), 0);
  const int R = 2, np = s.w * s.h;
  for (int y = 0; y < s.h; ++y)
    for (int x = 0; x < s.w; ++x) {
      const int p = y * s.w + x;
      if (s.gpos[p].s[3] == 0) continue;
      const D3 P = d3(s.gpos[p]), ng = d3(s.ggeo[p]);
      const double lift = 4e-7 * (std::fabs(P[0]) + std::fabs(P[1]) + std::fabs(P[2]));
      std::vector<cl_uint> list;
      for (int j = std::max(0, y - R); j <= std::min(s.h - 1, y + R); ++j)
        for (int i = std::max(0, x - R); i <= std::min(s.w - 1, x + R); ++i) {
          const cl_uint id = s.ids[std::size_t(j) * s.w + i];
          if (id == PB_ID_EMPTY || id == s.ids[p]) continue;
          if (std::find(list.begin(), list.end(), id) != list.end()) continue;
          const cl_int4 t = s.tris[id];
          bool above = false;
          for (int k = 0; k < 3; ++k) above = above || dot(sub(d3(s.pos[t.s[k]]), P), ng) > lift;
          if (above) list.push_back(id);
        }
      for (std::size_t l = 0; l < s.lights.size(); ++l) {
        const std::size_t vi = l * np + p;
        if ((maskLight2 && l == 2) || s.vis[vi] == 0) continue;  // light 2 masked off
        const pb_light& L = s.lights[l];
        const D3 d{L.dir[0], L.dir[1], L.dir[2]};
        if (dot(d, ng) <= 0) continue;
        const double texel = 2.0 * std::max(L.ex[3], L.ey[3]) / mapSize, len = texels * texel;
        const double off = std::max(1e-3 * texel, 2 * lift);
        const D3 o{P[0] + ng[0] * off, P[1] + ng[1] * off, P[2] + ng[2] * off};
        bool hit = false, near = false;
        for (cl_uint id : list) {
          const cl_int4 t = s.tris[id];
          const D3 a = d3(s.pos[t.s[0]]), b = d3(s.pos[t.s[1]]), c = d3(s.pos[t.s[2]]);
          const D3 e1 = sub(b, a), e2 = sub(c, a), pv = cross(d, e2);
          const double det = dot(e1, pv);
          if (std::fabs(det) < 1e-9) {  // (near) parallel: the kernel's float may go either way
            near = near || std::fabs(det) > 0;
            continue;
          }
          const D3 sv = sub(o, a), q = cross(sv, e1);
          const double bu = dot(sv, pv) / det, bv = dot(d, q) / det, tt = dot(e2, q) / det;
          const double margin = std::min({bu, bv, 1 - bu - bv});
          if (std::fabs(margin) < 1e-4 && tt > 0 && tt < len * (1 + 1e-4)) near = true;
          if (margin >= 0 && std::fabs(tt - len) < 1e-4 * len) near = true;
          if (margin >= 0 && tt > 0 && tt < len) hit = true;
        }
        if (hit) out[vi] = 0;
        close[vi] = near;
      }
    }
}

// Runs the kernel on a synthetic frame, light 2 masked off or not; returns the number of entries
// that differ from the reference where the reference is clear, and the number of entries the
// kernel set to 0, in all and in light 2.
struct KernelRun {
  int mismatches = 0, zeroed = 0, zeroedLight2 = 0, close = 0, entries = 0;
};

// The frame's fields both kernels read, from the synthetic frame, map size S.
void fillFrame(detail::ShadowFrame& f, detail::BufferPool& pool, const Synthetic& s, int S) {
  f.width = s.w;
  f.height = s.h;
  f.pixels = s.w * s.h;
  f.mapSize = S;
  f.lightBuffer = pool.upload("lights", s.lights);
  f.gpos = pool.upload("gpos", s.gpos);
  f.ggeo = pool.upload("ggeo", s.ggeo);
  f.gids = pool.upload("ids", s.ids);
  f.positions = pool.upload("positions", s.pos);
  f.triangles = pool.upload("triangles", s.tris);
  f.triangleCount = int(s.tris.size());
  f.vis = pool.upload("vis", s.vis);
}

// The kernel's result `got` against the reference's `want` where `close` does not excuse it.
KernelRun tally(const Synthetic& s, const std::vector<float>& got, const std::vector<float>& want,
                const std::vector<char>& close) {
  KernelRun r;
  const std::size_t np = std::size_t(s.w) * s.h;
  r.entries = int(got.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    r.close += close[i];
    if (!close[i] && got[i] != want[i]) ++r.mismatches;
    const bool z = got[i] == 0 && s.vis[i] != 0;
    r.zeroed += z;
    r.zeroedLight2 += z && i / np == 2;
  }
  return r;
}

// Light 2 stands for one whose visibility already tests triangles: left alone.
std::vector<cl_uchar> lightMask(const Synthetic& s, bool maskLight2) {
  std::vector<cl_uchar> mask(s.lights.size(), 1);
  if (maskLight2) mask[2] = 0;
  return mask;
}

// One run of contact_shadows: a synthetic frame (block, nlights: synthetic's), light 2 masked off
// or not, in the CPU form (PENUMBRA_CPU_BATCHING=on: a run of a row a work-item, SIMD over the
// lights) or a pixel a work-item (=off), whatever the device. *got: the visibility it left.
struct CameraRun {
  int w, h;
  unsigned seed;
  bool maskLight2 = true, batched = false;
  int block = 1, nlights = 5;
};

KernelRun runKernel(const CameraRun& c, std::vector<float>* gotOut = nullptr) {
  const Synthetic s = synthetic(c.w, c.h, c.seed, c.block, c.nlights);
  const float texels = 10.0f;
  const int mapSize = 16;
  RenderOptions ro;
  ro.shadow.contactTexels = texels;
  detail::BufferPool pool(ctx());
  detail::ShadowFrame f(ctx(), pool, ro, s.lights);
  fillFrame(f, pool, s, mapSize);
  {
    const test::ScopedEnv env("PENUMBRA_CPU_BATCHING", std::string(c.batched ? "on" : "off"));
    detail::contactShadows(f, pool.upload("mask", lightMask(s, c.maskLight2)));
  }
  const std::vector<float> got = ctx().download<float>(f.vis, s.vis.size(), "vis");
  std::vector<float> want;
  std::vector<char> close;
  reference(s, texels, mapSize, c.maskLight2, want, close);
  if (gotOut) *gotOut = got;
  return tally(s, got, want, close);
}

bool sameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

// The pixels of a synthetic frame with another triangle in their 5 x 5 window (the ones the CPU
// form tests), and all its pixels on a triangle.
std::array<int, 2> pixelsWithNeighbours(const Synthetic& s) {
  std::array<int, 2> n{0, 0};
  for (int y = 0; y < s.h; ++y)
    for (int x = 0; x < s.w; ++x) {
      const cl_uint own = s.ids[std::size_t(y) * s.w + x];
      if (own == PB_ID_EMPTY) continue;
      ++n[1];
      bool other = false;
      for (int j = std::max(0, y - 2); j <= std::min(s.h - 1, y + 2); ++j)
        for (int i = std::max(0, x - 2); i <= std::min(s.w - 1, x + 2); ++i) {
          const cl_uint id = s.ids[std::size_t(j) * s.w + i];
          other = other || (id != PB_ID_EMPTY && id != own);
        }
      n[0] += other;
    }
  return n;
}

}  // namespace

// 1x1, a row, a column, odd sizes and one wider than a work-group, 5 lights each, with light 2
// masked off and then not; a pixel a work-item and the CPU form, which must agree bit for bit.
TEST(ContactShadows, KernelMatchesHostReference) {
  int zeroed = 0, zeroedLight2 = 0;
  for (auto [w, h] : std::vector<std::array<int, 2>>{{1, 1}, {1, 9}, {9, 1}, {7, 5}, {67, 33}}) {
    std::vector<float> got[2];
    for (bool batched : {false, true}) {
      const unsigned seed = unsigned(w * 131 + h);
      const KernelRun masked = runKernel({w, h, seed, true, batched}, &got[batched]);
      EXPECT_EQ(masked.mismatches, 0) << w << "x" << h << (batched ? ", CPU form" : "");
      EXPECT_EQ(masked.zeroedLight2, 0) << w << "x" << h << (batched ? ", CPU form" : "");
      const KernelRun all = runKernel({w, h, seed, false, batched});
      EXPECT_EQ(all.mismatches, 0) << w << "x" << h << (batched ? ", CPU form" : "");
      if (batched) continue;
      zeroed += masked.zeroed;
      zeroedLight2 += all.zeroedLight2;
    }
    EXPECT_TRUE(sameBits(got[0], got[1])) << w << "x" << h << ": the two forms differ";
  }
  // The synthetic frames do exercise hits (measured: 125 of the 11,325 entries set to 0; a third
  // start at 0 and half face away from their light), and the mask matters (light 2 unmasked:
  // measured 28).
  EXPECT_GT(zeroed, 50);
  EXPECT_GT(zeroedLight2, 5);
}

// The CPU form where it differs: pixels whose window holds only their own triangle (skipped
// there), rows of more than one work-item's run (64 pixels) with a partial last one, and more
// lights than its SIMD loop's 16 lanes (37: two full chunks and a partial one). Both forms against
// the reference and against each other, bit for bit.
TEST(ContactShadows, CpuFormMatchesOnBlocksAndManyLights) {
  int zeroed = 0, skipped = 0, onGeometry = 0;
  for (auto [w, h] : std::vector<std::array<int, 2>>{{1, 1}, {130, 7}, {67, 33}, {5, 70}}) {
    const unsigned seed = unsigned(w * 31 + h);
    const auto around = pixelsWithNeighbours(synthetic(w, h, seed, 6, 37));
    skipped += around[1] - around[0];
    onGeometry += around[1];
    std::vector<float> one, cpu;
    const KernelRun a = runKernel({w, h, seed, true, false, 6, 37}, &one);
    const KernelRun b = runKernel({w, h, seed, true, true, 6, 37}, &cpu);
    EXPECT_EQ(a.mismatches, 0) << w << "x" << h;
    EXPECT_EQ(b.mismatches, 0) << w << "x" << h << ", CPU form";
    EXPECT_EQ(b.zeroedLight2, 0) << w << "x" << h << ", CPU form";
    EXPECT_TRUE(sameBits(one, cpu)) << w << "x" << h << ": the two forms differ";
    zeroed += b.zeroed;
  }
  std::printf("[ penumbra ] CPU form: %d entries set to 0; %d of %d pixels on geometry have only "
              "their own triangle around them\n", zeroed, skipped, onGeometry);
  // Measured: 172 entries set to 0; 711 of the 3,280 pixels on geometry skipped.
  EXPECT_GT(zeroed, 50);
  EXPECT_GT(skipped, onGeometry / 10);
}

TEST(OclgrindContact, Kernel) {
  for (bool batched : {false, true}) {
    const KernelRun r = runKernel({9, 7, 5u, true, batched});
    EXPECT_EQ(r.mismatches, 0) << batched;
    EXPECT_GT(r.zeroed, 0) << batched;
  }
  const KernelRun r = runKernel({70, 9, 5u, true, true, 6, 20});
  EXPECT_EQ(r.mismatches, 0);
  EXPECT_GT(r.zeroed, 0);
}

namespace {

D3 scaled(D3 a, double k) { return {a[0] * k, a[1] * k, a[2] * k}; }
D3 added(D3 a, D3 b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
D3 normalized(D3 a) { return scaled(a, 1.0 / std::sqrt(dot(a, a))); }

// Two-sided ray-triangle in double: the distance along d (or +inf), the barycentric margin (how
// far inside the triangle, < 0 outside) and whether the ray is (near) parallel to it.
struct TriHit {
  double t = INFINITY, margin = -1;
  bool parallel = false;
};
TriHit rayTriangle(D3 o, D3 d, D3 a, D3 b, D3 c) {
  TriHit h;
  const D3 e1 = sub(b, a), e2 = sub(c, a), pv = cross(d, e2);
  const double det = dot(e1, pv);
  if (std::fabs(det) < 1e-9) {
    h.parallel = std::fabs(det) > 0;
    return h;
  }
  const D3 sv = sub(o, a), q = cross(sv, e1);
  const double bu = dot(sv, pv) / det, bv = dot(d, q) / det;
  h.t = dot(e2, q) / det;
  h.margin = std::min({bu, bv, 1 - bu - bv});
  return h;
}

// contact_map's frame: the synthetic frame's triangles, pixels and visibility; shading normals
// tilted off the geometric ones (so that some light centres fall between the two horizons); and
// light frames whose maps are drawn here as the rasterizer keeps them: each texel's ray along
// -w from the light's near plane, the nearest triangle (either side; the least index at equal
// distance) and its distance, PB_DEPTH_EMPTY / PB_ID_EMPTY where none.
struct MapFrame {
  Synthetic s;
  std::vector<cl_float4> gnrm;
  int S = 16;
  std::vector<cl_uint> depth, ids;  // [light][row][column]
};

MapFrame mapFrame(int w, int h, unsigned seed) {
  MapFrame m{synthetic(w, h, seed), {}, 16, {}, {}};
  std::mt19937 rng(seed + 7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  // positions off their triangle along the camera-facing normal, as the renderer's G-buffer
  // lifts them (scene/shadow_offset.hpp)
  for (std::size_t p = 0; p < m.s.gpos.size(); ++p)
    for (int k = 0; k < 3; ++k) m.s.gpos[p].s[k] += 2e-3f * m.s.ggeo[p].s[k];
  for (const cl_float4& g : m.s.ggeo) {
    const D3 ng = d3(g);
    D3 n = normalized(added(ng, {0.6 * u(rng), 0.6 * u(rng), 0.6 * u(rng)}));
    if (dot(n, ng) < 0.3) n = ng;
    m.gnrm.push_back({{float(n[0]), float(n[1]), float(n[2]), 0.0f}});
  }
  const int S = m.S;
  for (pb_light& L : m.s.lights) {
    const D3 w{L.dir[0], L.dir[1], L.dir[2]};
    const D3 ex = normalized(cross(w, std::fabs(w[1]) < 0.9 ? D3{0, 1, 0} : D3{1, 0, 0}));
    const D3 ey = cross(ex, w);
    const D3 org = added({0.5, 0.5, 0.5}, scaled(w, 2.0));
    for (int k = 0; k < 3; ++k) {
      L.ex[k] = float(ex[k]);
      L.ey[k] = float(ey[k]);
      L.origin[k] = float(org[k]);
    }
    L.origin[3] = 4.0f;  // the depth range (read by the map techniques, not here)
    for (int cy = 0; cy < S; ++cy)
      for (int cx = 0; cx < S; ++cx) {
        const double xc = ((cx + 0.5) * 2.0 / S - 1.0) * L.ex[3];
        const double yc = (1.0 - (cy + 0.5) * 2.0 / S) * L.ey[3];
        const D3 o = added(org, added(scaled(ex, xc), scaled(ey, yc)));
        double best = INFINITY;
        cl_uint id = PB_ID_EMPTY;
        for (std::size_t t = 0; t < m.s.tris.size(); ++t) {
          const cl_int4 tr = m.s.tris[t];
          const TriHit hit = rayTriangle(o, scaled(w, -1.0), d3(m.s.pos[tr.s[0]]),
                                         d3(m.s.pos[tr.s[1]]), d3(m.s.pos[tr.s[2]]));
          if (hit.margin >= 0 && hit.t > 0 && hit.t < best) {
            best = hit.t;
            id = cl_uint(t);
          }
        }
        const float f = float(best);
        cl_uint bits = PB_DEPTH_EMPTY;
        if (id != PB_ID_EMPTY) std::memcpy(&bits, &f, 4);
        m.depth.push_back(bits);
        m.ids.push_back(id);
      }
  }
  return m;
}

// contact_map's rule in double precision (contact.cl says why each part): the expected buffer
// and, per entry, whether it is too close to call (p on a texel's edge, a comparison within 1e-5,
// a horizon within 1e-6, a hit within 1e-4 of a triangle's edge or of the ray's end).
void mapReference(const MapFrame& m, float texels, bool maskLight2, std::vector<float>& out,
                  std::vector<char>& close) {
  const Synthetic& s = m.s;
  out = s.vis;
  close.assign(s.vis.size(), 0);
  const int np = s.w * s.h, S = m.S;
  for (int p = 0; p < np; ++p) {
    if (s.gpos[p].s[3] == 0) continue;
    const D3 P = d3(s.gpos[p]), ng = d3(s.ggeo[p]), ns = d3(m.gnrm[p]);
    const cl_uint own = s.ids[p];
    const double lift = 4e-7 * (std::fabs(P[0]) + std::fabs(P[1]) + std::fabs(P[2]));
    for (std::size_t l = 0; l < s.lights.size(); ++l) {
      const std::size_t vi = l * np + p;
      if ((maskLight2 && l == 2) || s.vis[vi] == 0) continue;
      const pb_light& L = s.lights[l];
      const D3 w{L.dir[0], L.dir[1], L.dir[2]}, ex{L.ex[0], L.ex[1], L.ex[2]},
          ey{L.ey[0], L.ey[1], L.ey[2]}, r = sub(P, {L.origin[0], L.origin[1], L.origin[2]});
      const double c = dot(ng, w), cs = dot(ns, w);
      const double xp = dot(r, ex), yp = dot(r, ey), tp = -dot(r, w);
      const double sx = 0.5 * S / L.ex[3], sy = 0.5 * S / L.ey[3];
      const double u = xp * sx + 0.5 * S, v = 0.5 * S - yp * sy;
      bool near = std::fabs(u - std::round(u)) < 1e-4 || std::fabs(v - std::round(v)) < 1e-4;
      const int cx = std::clamp(int(std::floor(u)), 0, S - 1);
      const int cy = std::clamp(int(std::floor(v)), 0, S - 1);
      const double dx = (cx + 0.5 - u) / sx, dy = (v - cy - 0.5) / sy;
      const std::size_t ti = (l * S + cy) * S + cx;
      float tmf;
      std::memcpy(&tmf, &m.depth[ti], 4);
      const double tm = tmf;
      const double texel = 2.0 * std::max(L.ex[3], L.ey[3]) / S, len = texels * texel;
      const double tol = 1e-3 * texel;
      const double lhs = (tm - tp + tol) * c, rhs = dx * dot(ng, ex) + dy * dot(ng, ey);
      const bool up = c > 0 && lhs < rhs && tm >= tp - len;
      const bool down = c <= 0 && cs > 0;
      if (c > 0 && std::isfinite(tm))
        near = near || std::fabs(lhs - rhs) < 1e-5 || std::fabs(tm - (tp - len)) < 1e-5;
      near = near || std::fabs(c) < 1e-6 || (c <= 0 && std::fabs(cs) < 1e-6);
      close[vi] = near;
      if (!up && !down) continue;
      const cl_uint id = m.ids[ti];
      std::vector<cl_uint> tested;
      if (down && own != PB_ID_EMPTY) tested.push_back(own);
      if (id != PB_ID_EMPTY && id != own) tested.push_back(id);
      const D3 o = up ? added(P, scaled(ng, std::max(1e-3 * texel, 2 * lift))) : P;
      bool hit = false;
      for (cl_uint t : tested) {
        const cl_int4 tr = s.tris[t];
        const TriHit th = rayTriangle(o, w, d3(s.pos[tr.s[0]]), d3(s.pos[tr.s[1]]),
                                      d3(s.pos[tr.s[2]]));
        if (th.parallel) close[vi] = 1;
        if (std::fabs(th.margin) < 1e-4 && th.t > 0 && th.t < len * (1 + 1e-4)) close[vi] = 1;
        if (th.margin >= 0 && std::fabs(th.t - len) < 1e-4 * len) close[vi] = 1;
        if (th.margin >= 0 && std::fabs(th.t) < 1e-5) close[vi] = 1;  // starts on it
        hit = hit || (th.margin >= 0 && th.t > 0 && th.t < len);
      }
      if (hit) out[vi] = 0;
    }
  }
}

// tiles: the CPU form (8 x 8 pixels a work-item, PENUMBRA_CPU_BATCHING=on) or a pixel a
// work-item (=off), whatever the device.
KernelRun runMapKernel(int w, int h, unsigned seed, bool tiles, bool maskLight2 = true) {
  const MapFrame m = mapFrame(w, h, seed);
  const Synthetic& s = m.s;
  const float texels = 2.0f;
  RenderOptions ro;
  ro.shadow.contactTexels = texels;
  detail::BufferPool pool(ctx());
  detail::ShadowFrame f(ctx(), pool, ro, s.lights);
  fillFrame(f, pool, s, m.S);
  f.gnrm = pool.upload("gnrm", m.gnrm);
  f.depth = pool.upload("depth", m.depth);
  f.mapIds = pool.upload("map ids", m.ids);
  {
    const test::ScopedEnv env("PENUMBRA_CPU_BATCHING", std::string(tiles ? "on" : "off"));
    detail::contactFromMaps(f, pool.upload("mask", lightMask(s, maskLight2)));
  }
  const std::vector<float> got = ctx().download<float>(f.vis, s.vis.size(), "vis");
  std::vector<float> want;
  std::vector<char> close;
  mapReference(m, texels, maskLight2, want, close);
  return tally(s, got, want, close);
}

}  // namespace

// contact_map (contact shadows from the lights' side) against the plain C++ rule: 1x1, a row, a
// column, odd sizes, and one of several 8 x 8 tiles with partial ones at its edges, 5 lights each,
// light 2 masked off and then not; in tiles (the CPU form) and a pixel a work-item.
TEST(ContactShadows, MapKernelMatchesHostReference) {
  int zeroed = 0, zeroedLight2 = 0, close = 0, entries = 0;
  for (auto [w, h] : std::vector<std::array<int, 2>>{{1, 1}, {1, 9}, {9, 1}, {7, 5}, {67, 33}}) {
    const KernelRun masked = runMapKernel(w, h, unsigned(w * 71 + h), true);
    close += masked.close;
    entries += masked.entries;
    EXPECT_EQ(masked.mismatches, 0) << w << "x" << h;
    EXPECT_EQ(masked.zeroedLight2, 0) << w << "x" << h;
    const KernelRun all = runMapKernel(w, h, unsigned(w * 71 + h), true, false);
    EXPECT_EQ(all.mismatches, 0) << w << "x" << h;
    const KernelRun single = runMapKernel(w, h, unsigned(w * 71 + h), false);
    EXPECT_EQ(single.mismatches, 0) << w << "x" << h << ", a pixel a work-item";
    EXPECT_EQ(single.zeroed, masked.zeroed) << w << "x" << h << ", a pixel a work-item";
    zeroed += masked.zeroed;
    zeroedLight2 += all.zeroedLight2;
  }
  std::printf("[ penumbra ] contact_map set %d entries to 0 (light 2 unmasked: %d); %d of %d "
              "too close to call\n", zeroed, zeroedLight2, close, entries);
  // Measured: 339 entries set to 0 (85 of light 2 unmasked), 5 of 11,325 too close to call.
  EXPECT_GT(zeroed, 150);
  EXPECT_LT(close, entries / 100);
  EXPECT_GT(zeroedLight2, 5);
}

TEST(OclgrindContact, MapKernel) {
  for (bool tiles : {true, false}) {
    const KernelRun r = runMapKernel(9, 7, 5u, tiles);
    EXPECT_EQ(r.mismatches, 0) << tiles;
    EXPECT_GT(r.zeroed, 0) << tiles;
  }
}

namespace {

// A wall (one quad, no thickness) standing on the ground at x = 0.5 under a cap 45 degrees off
// the vertical, towards -x; the camera at +x sees the wall's lit-away side and the ground in front
// of it, the wall's shadow (tests/test_shadow_accuracy.cpp's light and camera). The ground at the
// wall's foot, 0.505 < x < 0.53 and |z| < 0.3, is in its umbra, within 0.03 * sqrt 2 of it along
// the light. With a depth bias of 0.05 of the map's depth range (a bias a user might set against
// acne on steep receivers; about 0.3 world units here) the maps leak there.
struct ContactRegions {
  double umbraMax = 0, litMean = 0;
  int umbra = 0, lit = 0;
  std::vector<float> visibility;
};

// The umbra's largest visibility and the open ground's mean over the receiver pixels whose ground
// point (x, z) each predicate takes (the umbra's first).
ContactRegions regions(const PlanarFrame& f, const std::function<bool(double, double)>& umbra,
                       const std::function<bool(double, double)>& lit) {
  ContactRegions r;
  for (const ReceiverPixel& p : f.receivers) {
    if (umbra(p.x, p.z)) {
      r.umbraMax = std::max(r.umbraMax, p.vis);
      ++r.umbra;
    } else if (lit(p.x, p.z)) {
      r.litMean += p.vis;
      ++r.lit;
    }
  }
  r.litMean /= std::max(r.lit, 1);
  r.visibility = f.visibility;
  return r;
}

Mesh wall() {
  Mesh m;
  m.name = "wall";
  m.positions = {{0.5f, 0, -0.5f}, {0.5f, 0, 0.5f}, {0.5f, 1, 0.5f}, {0.5f, 1, -0.5f}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

ContactRegions contactScene(ShadowTechnique t, bool contact, float depthBias) {
  PlanarPenumbra s;
  s.blockers.clear();
  s.extraMeshes = {wall()};
  const float c = float(std::sqrt(0.5));
  s.light.direction = {-c, c, 0};
  s.light.cosAlpha = float(std::cos(20.0 * M_PI / 180));
  s.light.radiance = {1, 1, 1};
  s.eye = {2.4f, 1.9f, 0.6f};
  s.target = {0.2f, 0.0f, 0.0f};
  s.fovyDeg = 70;
  s.imageWidth = 256;
  s.imageHeight = 192;
  s.keep = [](double x, double) { return x > 0.505 || x < 0.495; };
  RenderOptions ro;
  ro.shadows = t;
  ro.shadow.depthBias = depthBias;
  ro.shadow.contactShadows = contact;
  const ContactRegions r = regions(
      renderPlanar(s, ro),
      [](double x, double z) { return x > 0.505 && x < 0.53 && std::fabs(z) < 0.3; },
      [](double x, double z) { return std::fabs(z) > 1.15 || x < 0.4 || x > 2.75; });
  std::printf("[ penumbra ] %s, bias %g, contact %s: umbra at the contact max V %.4f over %d "
              "pixels; open ground mean V %.4f over %d\n",
              toString(t), depthBias, contact ? "on" : "off", r.umbraMax, r.umbra, r.litMean,
              r.lit);
  return r;
}

}  // namespace

// Hard shadows and MSSM4 with a bias of 0.05: without contact shadows the ground at the wall's
// foot is lit (measured max V: 1 for both; the negative control), with them it is dark
// (measured 0 and 0). Contact shadows never lighten a pixel, and on the open ground, where the
// truth is lit, they change nothing: the same bits.
// The contact's umbra lit without (the negative control) and dark with; the open ground the same
// bits; no pixel lighter.
void expectContactClosed(const ContactRegions& off, const ContactRegions& on, int minUmbra,
                         int minLit, ShadowTechnique t) {
  ASSERT_GE(on.umbra, minUmbra) << toString(t);
  ASSERT_GT(on.lit, minLit) << toString(t);
  EXPECT_GT(off.umbraMax, 0.5) << toString(t);
  EXPECT_LE(on.umbraMax, 0.05) << toString(t);
  EXPECT_EQ(on.litMean, off.litMean) << toString(t);
  ASSERT_EQ(on.visibility.size(), off.visibility.size());
  int lighter = 0;
  for (std::size_t i = 0; i < on.visibility.size(); ++i)
    lighter += on.visibility[i] > off.visibility[i];
  EXPECT_EQ(lighter, 0) << toString(t);
}

TEST(ContactShadows, CloseTheLeakAtAContact) {
  for (ShadowTechnique t : {ShadowTechnique::Hard, ShadowTechnique::MSSM4})
    expectContactClosed(contactScene(t, false, 0.05f), contactScene(t, true, 0.05f), 20, 10000, t);
}

namespace {

// The wall again, 0.3 high and 0.5 wide, with the camera framed so that the top edge of the image
// meets the ground at x = 0.503: the wall is off screen (above that edge's plane everywhere), and
// the ground at its foot, in its umbra, is the top rows of the image. With the depth bias of 0.05
// the maps leak there, and the camera sees no triangle within 2 pixels that could block: only the
// lights' maps, which see the wall, can close it.
ContactRegions offScreenWall(ShadowTechnique t, bool fromMaps) {
  PlanarPenumbra s;
  s.blockers.clear();
  Mesh m;
  m.name = "short wall";
  m.positions = {{0.5f, 0, -0.25f}, {0.5f, 0, 0.25f}, {0.5f, 0.3f, 0.25f}, {0.5f, 0.3f, -0.25f}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  s.extraMeshes = {m};
  const float c = float(std::sqrt(0.5));
  s.light.direction = {-c, c, 0};
  s.light.cosAlpha = float(std::cos(20.0 * M_PI / 180));
  s.light.radiance = {1, 1, 1};
  // eye 0.8 above the ground at x = 1.4; the top edge 41.73 degrees below the horizontal (ground
  // at x = 1.4 - 0.8 / tan 41.73 = 0.503), the centre 20 degrees lower
  const double top = std::atan2(0.8, 1.4 - 0.503), mid = top + 20.0 * M_PI / 180;
  s.eye = {1.4f, 0.8f, 0.0f};
  s.target = {float(1.4 - 0.8 / std::tan(mid)), 0.0f, 0.0f};
  s.fovyDeg = 40;
  s.imageWidth = 256;
  s.imageHeight = 192;
  RenderOptions ro;
  ro.shadows = t;
  ro.shadow.depthBias = 0.05f;
  ro.shadow.contactFromMaps = fromMaps;
  const PlanarFrame f = renderPlanar(s, ro);
  for (const ReceiverPixel& p : f.receivers)
    if (p.x < 0.5) ADD_FAILURE() << "the ground behind the wall is on screen: x " << p.x;
  const ContactRegions r = regions(
      f, [](double x, double z) { return x > 0.505 && x < 0.53 && std::fabs(z) < 0.15; },
      // beyond the shadow and its penumbra
      [](double x, double z) { return x > 1.05 || std::fabs(z) > 0.6; });
  std::printf("[ penumbra ] off-screen wall, %s, from maps %s: umbra at the contact max V %.4f "
              "over %d pixels; open ground mean V %.4f over %d\n",
              toString(t), fromMaps ? "on" : "off", r.umbraMax, r.umbra, r.litMean, r.lit);
  return r;
}

}  // namespace

// An occluder the camera does not see: without the lights' maps the contact is lit (the negative
// control: the screen-space rays find nothing; measured max V 1 with hard shadows and MSSM4), with
// them it is dark (measured 0 and 0 over 350 pixels); nothing gets lighter, and the open ground
// keeps its bits.
TEST(ContactShadows, MapsFindOccludersOffScreen) {
  for (ShadowTechnique t : {ShadowTechnique::Hard, ShadowTechnique::MSSM4})
    expectContactClosed(offScreenWall(t, false), offScreenWall(t, true), 100, 1000, t);
}

// Which lights get them: every light of a technique that reads depth maps with a bias (the
// frame's maps, or its own as brute force and area-approx), none of the bitmask techniques, which
// test triangles. (auto's exact light: AutoFrame.ComposedRowsEqualEachTechniqueAlone, whose rows
// of each technique alone would differ from auto's if it got them.)
TEST(ContactShadows, GivenToMapTechniquesOnly) {
  for (ShadowTechnique t : {ShadowTechnique::Hard, ShadowTechnique::PCSS, ShadowTechnique::CSSM,
                            ShadowTechnique::MSSM4, ShadowTechnique::MSSM6, ShadowTechnique::Brute,
                            ShadowTechnique::AreaApprox})
    EXPECT_TRUE(detail::makeShadowPass(t)->lightFromShadowMap(0)) << toString(t);
  for (ShadowTechnique t : {ShadowTechnique::Bitmask, ShadowTechnique::BitmaskHard})
    EXPECT_FALSE(detail::makeShadowPass(t)->lightFromShadowMap(0)) << toString(t);
}

TEST(ContactShadows, ContactTexelsIsChecked) {
  for (float bad : {0.0f, -1.0f, std::nanf(""), INFINITY}) {
    RenderOptions ro;
    ro.shadow.contactTexels = bad;
    try {
      PlanarPenumbra s;
      renderPlanar(s, ro);
      ADD_FAILURE() << "contactTexels " << bad << " was accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_NE(std::string(e.what()).find("contactTexels"), std::string::npos) << e.what();
    }
  }
}
