// CPU ground truth with Embree 3: one primary ray per pixel (the same pixel centres as the device
// rasterizer, through cameraRayDirection), then Monte Carlo direct lighting of a two-sided diffuse
// surface with exact shadow rays:
//   L_o = albedo/pi * integral over the sphere of L_in(w) V(w) max(0, n.w) dw.
// Both estimators below are unbiased for the model the device renders (a piecewise-constant
// equirect map, or uniform spherical caps), so their noise is the only difference from the truth.
#include "penumbra/reference.hpp"

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <mutex>
#include <thread>
#include <vector>

#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "common/shared.h"
#include "core/json.hpp"
#include "core/vec3.hpp"
#include "reference/embree_scene.hpp"
#include "scene/shadow_offset.hpp"

namespace penumbra {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kMaxImageSide = 16384;

// Vector helpers (float, like the scene data): core/vec3.hpp.
using detail::V3;
using detail::cross;
using detail::dot;
using detail::operator+;
using detail::operator-;
using detail::operator*;
using detail::normalizeNonZero;

// Orthonormal basis around unit n without branches on the sign trouble spot (Duff et al. 2017,
// "Building an Orthonormal Basis, Revisited").
inline void basisAround(V3 n, V3& t, V3& b) {
  float sign = std::copysign(1.0f, n[2]);
  float a = -1.0f / (sign + n[2]);
  float c = n[0] * n[1] * a;
  t = {1.0f + sign * n[0] * n[0] * a, sign * c, -sign * n[0]};
  b = {c, sign + n[1] * n[1] * a, -n[1]};
}

inline double luminance(double r, double g, double b) {
  return PB_LUM_R * r + PB_LUM_G * g + PB_LUM_B * b;
}

// ---------------------------------------------------------------------------------------------
// Random numbers: PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient
// Statistically Good Algorithms for Random Number Generation"), one generator per pixel whose
// state and stream come from (seed, pixel index) through SplitMix64 (Steele et al. 2014). A pixel's
// samples therefore do not depend on which thread renders it, or in what order.

inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

class Pcg32 {
 public:
  Pcg32(std::uint64_t seed, std::uint64_t pixel) {
    std::uint64_t s = splitmix64(seed);
    std::uint64_t initState = splitmix64(s ^ splitmix64(pixel));
    inc_ = (splitmix64(pixel ^ splitmix64(s + 0x632BE59BD9B4E019ull)) << 1) | 1u;
    state_ = 0;
    next();
    state_ += initState;
    next();
  }
  std::uint32_t next() {
    std::uint64_t old = state_;
    state_ = old * 6364136223846793005ull + inc_;
    auto xorshifted = std::uint32_t(((old >> 18) ^ old) >> 27);
    auto rot = std::uint32_t(old >> 59);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
  }
  // Uniform in [0, 1): 24 random mantissa bits, so the result is never rounded up to 1.
  float uniform() { return float(next() >> 8) * (1.0f / 16777216.0f); }

 private:
  std::uint64_t state_ = 0, inc_ = 1;
};

// ---------------------------------------------------------------------------------------------
// Scene flattening and Embree.

}  // namespace

namespace detail {

FlatScene flatten(const Scene& scene) {
  FlatScene f;
  std::size_t nv = 0, nt = 0;
  for (const Mesh& m : scene.meshes) {
    nv += m.positions.size();
    nt += m.triangles.size();
  }
  if (nt == 0) badInput("scene has no triangles");
  if (nv > std::numeric_limits<unsigned>::max() / 2 || nt > std::numeric_limits<unsigned>::max() / 4)
    badInput("scene is too large for the reference renderer");
  f.positions.reserve(nv * 3);
  f.indices.reserve(nt * 3);
  f.triMesh.reserve(nt);
  float lo[3] = {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
                 std::numeric_limits<float>::max()};
  float hi[3] = {-lo[0], -lo[1], -lo[2]};
  for (std::size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const Mesh& m = scene.meshes[mi];
    const std::size_t base = f.positions.size() / 3;
    const std::string label = "scene mesh " + std::to_string(mi) +
                              (m.name.empty() ? std::string() : " (" + m.name + ")");
    f.meshes.push_back(&m);
    f.meshFirstVertex.push_back(std::uint32_t(base));
    for (const Vec3& p : m.positions) {
      for (int c = 0; c < 3; ++c) {
        if (!std::isfinite(p[c])) badInput(label + " has a non-finite vertex coordinate");
        lo[c] = std::min(lo[c], p[c]);
        hi[c] = std::max(hi[c], p[c]);
        f.positions.push_back(p[c]);
      }
    }
    for (const auto& t : m.triangles) {
      for (int c = 0; c < 3; ++c) {
        if (t[c] < 0 || std::size_t(t[c]) >= m.positions.size())
          badInput(label + " has a triangle index out of range: " + std::to_string(t[c]));
        f.indices.push_back(unsigned(base + std::size_t(t[c])));
      }
      f.triMesh.push_back(std::uint32_t(mi));
    }
  }
  // The offset must clear both the geometry's scale and float rounding of coordinates far from
  // the origin; the renderer's G-buffer uses the same one (scene/shadow_offset.hpp).
  f.epsilon = shadowRayOffset(lo, hi);
  return f;
}

EmbreeScene::EmbreeScene(const FlatScene& f, int threads) {
  const std::string config =
      threads > 0 ? "verbose=0,threads=" + std::to_string(threads) : std::string("verbose=0");
  device_ = rtcNewDevice(config.c_str());
  if (!device_) throw Error(ErrorKind::Internal, "Embree: rtcNewDevice failed");
  scene_ = rtcNewScene(device_);
  // Robust mode: no cracks between triangles sharing an edge, which a ground truth cannot have.
  rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
  const std::size_t nv = f.positions.size() / 3, nt = f.indices.size() / 3;
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0,
                                                        RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
  auto* ix = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), nt));
  if (!v || !ix) {
    rtcReleaseGeometry(g);
    check("allocating geometry buffers");
    throw Error(ErrorKind::Internal, "Embree: geometry buffer allocation failed");
  }
  std::memcpy(v, f.positions.data(), f.positions.size() * sizeof(float));
  std::memcpy(ix, f.indices.data(), f.indices.size() * sizeof(unsigned));
  rtcCommitGeometry(g);
  rtcAttachGeometry(scene_, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(scene_);
  check("building the scene");
}
EmbreeScene::~EmbreeScene() {
  if (scene_) rtcReleaseScene(scene_);
  if (device_) rtcReleaseDevice(device_);
}
void EmbreeScene::check(const char* what) {
  RTCError e = rtcGetDeviceError(device_);
  if (e == RTC_ERROR_NONE) return;
  if (e == RTC_ERROR_OUT_OF_MEMORY)
    throw Error(ErrorKind::OutOfMemory, std::string("Embree: out of memory ") + what);
  throw Error(ErrorKind::Internal,
              std::string("Embree error ") + std::to_string(int(e)) + " while " + what);
}
}  // namespace detail

