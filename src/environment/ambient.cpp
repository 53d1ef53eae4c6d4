// The ambient residual of a light set (Arbree et al. 2005 §3; Ramamoorthi & Hanrahan 2001): what
// the lights
// do not carry, the map minus the lights (caps or polygons), applied unshadowed. Always as 9
// spherical-harmonic coefficients of order <= 2 (its power, the JSON, AmbientModel::SH9), and by
// default also as Arbree et al.'s (2005) pre-integrated irradiance map
// (kernels/environment/irradiance.cl),
// which is what shading then reads. Also the LightSet methods that concern the ambient.
//
// The map's projection runs on the device (kernels/environment/sh.cl, exact per lat-long texel);
// each cap's projection is analytic (below), each polygon's a quadrature on the host, so the
// residual costs one pass over the map whatever the method. The irradiance map subtracts each
// light's exact irradiance per table normal on the device.
#include <algorithm>
#include <cmath>

#include "penumbra/ambient.hpp"
#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "common/shared.h"
#include "lights/light_buffers.hpp"

namespace penumbra {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kCoeffs = 9;
// Texels each work-item of sh_project visits (grid stride): enough work per item to hide the
// reduction, enough work-groups to fill a GPU (a 1024x512 map gives 128 groups of 256).
constexpr std::size_t kTexelsPerItem = 16;
constexpr std::size_t kMaxGroups = 1024;
// Irradiance map (kernels/environment/irradiance.cl): running sums per map texel (RGB x xyz moment,
// 9 floats), and the table normals' sums in bands of kBandRows map rows (a 1024x512 map's band of
// prefixes, 8 x 37 KB, stays in cache while every normal reads it), at most kMaxPartials normal x
// band sums (12 MB) however large the table.
constexpr std::size_t kBandRows = 8;
constexpr std::size_t kMaxPartials = std::size_t(1) << 20;
// Row prefixes held at once (a chunk of bands): 64 MiB, a 1024x512 map's 19 MB in one chunk, a
// 16384-wide map's in chunks of 112 rows. (Smaller chunks, measured at 4 and 12 MiB, are no
// faster: more launches, and the bands' reads hit the cache no more often.)
constexpr std::size_t kMaxPrefixBytes = std::size_t(64) << 20;

using SH9 = std::array<std::array<double, 3>, kCoeffs>;

// Row (theta) and column (phi) integrals of kernels/environment/sh.cl's texel_sh9, in double:
// differences of nearby cosines lose digits in float, in double they keep ~1e-12 relative on any
// map up to 16k. `shift`: the map's rotation about +y in columns (Environment::rotationColumns):
// map column c covers world columns [c - shift, c - shift + 1) (pb_env_world_column, modulo the
// width, which the periodic phi integrals do not see), so the projection is the rotated map's,
// exactly.
void shTables(int W, int H, double shift, std::vector<cl_float8>& rows,
              std::vector<cl_float8>& cols) {
  rows.assign(H, cl_float8{});
  cols.assign(W, cl_float8{});
  for (int r = 0; r < H; ++r) {
    const double a = kPi * r / H, b = kPi * (r + 1) / H;
    const double ca = std::cos(a), cb = std::cos(b), sa = std::sin(a), sb = std::sin(b);
    const double v[6] = {
        ca - cb,                                            // int sin
        0.5 * (b - a) - 0.25 * (std::sin(2 * b) - std::sin(2 * a)),  // int sin^2
        0.5 * (sb * sb - sa * sa),                          // int cos sin
        (ca - cb) - (ca * ca * ca - cb * cb * cb) / 3.0,    // int sin^3 = int (1 - cos^2) sin
        (ca * ca * ca - cb * cb * cb) / 3.0,                // int cos^2 sin
        (sb * sb * sb - sa * sa * sa) / 3.0,                // int sin^2 cos
    };
    for (int k = 0; k < 6; ++k) rows[r].s[k] = float(v[k]);
  }
  const double whole = std::floor(shift), frac = shift - whole;
  for (int c = 0; c < W; ++c) {
    // phi = (s / W - 0.5) 2 pi at world column s, as pb_equirect_dir; s0 wrapped into
    // [-frac, W - frac) as pb_env_world_column does, so that a turn by whole columns gives each
    // world column the very same floats (kernels/environment/irradiance.cl sums them in world
    // order)
    int w = (c - int(whole)) % W;
    if (w < 0) w += W;
    const double s0 = double(w) - frac;
    const double p = (s0 / W - 0.5) * 2 * kPi, q = ((s0 + 1) / W - 0.5) * 2 * kPi;
    const double sp = std::sin(p), sq = std::sin(q);
    const double v[6] = {
        q - p,                                                       // int 1
        std::cos(p) - std::cos(q),                                   // int sin
        sq - sp,                                                     // int cos
        0.5 * (q - p) - 0.25 * (std::sin(2 * q) - std::sin(2 * p)),  // int sin^2
        0.5 * (q - p) + 0.25 * (std::sin(2 * q) - std::sin(2 * p)),  // int cos^2
        0.5 * (sq * sq - sp * sp),                                   // int sin cos
    };
    for (int k = 0; k < 6; ++k) cols[c].s[k] = float(v[k]);
  }
}

// The map and its row/column integrals on the device, shared by the SH projection and the
// irradiance map.
struct DeviceMap {
  int W = 0, H = 0;
  cl::Buffer eq, rows, cols;
};

DeviceMap uploadMap(Context& ctx, const Environment& env) {
  const Image& eq = env.equirect;
  if (eq.empty() || eq.channels != 3) badInput(env.source + ": environment has no RGB pixels");
  DeviceMap m;
  m.W = eq.width;
  m.H = eq.height;
  std::vector<cl_float8> rows, cols;
  shTables(m.W, m.H, double(env.rotationColumns()), rows, cols);
  m.eq = ctx.upload(eq.pixels, "environment map (ambient)");
  m.rows = ctx.upload(rows, "SH row integrals");
  m.cols = ctx.upload(cols, "SH column integrals");
  return m;
}

// The map's 9 x RGB coefficients, integral of L(w) Y_lm(w) dw, on the device.
SH9 projectMap(Context& ctx, const DeviceMap& m) {
  const int W = m.W, H = m.H;
  cl::Kernel k = ctx.kernel("sh.cl", "sh_project");
  const std::size_t wg = ctx.workGroupSize(k, 256);
  const std::size_t n = std::size_t(W) * H;
  const std::size_t perGroup = wg * kTexelsPerItem;
  const std::size_t groups = std::clamp<std::size_t>((n + perGroup - 1) / perGroup, 1, kMaxGroups);
  cl::Buffer partB = ctx.buffer(groups * 3 * kCoeffs * sizeof(cl_float), "SH partial sums");
  ctx.launchWith("ambient/sh-project", k, cl::NDRange(groups * wg), cl::NDRange(wg), m.eq,
                 cl_int(W), cl_int(H), m.rows, m.cols, cl::Local(wg * sizeof(cl_float)), partB);
  auto part = ctx.download<cl_float>(partB, groups * 3 * kCoeffs, "SH partial sums");
  SH9 sh{};
  for (std::size_t g = 0; g < groups; ++g)  // fixed order: bit-identical results
    for (int i = 0; i < kCoeffs; ++i)
      for (int c = 0; c < 3; ++c) sh[i][c] += double(part[g * 3 * kCoeffs + 3 * i + c]);
  return sh;
}

// The residual's irradiance table on the device (kernels/environment/irradiance.cl): the map's
// running sums of L_t m_t along each row, the runs' half-widths per table row, the sums per band of
// map rows, then per normal the bands in order minus the lights.
AmbientMap irradianceMap(Context& ctx, const DeviceMap& m, float shift,
                         const std::vector<AreaLight>& lights, int TW, int TH) {
  const int W = m.W, H = m.H;
  const std::size_t N = std::size_t(TW) * TH;
  // The rotation's whole and fractional columns as pb_env_world_column splits them.
  const float wholeF = std::floor(shift), frac = shift - wholeF;
  const int whole = ((int(wholeF) % W) + W) % W;
  cl::Buffer normalB = ctx.buffer(N * sizeof(cl_float4), "ambient map normals");
  {
    cl::Kernel k = ctx.kernel("irradiance.cl", "irradiance_normals");
    ctx.launchWith("ambient/map-normals", k, cl::NDRange(N), cl::NullRange, cl_int(TW), cl_int(TH),
                   normalB);
  }
  cl::Buffer hwB = ctx.buffer(std::size_t(H) * TH * sizeof(cl_float), "ambient map run widths");
  {
    cl::Kernel k = ctx.kernel("irradiance.cl", "irradiance_halfwidth");
    ctx.launchWith("ambient/map-widths", k, cl::NDRange(std::size_t(H) * TH), cl::NullRange,
                   cl_int(W), cl_int(H), m.rows, cl_int(TW), cl_int(TH), normalB,
                   cl_float(2.0 * std::sin(kPi / W)), cl_float(2.0 * kPi / W), hwB);
  }
  // Bands of kBandRows map rows, fewer (taller bands) when the table is so large that the partial
  // sums would pass kMaxPartials normals x bands; but never so tall that one band's row prefixes
  // pass kMaxPrefixBytes (that bound wins: a 1024x1024 table on an 8192x4096 map would otherwise
  // put every row's prefixes, 1.2 GB, in one buffer).
  const std::size_t rowBytes = std::size_t(W + 1) * 9 * sizeof(cl_float);
  const std::size_t maxBandRows = std::max<std::size_t>(1, kMaxPrefixBytes / rowBytes);
  const std::size_t minBands = (std::size_t(H) + maxBandRows - 1) / maxBandRows;
  const int bands = int(std::clamp<std::size_t>(
      std::max(std::min<std::size_t>((H + kBandRows - 1) / kBandRows, kMaxPartials / N), minBands),
      1, H));
  const int bandRows = (H + bands - 1) / bands;
  const int usedBands = (H + bandRows - 1) / bandRows;
  cl::Buffer partB = ctx.buffer(std::size_t(usedBands) * N * 3 * sizeof(cl_float),
                                "ambient map band sums");
  // The rows' prefixes in chunks of whole bands within kMaxPrefixBytes (one band at least): a
  // 1024-wide map's rows all fit in one.
  const int chunkBands = int(std::clamp<std::size_t>(
      kMaxPrefixBytes / (rowBytes * std::size_t(bandRows)), 1, std::size_t(usedBands)));
  const int chunkRows = std::min(H, chunkBands * bandRows);
  cl::Buffer prefixB = ctx.buffer(std::size_t(chunkRows) * rowBytes, "ambient map row prefix sums");
  cl::Kernel kp = ctx.kernel("irradiance.cl", "irradiance_prefix");
  cl::Kernel kb = ctx.kernel("irradiance.cl", "irradiance_bands");
  // TW even: each work-item also writes its normal's antipode (irradiance_bands)
  const std::size_t computed = TW % 2 == 0 ? N / 2 : N;
  for (int b0 = 0; b0 < usedBands; b0 += chunkBands) {
    const int r0 = b0 * bandRows, nrows = std::min(H - r0, chunkRows);
    const int nb = std::min(chunkBands, usedBands - b0);
    ctx.launchWith("ambient/map-prefix", kp, cl::NDRange(std::size_t(nrows)), cl::NullRange, m.eq,
                   cl_int(W), cl_int(whole), m.rows, m.cols, cl_int(r0), cl_int(nrows), prefixB);
    ctx.launchWith("ambient/map-bands", kb, cl::NDRange(std::size_t(nb) * computed), cl::NullRange,
                   prefixB, cl_int(W), cl_int(H), cl_float(frac), hwB, normalB, cl_int(TW),
                   cl_int(TH), cl_int(bandRows), cl_int(b0), cl_int(nb), partB);
  }
  // Lights: (direction, cos alpha), (radiance, 0); polygons as shade.cl reads them.
  const int nl = int(lights.size());
  std::vector<cl_float4> lightV(std::max<std::size_t>(1, 2 * std::size_t(nl)),
                                cl_float4{{0, 0, 0, 0}});
  for (int l = 0; l < nl; ++l) {
    const AreaLight& a = lights[l];
    lightV[2 * l] = cl_float4{{a.direction[0], a.direction[1], a.direction[2], a.cosAlpha}};
    lightV[2 * l + 1] = cl_float4{{a.radiance[0], a.radiance[1], a.radiance[2], 0.0f}};
  }
  const std::vector<cl_float4> polyV = detail::polygonVertexBlocks(lights);
  cl::Buffer lightB = ctx.upload(lightV, "ambient map lights");
  cl::Buffer polyB = ctx.upload(polyV, "ambient map polygon vertices");
  AmbientMap out;
  out.width = TW;
  out.height = TH;
  cl::Buffer tableB = ctx.buffer(N * 3 * sizeof(cl_float), "ambient irradiance map");
  cl::Kernel k = ctx.kernel("irradiance.cl", "irradiance_table");
  // pairs of antipodes, as the bands
  ctx.launchWith("ambient/map-table", k, cl::NDRange(computed), cl::NullRange, partB,
                 cl_int(usedBands), normalB, lightB, cl_int(nl), polyB, cl_int(TW), cl_int(TH),
                 tableB);
  out.rgb = ctx.download<cl_float>(tableB, N * 3, "ambient irradiance map");
  return out;
}

// A uniform cap of radiance L, half-angle alpha (c = cos alpha) around unit d, projected onto SH.
// The cap is symmetric about d, so in a frame with d as the pole only the zonal terms survive:
//   f_l = integral of L Y_l0 = 2 pi L N_l int_c^1 P_l(t) dt,  N_l = sqrt((2l+1) / (4 pi)).
// Rotating a zonal function to axis d (addition theorem) gives
//   c_lm = sqrt(4 pi / (2l+1)) f_l Y_lm(d) = g_l Y_lm(d),  g_l = 2 pi L int_c^1 P_l(t) dt:
//   g_0 = 2 pi L (1 - c)               (the cap's power M, as it must: Y_00 is constant)
//   g_1 = 2 pi L (1 - c^2) / 2 = pi L sin^2 alpha
//   g_2 = 2 pi L [(t^3 - t) / 2]_c^1 = pi L c sin^2 alpha   (P_2 = (3t^2 - 1) / 2)
void subtractCap(const AreaLight& l, SH9& sh) {
  const double c = std::clamp(double(l.cosAlpha), -1.0, 1.0);
  double dx = l.direction[0], dy = l.direction[1], dz = l.direction[2];
  const double len = std::sqrt(dx * dx + dy * dy + dz * dz);
  if (!(len > 0) || !std::isfinite(len)) return;  // no direction: a light without extent or power
  float Y[kCoeffs];
  pb_sh9(float(dx / len), float(dy / len), float(dz / len), Y);
  const double s2 = 1.0 - c * c;
  const double g[3] = {2.0 * kPi * (1.0 - c), kPi * s2, kPi * c * s2};
  for (int i = 0; i < kCoeffs; ++i) {
    const int band = i == 0 ? 0 : (i < 4 ? 1 : 2);
    for (int ch = 0; ch < 3; ++ch) sh[i][ch] -= g[band] * double(l.radiance[ch]) * double(Y[i]);
  }
}

// A uniform polygon light (lights.hpp) projected onto SH: L times the integral of Y_lm over the
// spherical polygon, by quadrature over lightSampleDirections (Arvo's area-preserving map of a
// Fibonacci lattice, uniform in solid angle): c_lm = L Omega / K sum_k Y_lm(w_k). The integrand is
// a polynomial of degree <= 2, smooth over the polygon, and the points are stratified, so K = 1024
// leaves ~1e-4 of the polygon's power (measured against 16x more points in
// tests/test_polygon_lights.cpp). The l = 0 term is set from the exact solid angle, so the
// residual's power stays exact: the l = 0 term of the polygon is L Omega Y_00 whatever K.
void subtractPolygon(const AreaLight& l, SH9& sh) {
  constexpr int K = 1024;
  const auto dirs = lightSampleDirections(l, K);
  if (dirs.empty()) return;
  const double omega = l.solidAngle();
  double acc[kCoeffs] = {};
  for (auto& w : dirs) {
    float Y[kCoeffs];
    pb_sh9(w[0], w[1], w[2], Y);
    for (int i = 0; i < kCoeffs; ++i) acc[i] += Y[i];
  }
  acc[0] = double(PB_SH_K00) * K;
  for (int i = 0; i < kCoeffs; ++i)
    for (int ch = 0; ch < 3; ++ch) sh[i][ch] -= double(l.radiance[ch]) * omega * acc[i] / K;
}

}  // namespace

