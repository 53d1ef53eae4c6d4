// rotateLightSet: a light set turned about +y with its environment (lights.hpp).
//
// An animation that turns its map (render --frames, --rotate-step) used to extract the lights of
// every frame from the turned map. Median cut splits the cube's texels, which do not turn with
// the map, so a light could jump between frames by far more than the map turned (measured with
// 32 lights, the sets extracted after turns of 1 to 3 degrees, turned back: lights up to 5
// degrees from the first set's on the built-in sky, 29 on studio.exr). Turning the first
// frame's set instead moves every light with the map, and costs a few microseconds where
// extraction costs the frame's environment stages.
#include "penumbra/lights.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/shared.h"
#include "core/number_text.hpp"
#include "core/vec3.hpp"
#include "lights/sampling.hpp"
#include "penumbra/error.hpp"

namespace penumbra {

namespace {

using detail::D3;

// R(a) about +y, counter-clockwise seen from above (+x towards -z): Environment::rotationYDeg's
// sense, so a direction of the map's at w appears at R(a) w.
struct TurnY {
  double c, s;
  D3 apply(const D3& w) const { return {c * w[0] + s * w[2], w[1], -s * w[0] + c * w[2]}; }
  // The float vector turned in double, then rounded; a unit vector is renormalized first in
  // double, so it stays unit to float's rounding.
  std::array<float, 3> turn(const std::array<float, 3>& v, bool unit) const {
    D3 r = apply(detail::vec3Cast<double>(v));
    if (unit) r = detail::normalize(r);
    return detail::vec3Cast<float>(r);
  }
};

// Solves the n x n system A x = b in place (Gaussian elimination, partial pivoting; A is well
// conditioned here: see rotateSH9).
void solve(std::vector<double>& A, std::vector<double>& b, int n) {
  for (int k = 0; k < n; ++k) {
    int p = k;
    for (int i = k + 1; i < n; ++i)
      if (std::fabs(A[i * n + k]) > std::fabs(A[p * n + k])) p = i;
    for (int j = 0; j < n; ++j) std::swap(A[k * n + j], A[p * n + j]);
    std::swap(b[k], b[p]);
    for (int i = k + 1; i < n; ++i) {
      const double f = A[i * n + k] / A[k * n + k];
      for (int j = k; j < n; ++j) A[i * n + j] -= f * A[k * n + j];
      b[i] -= f * b[k];
    }
  }
  for (int k = n - 1; k >= 0; --k) {
    double v = b[k];
    for (int j = k + 1; j < n; ++j) v -= A[k * n + j] * b[j];
    b[k] = v / A[k * n + k];
  }
}

// The nine SH coefficients of f'(n) = f(R(-a) n). A rotation keeps each band (l = 0, 1, 2), so f'
// is again of order <= 2 and the least-squares fit of f'(d_k) = f(R(-a) d_k) over directions d_k
// that determine the nine basis functions is exact, up to rounding. The 64 directions are
// spread uniformly over the sphere (the light samples' spherical Fibonacci set, lights/sampling):
// their 9 x 9 normal matrix is close to diagonal (a quadrature of the basis's orthogonality), so
// the solve loses nothing in double.
void rotateSH9(std::array<std::array<float, 3>, 9>& sh, const TurnY& turn) {
  constexpr int kN = 9, kDirs = 64;
  const TurnY back{turn.c, -turn.s};
  std::vector<double> AtA(kN * kN, 0.0);
  std::array<std::vector<double>, 3> Atb;
  for (auto& v : Atb) v.assign(kN, 0.0);
  // the whole sphere as a cap of half-angle pi (lights/sampling.hpp)
  for (const auto& df : detail::sphericalFibonacciCap({0, 1, 0}, -1.0f, kDirs, 0.0f)) {
    const D3 d = detail::vec3Cast<double>(df);
    const D3 src = back.apply(d);
    float Y[kN], Ys[kN];
    pb_sh9(float(d[0]), float(d[1]), float(d[2]), Y);
    pb_sh9(float(src[0]), float(src[1]), float(src[2]), Ys);
    for (int c = 0; c < 3; ++c) {
      double f = 0;  // f(R(-a) d)
      for (int i = 0; i < kN; ++i) f += double(Ys[i]) * sh[i][c];
      for (int i = 0; i < kN; ++i) Atb[c][i] += double(Y[i]) * f;
    }
    for (int i = 0; i < kN; ++i)
      for (int j = 0; j < kN; ++j) AtA[i * kN + j] += double(Y[i]) * double(Y[j]);
  }
  for (int c = 0; c < 3; ++c) {
    std::vector<double> A = AtA;
    solve(A, Atb[c], kN);
    for (int i = 0; i < kN; ++i) sh[i][c] = float(Atb[c][i]);
  }
}

// The irradiance map of the turned residual: E'(n) = E(R(-a) n). R(-a) keeps the colatitude and
// adds a to the longitude, so each row is shifted by a / 360 of its width, read linearly between
// the two columns the shift falls between (wrapping), as the bilinear lookup would read them
// (pb_ambient_map_taps). A whole-column shift copies the columns exactly.
void rotateAmbientMap(AmbientMap& m, double turns) {
  const int W = m.width;
  const double shift = turns * W;  // in [0, W]: W only by rounding, which the % W below wraps
  const double whole = std::floor(shift);
  const float frac = float(shift - whole);
  const int w0 = int(whole);
  std::vector<float> out(m.rgb.size());
  for (int j = 0; j < m.height; ++j)
    for (int i = 0; i < W; ++i) {
      const int i0 = (i + w0) % W, i1 = (i0 + 1) % W;
      const float* a = &m.rgb[3 * (std::size_t(j) * W + i0)];
      const float* b = &m.rgb[3 * (std::size_t(j) * W + i1)];
      float* o = &out[3 * (std::size_t(j) * W + i)];
      for (int c = 0; c < 3; ++c) o[c] = frac == 0.0f ? a[c] : (1.0f - frac) * a[c] + frac * b[c];
    }
  m.rgb = std::move(out);
}

}  // namespace

LightSet rotateLightSet(const LightSet& set, float degrees) {
  if (!std::isfinite(degrees))
    badInput("rotateLightSet: the angle must be finite, got " + detail::numberText(degrees));
  set.ambientMap.check();
  // Reduced in double as Environment::rotationColumns reduces it: whole turns give exactly 0.
  double turns = std::fmod(double(degrees), 360.0) / 360.0;
  if (turns < 0) turns += 1.0;
  if (turns >= 1.0) turns = 0.0;
  LightSet out = set;
  if (turns == 0.0) return out;
  const double a = turns * 2.0 * 3.14159265358979323846;
  const TurnY turn{std::cos(a), std::sin(a)};
  for (AreaLight& l : out.lights) {
    l.direction = turn.turn(l.direction, true);
    // The frame (rects, ellipses, textured caps) turns with the light, its length kept; no
    // frame (a zero axisU) stays none.
    if (l.axisU != std::array<float, 3>{0, 0, 0}) l.axisU = turn.turn(l.axisU, false);
    for (auto& v : l.vertices) v = turn.turn(v, true);
    // The cube regions were the unturned map's; they no longer mark where the light is.
    l.regions.clear();
  }
  if (out.hasAmbient) {
    rotateSH9(out.ambientSH, turn);
    if (!out.ambientMap.empty()) rotateAmbientMap(out.ambientMap, turns);
  }
  return out;
}

}  // namespace penumbra