namespace {

using detail::EmbreeScene;
using detail::FlatScene;
using detail::flatten;

// A surface point as the shading sees it.
struct Hit {
  V3 p{};        // position (from barycentrics, so it lies on the triangle)
  V3 ng{};       // unit geometric normal on the camera's side
  V3 n{};        // unit shading normal on the same side
  V3 origin{};   // shadow-ray origin: p offset along ng
  const Mesh* mesh = nullptr;
};

// Traces the primary ray; false when it leaves the scene.
bool tracePrimary(const EmbreeScene& es, const FlatScene& f, V3 eye, V3 dir, Hit& h) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  rh.ray.org_x = eye[0];
  rh.ray.org_y = eye[1];
  rh.ray.org_z = eye[2];
  rh.ray.dir_x = dir[0];
  rh.ray.dir_y = dir[1];
  rh.ray.dir_z = dir[2];
  rh.ray.tnear = 0.0f;
  rh.ray.tfar = std::numeric_limits<float>::infinity();
  rh.ray.time = 0.0f;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(es.get(), &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;

  const unsigned prim = rh.hit.primID;
  const unsigned* tri = &f.indices[std::size_t(prim) * 3];
  auto vert = [&](unsigned i) {
    return V3{f.positions[3 * std::size_t(i)], f.positions[3 * std::size_t(i) + 1],
              f.positions[3 * std::size_t(i) + 2]};
  };
  const V3 p0 = vert(tri[0]), p1 = vert(tri[1]), p2 = vert(tri[2]);
  // Embree's barycentrics: p = (1-u-v) p0 + u p1 + v p2.
  const float u = rh.hit.u, v = rh.hit.v, w = 1.0f - u - v;
  h.p = p0 * w + p1 * u + p2 * v;
  h.mesh = f.meshes[f.triMesh[prim]];

  // Two-sided: the geometric normal is turned towards the viewer.
  V3 ng = normalizeNonZero(cross(p1 - p0, p2 - p0));
  if (dot(ng, ng) == 0.0f) ng = dir * -1.0f;  // degenerate triangle: face the camera
  if (dot(ng, dir) > 0.0f) ng = ng * -1.0f;
  h.ng = ng;

  // Interpolated vertex normals when the mesh has them. They are turned to the side of the
  // (camera-facing) geometric normal: the same as "towards the camera" except at silhouettes,
  // where an interpolated normal can point slightly away from the eye although the face does not.
  V3 n = ng;
  const Mesh& m = *h.mesh;
  if (!m.normals.empty() && m.normals.size() == m.positions.size()) {
    const std::uint32_t base = f.meshFirstVertex[f.triMesh[prim]];
    V3 s = m.normals[tri[0] - base] * w + m.normals[tri[1] - base] * u +
           m.normals[tri[2] - base] * v;
    float l2 = dot(s, s);
    if (l2 > 0.0f && std::isfinite(l2)) {
      s = s * (1.0f / std::sqrt(l2));
      n = dot(s, ng) < 0.0f ? s * -1.0f : s;
    }
  }
  h.n = n;
  h.origin = h.p + ng * f.epsilon;
  return true;
}

// True if nothing blocks direction d (unit) from the shadow-ray origin to infinity.
inline bool unoccluded(const EmbreeScene& es, const V3& origin, const V3& d) {
  return !detail::rayOccluded(es.get(), origin, d, 0.0f);
}

// ---------------------------------------------------------------------------------------------
// The environment as a piecewise-constant distribution: texel (c, r) is picked with probability
// lum(c, r) * dw(r) / total (marginal CDF over rows, conditional CDF within the row), then a
// direction uniform in solid angle inside the texel (phi uniform, cos(theta) uniform within the
// row's band). The density over solid angle is then exactly P(texel) / dw(row) = lum / total.

class EnvSampler {
 public:
  explicit EnvSampler(const Environment& env) : env_(env) {
    const Image& im = env.equirect;
    w_ = im.width;
    h_ = im.height;
    shift_ = env.rotationColumns();
    rowCdf_.assign(std::size_t(h_) + 1, 0.0);
    colCdf_.assign(std::size_t(h_) * (std::size_t(w_) + 1), 0.0);
    texelOmega_.resize(std::size_t(h_));
    cosEdge_.resize(std::size_t(h_) + 1);
    for (int r = 0; r <= h_; ++r) cosEdge_[std::size_t(r)] = std::cos(kPi * r / h_);
    for (int r = 0; r < h_; ++r) {
      texelOmega_[std::size_t(r)] = env.texelSolidAngle(r);
      double* cdf = &colCdf_[std::size_t(r) * (std::size_t(w_) + 1)];
      for (int c = 0; c < w_; ++c) {
        float rgb[3];
        texel(c, r, rgb);
        cdf[c + 1] = cdf[c] + luminance(rgb[0], rgb[1], rgb[2]);
      }
      rowCdf_[std::size_t(r) + 1] = rowCdf_[std::size_t(r)] + cdf[w_] * texelOmega_[std::size_t(r)];
    }
    total_ = rowCdf_[std::size_t(h_)];
  }