AmbientModel parseAmbientModel(const std::string& name) {
  for (AmbientModel m : {AmbientModel::IrradianceMap, AmbientModel::SH9})
    if (name == toString(m)) return m;
  badInput("AmbientOptions.model: unknown model '" + name + "' (accepted: map, sh9)");
}

const char* toString(AmbientModel m) {
  return m == AmbientModel::SH9 ? "sh9" : "map";
}

void addAmbientResidual(Context& ctx, const Environment& env, LightSet& set,
                        const AmbientOptions& opt) {
  const bool map = opt.model == AmbientModel::IrradianceMap;
  if (map && (opt.mapWidth < 1 || opt.mapWidth > 1024 || opt.mapHeight < 1 ||
              opt.mapHeight > 1024))
    badInput("ambient map size must be 1..1024 x 1..1024 texels, got " +
             std::to_string(opt.mapWidth) + "x" + std::to_string(opt.mapHeight));
  const DeviceMap m = uploadMap(ctx, env);
  SH9 sh = projectMap(ctx, m);
  set.ambientMap = map ? irradianceMap(ctx, m, env.rotationColumns(), set.lights, opt.mapWidth,
                                       opt.mapHeight)
                       : AmbientMap{};
  for (const AreaLight& l : set.lights) {
    if (l.shape == LightShape::Polygon)
      subtractPolygon(l, sh);
    else
      subtractCap(l, sh);
  }
  for (int i = 0; i < kCoeffs; ++i)
    for (int c = 0; c < 3; ++c) set.ambientSH[i][c] = float(sh[i][c]);
  set.hasAmbient = true;
}

