// Bent normals at light silhouettes (Sintorn et al. 2008 §4.3): the host side of
// kernels/render/bent.cl
// (welding, launches) and the plain C++ reference of its per-vertex stage.
#include "render/bent_normals.hpp"

#include <climits>
#include <cmath>
#include <cstring>
#include <limits>
#include <unordered_map>

#include "core/vec3.hpp"

namespace penumbra::detail {

namespace {

// Position and normal of a vertex, bit for bit, as a hash key.
struct VertexKey {
  std::array<std::uint32_t, 8> bits;
  bool operator==(const VertexKey& o) const { return bits == o.bits; }
};
struct VertexKeyHash {
  std::size_t operator()(const VertexKey& k) const {
    std::size_t h = 1469598103934665603ull;
    for (std::uint32_t b : k.bits) h = (h ^ b) * 1099511628211ull;
    return h;
  }
};

}  // namespace

std::vector<cl_int4> weldedTriangles(const std::vector<cl_float4>& pos,
                                     const std::vector<cl_float4>& nrm,
                                     const std::vector<cl_int4>& tris) {
  std::unordered_map<VertexKey, int, VertexKeyHash> first;
  first.reserve(pos.size());
  std::vector<int> canon(pos.size());
  for (std::size_t v = 0; v < pos.size(); ++v) {
    VertexKey k{};
    std::memcpy(k.bits.data(), pos[v].s, 16);
    std::memcpy(k.bits.data() + 4, nrm[v].s, 16);
    canon[v] = first.emplace(k, int(v)).first->second;
  }
  std::vector<cl_int4> out(tris);
  for (cl_int4& t : out)
    for (int k = 0; k < 3; ++k) t.s[k] = canon[std::size_t(t.s[k])];
  return out;
}

void bentVertices(Context& ctx, const cl::Buffer& pos, const cl::Buffer& nrm,
                  const cl::Buffer& tris, int ntris, int nverts, const cl::Buffer& lights,
                  int nlights, cl::Buffer& bend) {
  if (ntris == 0 || nlights == 0 || nverts == 0) return;
  // INT_MAX (minimum) and INT_MIN (maximum): no face yet.
  const cl_int2 empty{{INT_MAX, INT_MIN}};
  ctx.fill(bend, &empty, sizeof empty, std::size_t(nlights) * nverts * sizeof empty,
           "bent normals per vertex");
  cl::Kernel k = ctx.kernel("bent.cl", "bent_vertices");
  ctx.launchWith("bent-normals/vertices", k,
                 cl::NDRange(std::size_t(ntris), std::size_t(nlights)), cl::NullRange, pos, nrm,
                 tris, cl_int(ntris), cl_int(nlights), lights, bend);
}

std::vector<std::array<float, 2>> bentVerticesReference(
    const std::vector<cl_float4>& pos, const std::vector<cl_float4>& nrm,
    const std::vector<cl_int4>& tris, const std::vector<std::array<float, 3>>& lightDirs) {
  const float inf = std::numeric_limits<float>::infinity();
  const std::size_t nv = pos.size();
  std::vector<std::array<float, 2>> out(lightDirs.size() * nv, {inf, -inf});
  for (std::size_t l = 0; l < lightDirs.size(); ++l)
    for (const cl_int4& t : tris) {
      const V3 a = xyz(pos[t.s[0]].s), b = xyz(pos[t.s[1]].s), c = xyz(pos[t.s[2]].s);
      const V3 e1{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      V3 n = cross(e1, e2);
      const float len = std::sqrt(dot(n, n));
      if (!(len > 0) || !std::isfinite(len)) continue;
      n = {n[0] / len, n[1] / len, n[2] / len};
      const float d = dot(n, lightDirs[l]);
      for (int k = 0; k < 3; ++k) {
        const cl_float4& vn = nrm[t.s[k]];
        const float s = vn.s[3] > 0 && dot(n, xyz(vn.s)) < 0 ? -d : d;
        auto& e = out[std::size_t(t.s[k]) * lightDirs.size() + l];
        e[0] = std::min(e[0], s);
        e[1] = std::max(e[1], s);
      }
    }
  return out;
}

BentBuffers bentNormals(Context& ctx, BufferPool& pool, const DeviceScene& scene,
                        const cl::Buffer& lights, int nlights, const DeviceGBuffer& g,
                        int npixels) {
  const std::vector<cl_float4>& pos = scene.positions();
  const std::vector<cl_int4>& tris = scene.triangles();
  const int nverts = int(pos.size()), ntris = int(tris.size());
  cl::Buffer& welded =
      pool.upload("welded triangles", weldedTriangles(pos, scene.normals(), tris));
  cl::Buffer& bend = pool.buffer("bent normals per vertex",
                                 std::max<std::size_t>(1, std::size_t(nlights) * nverts) * 8);
  bentVertices(ctx, scene.positionBuffer(), scene.normalBuffer(), welded, ntris, nverts, lights,
               nlights, bend);
  cl::Buffer& vert = pool.buffer("bent normals: pixel vertices", std::size_t(npixels) * 16);
  cl::Buffer& weight = pool.buffer("bent normals: pixel weights", std::size_t(npixels) * 16);
  cl::Kernel k = ctx.kernel("bent.cl", "bent_pixels");
  ctx.launchWith("bent-normals/pixels", k, cl::NDRange(std::size_t(npixels)), cl::NullRange,
                 scene.positionBuffer(), scene.normalBuffer(), welded, g.ids, g.position,
                 g.normal, cl_int(npixels), vert, weight);
  return {bend, vert, weight};
}

}  // namespace penumbra::detail