  // False for a black map: then only the cosine lobe is sampled.
  bool usable() const { return total_ > 0.0 && std::isfinite(total_); }

  void texel(int c, int r, float rgb[3]) const {
    const Image& im = env_.equirect;
    const std::size_t i = (std::size_t(r) * im.width + c) * im.channels;
    for (int k = 0; k < 3; ++k) rgb[k] = im.pixels[i + std::size_t(std::min(k, im.channels - 1))];
  }

  // The texel a direction falls in, exactly as Environment::lookup picks it (nearest, clamped).
  void texelOf(V3 d, int& c, int& r) const {
    float s, t;
    pb_dir_equirect(d[0], d[1], d[2], float(w_), float(h_), &s, &t);
    c = pb_env_column(s, shift_, w_);  // the map's rotation about +y
    r = std::clamp(int(std::floor(t)), 0, h_ - 1);
  }

  // Density over solid angle of sampling texel (c, r) and a direction in it.
  double pdf(int c, int r) const {
    const double* cdf = &colCdf_[std::size_t(r) * (std::size_t(w_) + 1)];
    const double rowMass = rowCdf_[std::size_t(r) + 1] - rowCdf_[std::size_t(r)];
    const double rowSum = cdf[w_];
    if (rowMass <= 0.0 || rowSum <= 0.0) return 0.0;
    // Written with the same CDF differences that sample() inverts, so the two agree exactly.
    const double pTexel = (rowMass / total_) * ((cdf[c + 1] - cdf[c]) / rowSum);
    return pTexel / texelOmega_[std::size_t(r)];
  }

  // Picks a texel and a direction in it; returns the direction and the texel.
  V3 sample(Pcg32& rng, int& c, int& r) const {
    r = pick(rowCdf_.data(), h_, double(rng.uniform()) * total_);
    const double* cdf = &colCdf_[std::size_t(r) * (std::size_t(w_) + 1)];
    c = pick(cdf, w_, double(rng.uniform()) * cdf[w_]);
    // Texel c of the (rotated) map starts at world column pb_env_world_column.
    const float s = pb_env_world_column(c, shift_, w_) + rng.uniform();
    // cos(theta) uniform within the row: with phi uniform this is uniform in solid angle.
    const double c0 = cosEdge_[std::size_t(r)], c1 = cosEdge_[std::size_t(r) + 1];
    const double ct = c0 + double(rng.uniform()) * (c1 - c0);
    double t = std::acos(std::clamp(ct, -1.0, 1.0)) / kPi * h_;
    t = std::clamp(t, double(r), std::nextafter(double(r + 1), double(r)));
    V3 d;
    pb_equirect_dir(s, float(t), float(w_), float(h_), &d[0], &d[1], &d[2]);
    return d;
  }

 private:
  // Index i in [0, n) with cdf[i] <= x < cdf[i+1] and a non-empty bin (cdf has n+1 entries,
  // cdf[0] = 0, non-decreasing).
  static int pick(const double* cdf, int n, double x) {
    int i = int(std::upper_bound(cdf + 1, cdf + n + 1, x) - (cdf + 1));
    i = std::min(i, n - 1);
    // x rounding to the total can land on trailing empty bins: step back to a non-empty one.
    while (i > 0 && !(cdf[i + 1] > cdf[i])) --i;
    return i;
  }