std::array<double, 3> LightSet::lightsPower() const {
  std::array<double, 3> p{0, 0, 0};
  for (auto& l : lights)
    for (int c = 0; c < 3; ++c) p[c] += l.power[c];
  return p;
}

// Integral over the sphere of sum_lm c_lm Y_lm: only Y_00 = 1 / sqrt(4 pi) has a non-zero
// integral (4 pi Y_00 = sqrt(4 pi)).
std::array<double, 3> LightSet::ambientPower() const {
  const double k = std::sqrt(4.0 * kPi);
  return {k * ambientSH[0][0], k * ambientSH[0][1], k * ambientSH[0][2]};
}

// R&H 2001 eq. 13 with the Ahat_l of shared.h: the SH radiance convolved with the clamped cosine.
// Not clamped at 0: a residual may be negative in places (a cap brighter than the texels it
// replaced) and only lights + ambient together are an irradiance.
void AmbientMap::check() const {
  if (rgb.size() != std::size_t(std::max(width, 0)) * std::max(height, 0) * 3)
    badInput("LightSet::ambientMap: " + std::to_string(width) + "x" + std::to_string(height) +
             " texels need " + std::to_string(std::size_t(std::max(width, 0)) * std::max(height, 0) * 3) +
             " values, got " + std::to_string(rgb.size()));
}

std::array<double, 3> LightSet::ambientIrradiance(const std::array<float, 3>& n) const {
  std::array<double, 3> e{0, 0, 0};
  if (!hasAmbient) return e;
  if (!ambientMap.empty()) {
    ambientMap.check();
    int idx[4];
    float wt[4];
    pb_ambient_map_taps(n[0], n[1], n[2], ambientMap.width, ambientMap.height, idx, wt);
    for (int k = 0; k < 4; ++k)
      for (int c = 0; c < 3; ++c) e[c] += double(wt[k]) * ambientMap.rgb[3 * std::size_t(idx[k]) + c];
    return e;
  }
  float Y[kCoeffs];
  pb_sh9(n[0], n[1], n[2], Y);
  for (int i = 0; i < kCoeffs; ++i)
    for (int c = 0; c < 3; ++c) e[c] += double(PB_SH_AHAT(i)) * double(Y[i]) * ambientSH[i][c];
  return e;
}

}  // namespace penumbra