  const Environment& env_;
  int w_ = 0, h_ = 0;
  float shift_ = 0;                 // Environment::rotationColumns()
  std::vector<double> rowCdf_;      // h+1: cumulative sum of rowSum(r) * dw(r)
  std::vector<double> colCdf_;      // h x (w+1): cumulative luminance within each row
  std::vector<double> texelOmega_;  // solid angle of a texel in row r
  std::vector<double> cosEdge_;     // cos(theta) at row edges
  double total_ = 0;
};

// Cosine-weighted direction about unit n: Malley's method (uniform disk, projected up).
inline V3 sampleCosine(V3 n, Pcg32& rng) {
  const float u1 = rng.uniform(), u2 = rng.uniform();
  const float rad = std::sqrt(u1), phi = float(2.0 * kPi) * u2;
  const float z = std::sqrt(std::max(0.0f, 1.0f - u1));
  V3 t, b;
  basisAround(n, t, b);
  return normalizeNonZero(t * (rad * std::cos(phi)) + b * (rad * std::sin(phi)) + n * z);
}

// Uniform direction in the cap of half-angle alpha around unit axis a: cos(theta) uniform in
// [cos alpha, 1], phi uniform, density 1 / (2 pi (1 - cos alpha)).
inline V3 sampleCap(V3 a, float cosAlpha, Pcg32& rng) {
  const float u1 = rng.uniform(), u2 = rng.uniform();
  const float ct = 1.0f - u1 * (1.0f - cosAlpha);
  const float st = std::sqrt(std::max(0.0f, 1.0f - ct * ct));
  const float phi = float(2.0 * kPi) * u2;
  V3 t, b;
  basisAround(a, t, b);
  return normalizeNonZero(t * (st * std::cos(phi)) + b * (st * std::sin(phi)) + a * ct);
}

// ---------------------------------------------------------------------------------------------
// The per-pixel loop shared by both modes.

void validateOptions(const ReferenceOptions& opt) {
  if (opt.width < 1 || opt.width > kMaxImageSide)
    badInput("ReferenceOptions.width must be between 1 and 16384, got " + std::to_string(opt.width));
  if (opt.height < 1 || opt.height > kMaxImageSide)
    badInput("ReferenceOptions.height must be between 1 and 16384, got " + std::to_string(opt.height));
  if (opt.spp < 1) badInput("ReferenceOptions.spp must be >= 1, got " + std::to_string(opt.spp));
  if (opt.threads < 0) badInput("ReferenceOptions.threads must be >= 0, got " + std::to_string(opt.threads));
}

void validateEnvironment(const Environment& env) {
  const Image& im = env.equirect;
  if (im.empty() || im.width < 1 || im.height < 1 || im.channels < 3 ||
      im.pixels.size() != std::size_t(im.width) * im.height * im.channels)
    badInput("environment map is empty or not RGB" +
             (env.source.empty() ? std::string() : " (" + env.source + ")"));
}

// What shade() writes for a geometry pixel: the full estimate, its two halves (ReferenceImage),
// and in light-set mode the lights' visibility.
struct PixelSample {
  float full[3] = {0, 0, 0}, a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
  float visibility = 1.0f;
};

// shade(hit, rng, sample) fills the sample of a geometry pixel.
template <class Shade>
ReferenceImage renderPixels(const Camera& camera, const Environment* background,
                            const ReferenceOptions& opt, bool withVisibility, Shade&& shade,
                            const EmbreeScene& es, const FlatScene& flat) {
  const int W = opt.width, H = opt.height;
  ReferenceImage result;
  result.image = Image(W, H, 4, 0.0f);
  result.halfA = Image(W, H, 4, 0.0f);
  result.halfB = Image(W, H, 4, 0.0f);
  if (withVisibility) result.visibility = Image(W, H, 1, 1.0f);
  Image& out = result.image;
  const CameraBasis basis = cameraBasis(camera, W, H);
  const V3 eye = basis.eye;

  unsigned nThreads = opt.threads > 0 ? unsigned(opt.threads) : std::thread::hardware_concurrency();
  nThreads = std::max(1u, std::min(nThreads, unsigned(H)));

  const std::size_t totalPixels = std::size_t(W) * std::size_t(H);
  std::atomic<int> nextRow{0}, rowsDone{0};
  std::atomic<std::size_t> pixelsDone{0};
  std::atomic<bool> abort{false};
  std::exception_ptr failure;
  std::mutex mutex;  // guards `failure`; pairs with `wake` so no notification is lost
  std::condition_variable wake;

  auto renderPixel = [&](int x, int y) {
    const V3 dir = cameraRayDirection(basis, W, H, float(x) + 0.5f, float(y) + 0.5f);
    const std::size_t at = (std::size_t(y) * W + x) * 4;
    float* px = &out.pixels[at];
    float* pa = &result.halfA.pixels[at];
    float* pb = &result.halfB.pixels[at];
    Hit hit;
    if (tracePrimary(es, flat, eye, dir, hit)) {
      Pcg32 rng(opt.seed, std::uint64_t(y) * std::uint64_t(W) + std::uint64_t(x));
      PixelSample ps;
      shade(hit, rng, ps);
      for (int k = 0; k < 3; ++k) {
        px[k] = ps.full[k];
        pa[k] = ps.a[k];
        pb[k] = ps.b[k];
      }
      px[3] = pa[3] = pb[3] = 1.0f;
      if (withVisibility) result.visibility.pixels[std::size_t(y) * W + x] = ps.visibility;
    } else if (background) {
      background->lookup(dir[0], dir[1], dir[2], px);
      px[3] = 0.0f;
      for (int k = 0; k < 4; ++k) pa[k] = pb[k] = px[k];
    }
    pixelsDone.fetch_add(1, std::memory_order_relaxed);
  };
  // A row, pixel by pixel, asking keepGoing() before each one: at thousands of samples per pixel
  // a row takes seconds, a pixel milliseconds, so a stop is honoured within a pixel. False when
  // it stopped early.
  auto renderRow = [&](int y, auto&& keepGoing) {
    for (int x = 0; x < W; ++x) {
      if (!keepGoing()) return false;
      renderPixel(x, y);
    }
    return true;
  };

  // The contract in reference.hpp: progress and cancel are called from the calling thread only,
  // never concurrently, at every poll; an exception from either (or the Cancelled error thrown
  // here) stops the render and propagates to the caller.
  auto poll = [&]() {
    const std::size_t done = pixelsDone.load(std::memory_order_relaxed);
    const double fraction = double(done) / double(totalPixels);
    if (opt.progress) opt.progress(fraction);
    if (opt.cancel && opt.cancel()) {
      char what[128];
      std::snprintf(what, sizeof what, "reference: cancelled after %.1f%% (%zu of %zu pixels)",
                    100.0 * fraction, done, totalPixels);
      throw Error(ErrorKind::Cancelled, what);
    }
  };
  const auto pollInterval = std::chrono::milliseconds(100);

  auto worker = [&]() {
    try {
      auto keepGoing = [&] { return !abort.load(std::memory_order_relaxed); };
      for (;;) {
        if (!keepGoing()) return;
        const int y = nextRow.fetch_add(1);
        if (y >= H) return;
        if (!renderRow(y, keepGoing)) return;
        rowsDone.fetch_add(1);
        { std::lock_guard<std::mutex> lock(mutex); }
        wake.notify_one();
      }
    } catch (...) {
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (!failure) failure = std::current_exception();
        abort = true;
      }
      wake.notify_one();
    }
  };

  // A first poll before any work: a cancel already set stops at 0%, and both callbacks are
  // called at least once however quickly the pool finishes.
  if (opt.progress || opt.cancel) poll();
  std::vector<std::thread> pool;
  if (nThreads > 1) {
    pool.reserve(nThreads);
    try {
      for (unsigned i = 0; i < nThreads; ++i) pool.emplace_back(worker);
    } catch (...) {
      // Fewer threads than asked for: those running still take every row (or none: see below).
    }
  }
  if (pool.empty()) {
    // One thread: render here, polling after each row and between pixels once the interval has
    // passed (the clock costs nanoseconds, a pixel microseconds at the least).
    const bool polled = opt.progress || opt.cancel;
    auto lastPoll = std::chrono::steady_clock::now();
    auto keepGoing = [&] {
      if (polled && std::chrono::steady_clock::now() - lastPoll >= pollInterval) {
        poll();
        lastPoll = std::chrono::steady_clock::now();
      }
      return true;
    };
    for (int y = 0; y < H; ++y) {
      renderRow(y, keepGoing);
      if (polled && y + 1 < H) {
        poll();
        lastPoll = std::chrono::steady_clock::now();
      }
    }
  } else {
    // The calling thread watches and polls while the pool renders: on every finished row and at
    // least every pollInterval.
    try {
      int seen = 0;
      for (;;) {
        std::unique_lock<std::mutex> lock(mutex);
        wake.wait_for(lock, pollInterval, [&] { return abort.load() || rowsDone.load() != seen; });
        const bool stop = abort.load();
        seen = rowsDone.load();
        lock.unlock();
        if (stop || seen >= H) break;
        poll();
      }
    } catch (...) {
      abort = true;
      for (auto& t : pool) t.join();
      throw;
    }
    for (auto& t : pool) t.join();
    if (failure) std::rethrow_exception(failure);
  }
  if (opt.progress) opt.progress(1.0);
  result.relativeNoise = opt.spp >= 2 ? relativeNoiseOfHalves(result.halfA, result.halfB, out)
                                      : std::numeric_limits<double>::quiet_NaN();
  return result;
}

}  // namespace

Image referenceEnvironment(const Scene& scene, const Camera& camera, const Environment& env,
                           const ReferenceOptions& opt) {
  return referenceEnvironmentWithNoise(scene, camera, env, opt).image;
}

ReferenceImage referenceEnvironmentWithNoise(const Scene& scene, const Camera& camera,
                                             const Environment& env, const ReferenceOptions& opt) {
  validateOptions(opt);
  validateEnvironment(env);
  const FlatScene flat = flatten(scene);
  const EmbreeScene es(flat, opt.threads);
  const EnvSampler envs(env);

  // Sample counts per technique. With n_e map samples and n_c cosine samples, the multi-sample
  // balance heuristic (Veach 1997, thesis §9.2.2, eq. 9.10 with w_i = n_i p_i / sum_k n_k p_k)
  // makes every sample, whichever technique drew it, contribute f(w) / (n_e p_e(w) + n_c p_c(w)).
  // This stays unbiased for any split, including odd spp and a black map (n_e = 0).
  const int nEnv = envs.usable() ? opt.spp / 2 : 0;
  const int nCos = opt.spp - nEnv;
  const double invPi = 1.0 / kPi;

  auto shade = [&](const Hit& h, Pcg32& rng, PixelSample& out) {
    // sum: every sample, as before the halves existed (so the image is unchanged); sumA: those of
    // even iterations. Each sample's weight already divides by the total counts, so the full
    // estimate is the sum and a half's estimate is twice its part.
    double sum[3] = {0, 0, 0}, sumA[3] = {0, 0, 0};
    bool even = true;
    // Adds the sample in direction d whose radiance comes from texel (c, r).
    auto add = [&](V3 d, int c, int r) {
      const float cosN = dot(h.n, d);
      if (!(cosN > 0.0f)) return;  // below the shading hemisphere: the integrand is 0
      float L[3];
      envs.texel(c, r, L);
      if (L[0] <= 0.0f && L[1] <= 0.0f && L[2] <= 0.0f) return;
      const double denom = nEnv * envs.pdf(c, r) + nCos * (cosN * invPi);
      if (!(denom > 0.0)) return;
      if (!unoccluded(es, h.origin, d)) return;
      const double wgt = cosN / denom;
      for (int k = 0; k < 3; ++k) {
        sum[k] += L[k] * wgt;
        if (even) sumA[k] += L[k] * wgt;
      }
    };
    const int iterations = std::max(nEnv, nCos);
    for (int i = 0; i < iterations; ++i) {
      even = (i & 1) == 0;
      if (i < nEnv) {
        int c, r;
        const V3 d = envs.sample(rng, c, r);
        // The texel that was sampled supplies the radiance (its pdf is the one used); d lies in it
        // up to float rounding at texel edges.
        add(d, c, r);
      }
      if (i < nCos) {
        const V3 d = sampleCosine(h.n, rng);
        int c, r;
        envs.texelOf(d, c, r);
        add(d, c, r);
      }
    }
    const auto& a = h.mesh->albedo;
    for (int k = 0; k < 3; ++k) {
      out.full[k] = float(a[k] * invPi * sum[k]);
      out.a[k] = float(a[k] * invPi * 2.0 * sumA[k]);
      out.b[k] = float(a[k] * invPi * 2.0 * (sum[k] - sumA[k]));
    }
  };

  return renderPixels(camera, opt.environmentBackground ? &env : nullptr, opt, false, shade, es,
                      flat);
}

Image referenceLights(const Scene& scene, const Camera& camera, const LightSet& lights,
                      const Environment& env, const ReferenceOptions& opt) {
  return referenceLightsWithNoise(scene, camera, lights, env, opt).image;
}

ReferenceImage referenceLightsWithNoise(const Scene& scene, const Camera& camera,
                                        const LightSet& lights, const Environment& env,
                                        const ReferenceOptions& opt) {
  validateOptions(opt);
  // The map is only the background here, so it is needed only when a background is drawn.
  if (opt.environmentBackground) validateEnvironment(env);

  struct CapLight {
    V3 axis;
    float cosAlpha;
    float radiance[3];
    double solidAngle;
    const AreaLight* src;
    std::vector<V3> edgeNormals;  // polygon lights: v_i x v_i+1, inside where all dot >= 0
    bool ellipse = false;         // ellipse lights: inside where frameCoords x^2 + y^2 <= 1
    bool inside(const V3& d) const {
      if (ellipse) {
        const auto xy = src->frameCoords(d);
        return xy[0] * xy[0] + xy[1] * xy[1] <= 1.0f;
      }
      for (const V3& en : edgeNormals)
        if (dot(en, d) < 0.0f) return false;
      return true;
    }
  };
  std::vector<CapLight> caps;
  caps.reserve(lights.lights.size());
  for (std::size_t i = 0; i < lights.lights.size(); ++i) {
    const AreaLight& l = lights.lights[i];
    bool finite = std::isfinite(l.cosAlpha);
    for (int k = 0; k < 3; ++k)
      finite = finite && std::isfinite(l.direction[k]) && std::isfinite(l.radiance[k]);
    if (!finite) badInput("light " + std::to_string(i) + " has a non-finite value");
    V3 axis = normalizeNonZero(l.direction);
    if (dot(axis, axis) == 0.0f) badInput("light " + std::to_string(i) + " has a zero direction");
    CapLight c;
    c.axis = axis;
    c.cosAlpha = std::clamp(l.cosAlpha, -1.0f, 1.0f);
    for (int k = 0; k < 3; ++k) c.radiance[k] = std::max(0.0f, l.radiance[k]);
    c.solidAngle = 2.0 * kPi * (1.0 - double(c.cosAlpha));
    if (l.shape == LightShape::Polygon && l.outline == AreaLight::Outline::Ellipse) {
      // Uniform in the ellipse itself (not its shading polygon) by rejection from the bounding
      // cap, which holds it; pdf 1 / the ellipse's solid angle.
      c.ellipse = true;
      c.solidAngle = double(l.solidAngle());
    } else if (l.shape == LightShape::Polygon) {
      // Uniform in the polygon by rejection from its bounding cap (lights.hpp: the cap contains
      // it); the estimator's pdf is then 1 / the polygon's solid angle.
      const std::size_t nv = l.vertices.size();
      for (std::size_t v = 0; v < nv; ++v)
        c.edgeNormals.push_back(cross(l.vertices[v], l.vertices[(v + 1) % nv]));
      c.solidAngle = double(l.solidAngle());
    }
    c.src = &l;
    caps.push_back(c);
  }

  const FlatScene flat = flatten(scene);
  const EmbreeScene es(flat, opt.threads);
  const double invPi = 1.0 / kPi;

  const bool shadowAmbient = opt.shadowAmbient && lights.hasAmbient;
  auto shade = [&](const Hit& h, Pcg32& rng, PixelSample& out) {
    // Light selection in proportion to the unshadowed irradiance's luminance at this point: the
    // visibility-free part of each light's contribution, so the estimator is exact where nothing
    // is in the way (up to the cosine's variation inside the cap).
    thread_local std::vector<double> cdf;
    cdf.assign(caps.size() + 1, 0.0);
    const std::array<float, 3>& n = h.n;
    for (std::size_t i = 0; i < caps.size(); ++i) {
      double lum = 0.0;
      if (caps[i].solidAngle > 0.0) {
        const std::array<float, 3> e = caps[i].src->irradiance(n);
        lum = luminance(e[0], e[1], e[2]);
        if (!(lum > 0.0) || !std::isfinite(lum)) lum = 0.0;
      }
      cdf[i + 1] = cdf[i] + lum;
    }
    const double total = cdf[caps.size()];
    // sum: every sample; sumA: the even ones (half A). lumShadowed / lumOpen: the luminance of
    // the samples with and without their visibility, for ReferenceImage::visibility.
    double sum[3] = {0, 0, 0}, sumA[3] = {0, 0, 0};
    double lumShadowed = 0.0, lumOpen = 0.0;
    if (total > 0.0) {
      for (int s = 0; s < opt.spp; ++s) {
        const double x = double(rng.uniform()) * total;
        std::size_t i = std::size_t(std::upper_bound(cdf.begin() + 1, cdf.end(), x) -
                                    (cdf.begin() + 1));
        i = std::min(i, caps.size() - 1);
        while (i > 0 && !(cdf[i + 1] > cdf[i])) --i;
        const CapLight& c = caps[i];
        const double prob = (cdf[i + 1] - cdf[i]) / total;
        V3 d = sampleCap(c.axis, c.cosAlpha, rng);
        for (int tries = 0; (c.ellipse || !c.edgeNormals.empty()) && tries < 1000; ++tries) {
          if (c.inside(d)) break;
          d = sampleCap(c.axis, c.cosAlpha, rng);
        }
        const float cosN = dot(h.n, d);
        if (!(cosN > 0.0f)) continue;
        // f / (prob * pdf) with pdf = 1 / solid angle; a textured light's radiance where d is
        const double wgt = cosN * c.solidAngle / prob;
        const std::array<float, 3> rad =
            c.src->texture.empty() ? std::array<float, 3>{c.radiance[0], c.radiance[1], c.radiance[2]}
                                   : c.src->radianceAt(d);
        double f[3];
        for (int k = 0; k < 3; ++k) f[k] = std::max(0.0f, rad[k]) * wgt;
        const double lum = luminance(f[0], f[1], f[2]);
        lumOpen += lum;
        if (!unoccluded(es, h.origin, d)) continue;
        lumShadowed += lum;
        for (int k = 0; k < 3; ++k) {
          sum[k] += f[k];
          if ((s & 1) == 0) sumA[k] += f[k];
        }
      }
    }
    out.visibility = lumOpen > 0.0 ? float(lumShadowed / lumOpen) : 1.0f;
    // The ambient residual, unshadowed as the renderer applies it (kernels/render/shade.cl): the
    // same light set, so the only difference left between the two is the shadow technique. The sum
    // is clamped at 0 as there (a residual may be negative where a cap outshines its texels).
    const std::array<double, 3> amb = lights.ambientIrradiance(n);
    // opt.shadowAmbient (reference.hpp): the residual's SH9 radiance in the blocked cosine-sampled
    // directions, pi L_res(w) per sample, taken off the unshadowed irradiance.
    double blocked[3] = {0, 0, 0}, blockedA[3] = {0, 0, 0};
    if (shadowAmbient) {
      for (int s = 0; s < opt.spp; ++s) {
        const V3 d = sampleCosine(h.n, rng);
        if (unoccluded(es, h.origin, d)) continue;
        float y[9];
        pb_sh9(d[0], d[1], d[2], y);
        for (int k = 0; k < 3; ++k) {
          double L = 0.0;
          for (int j = 0; j < 9; ++j) L += double(lights.ambientSH[std::size_t(j)][std::size_t(k)]) * y[j];
          blocked[k] += kPi * L;
          if ((s & 1) == 0) blockedA[k] += kPi * L;
        }
      }
    }
    const auto& a = h.mesh->albedo;
    const double perSample = 1.0 / opt.spp, perHalfSample = 2.0 / opt.spp;
    for (int k = 0; k < 3; ++k) {
      const double ambK = amb[k] - blocked[k] * perSample;
      out.full[k] = float(a[k] * invPi * std::max(0.0, sum[k] / opt.spp + ambK));
      out.a[k] = float(a[k] * invPi *
                       std::max(0.0, sumA[k] * perHalfSample + amb[k] - blockedA[k] * perHalfSample));
      out.b[k] = float(a[k] * invPi *
                       std::max(0.0, (sum[k] - sumA[k]) * perHalfSample + amb[k] -
                                         (blocked[k] - blockedA[k]) * perHalfSample));
    }
  };

  return renderPixels(camera, opt.environmentBackground ? &env : nullptr, opt, true, shade, es,
                      flat);
}

// ---------------------------------------------------------------------------------------------
// Metrics.

double relativeNoiseOfHalves(const Image& halfA, const Image& halfB, const Image& full) {
  if (halfA.width != full.width || halfA.height != full.height || halfB.width != full.width ||
      halfB.height != full.height || halfA.channels < 3 || halfB.channels < 3 || full.channels < 3)
    badInput("relativeNoiseOfHalves: the halves and the full image must be RGB(A) of one size");
  const std::size_t n = std::size_t(full.width) * std::size_t(full.height);
  double sumSq = 0.0, sumFull = 0.0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const float* pf = &full.pixels[i * full.channels];
    if (full.channels >= 4 && !(pf[3] > 0.5f)) continue;
    const float* pa = &halfA.pixels[i * halfA.channels];
    const float* pb = &halfB.pixels[i * halfB.channels];
    for (int k = 0; k < 3; ++k) {
      const double d = double(pa[k]) - double(pb[k]);
      sumSq += d * d;
      sumFull += pf[k];
    }
    ++count;
  }
  if (count == 0 || !(sumFull > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  const double values = 3.0 * double(count);
  return 0.5 * std::sqrt(sumSq / values) / (sumFull / values);
}

ImageMetrics compareImages(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height)
    badInput("image sizes differ: A is " + std::to_string(a.width) + "x" +
             std::to_string(a.height) + ", reference B is " + std::to_string(b.width) + "x" +
             std::to_string(b.height));
  if (a.channels < 3 || b.channels < 3)
    badInput("images must have 3 (RGB) or 4 (RGBA) channels; A has " +
             std::to_string(a.channels) + ", B has " + std::to_string(b.channels));
  const std::size_t n = std::size_t(a.width) * std::size_t(a.height);
  if (a.pixels.size() != n * a.channels || b.pixels.size() != n * b.channels)
    badInput("image pixel data does not match its size");

  const bool masked = b.channels >= 4;
  double sumSq = 0, sumB = 0, maxB = -std::numeric_limits<double>::infinity(), maxAbs = 0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const float* pb = &b.pixels[i * b.channels];
    const float* pa = &a.pixels[i * a.channels];
    if (masked && !(pb[3] > 0.5f)) continue;
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(pa[k])) badInput("image A contains non-finite values");
      if (!std::isfinite(pb[k])) badInput("image B (reference) contains non-finite values");
      const double d = double(pa[k]) - double(pb[k]);
      sumSq += d * d;
      sumB += pb[k];
      maxB = std::max(maxB, double(pb[k]));
      maxAbs = std::max(maxAbs, std::fabs(d));
    }
    ++count;
  }
  if (count == 0) badInput("no geometry pixels to compare (reference alpha is 0 everywhere)");

  ImageMetrics m;
  const double values = 3.0 * double(count);
  m.pixels = count;
  m.rmse = std::sqrt(sumSq / values);
  m.maxAbsError = maxAbs;
  const double meanB = sumB / values;
  const double inf = std::numeric_limits<double>::infinity();
  m.relativeRmse = meanB > 0 ? m.rmse / meanB : (m.rmse == 0 ? 0.0 : inf);
  // Identical images: infinite PSNR. A black reference with errors: -inf.
  m.psnr = m.rmse > 0 ? (maxB > 0 ? 20.0 * std::log10(maxB / m.rmse) : -inf) : inf;
  return m;
}

std::string toJson(const ImageMetrics& m) {
  // One line, numbers in their shortest round-trip form (nlohmann's, independent of the locale).
  // JSON has no infinities or NaN: those are written as null (e.g. the PSNR of identical images).
  detail::Json j;
  j["rmse"] = detail::finiteOrNull(m.rmse);
  j["relative_rmse"] = detail::finiteOrNull(m.relativeRmse);
  j["psnr"] = detail::finiteOrNull(m.psnr);
  j["max_abs_error"] = detail::finiteOrNull(m.maxAbsError);
  j["pixels"] = m.pixels;
  return detail::dumpJson(j, -1);
}

}  // namespace penumbra
