// FLIP on the host: LDR-FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating
// Images": colour pipeline, feature pipeline, final error) and HDR-FLIP (Andersson et al.
// 2021, "Visualizing Errors in Rendered High Dynamic Range Images": LDR-FLIP over a range
// of tone-mapped exposures, per-pixel maximum). Every 2D filter of the papers is separable (a
// Gaussian, a sum of two Gaussians, or a Gaussian derivative times a Gaussian), so all filtering is
// done as row and column passes over float planes with clamp-to-edge borders, band of rows by band
// of rows, the bands shared among std::threads.
#include "penumbra/flip.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "core/number_text.hpp"
#include "penumbra/error.hpp"

namespace penumbra {
namespace {

constexpr double kMaxExposureStops = 128;


constexpr double kPi = 3.14159265358979323846;

// Andersson et al. 2020, their chosen parameters: colour exponent q_c, feature exponent q_f, the
// colour-error breakpoints p_c (of c_max) and p_t (of the [0,1] output range), and the feature
// detectors' width w in degrees of visual angle.
constexpr float kQc = 0.7f;
constexpr float kQf = 0.5f;
constexpr float kPc = 0.4f;
constexpr float kPt = 0.95f;
constexpr double kFeatureWidth = 0.082;

// Contrast sensitivity functions as sums of Gaussians, Andersson et al. 2020, colour pipeline
// (after Mullen's and Johnson and Fairchild's CSFs): S(x) = a1 sqrt(pi/b1) exp(-pi^2 x^2 / b1) + a2
// sqrt(pi/b2) exp(-pi^2 x^2 / b2), x in degrees, for the achromatic (Y), red-green (Cx) and
// blue-yellow (Cz) channels. Y and Cx have a2 = 0: one Gaussian each.
constexpr double kA1[3] = {1.0, 1.0, 34.1};
constexpr double kB1[3] = {0.0047, 0.0053, 0.04};
constexpr double kA2[3] = {0.0, 0.0, 13.5};
constexpr double kB2[3] = {0.0, 0.0, 0.025};

// Linear sRGB (D65) <-> CIE XYZ, the sRGB standard's matrices (IEC 61966-2-1).
constexpr float kRgbToXyz[3][3] = {{0.4123908f, 0.3575843f, 0.1804808f},
                                   {0.2126390f, 0.7151687f, 0.0721923f},
                                   {0.0193308f, 0.1191948f, 0.9505322f}};
constexpr float kXyzToRgb[3][3] = {{3.2409699f, -1.5373832f, -0.4986108f},
                                   {-0.9692436f, 1.8759675f, 0.0415551f},
                                   {0.0556301f, -0.2039770f, 1.0569715f}};
// The reference white is linear RGB (1,1,1) itself (the rows' sums), so white maps to Y = 100
// with zero opponent and chroma values.
constexpr float kWhite[3] = {kRgbToXyz[0][0] + kRgbToXyz[0][1] + kRgbToXyz[0][2],
                             kRgbToXyz[1][0] + kRgbToXyz[1][1] + kRgbToXyz[1][2],
                             kRgbToXyz[2][0] + kRgbToXyz[2][1] + kRgbToXyz[2][2]};

// HDR-FLIP's tone mapper (Andersson et al. 2021, HDR-FLIP): Narkowicz's ACES fit applied after a
// 0.6 pre-scale, t(x) = (k0 x^2 + k1 x + k2) / (k3 x^2 + k4 x + k5) per channel, clamped to [0,1].
constexpr double kTone[6] = {0.6 * 0.6 * 2.51, 0.6 * 0.03, 0.0, 0.6 * 0.6 * 2.43, 0.6 * 0.59, 0.14};
// Andersson et al. 2021, HDR-FLIP: the exposure range puts the reference's maximum luminance
// (start) and median luminance (stop) at this tone-mapped value.
constexpr double kToneTarget = 0.85;

const double kLumaWeights[3] = {0.2126, 0.7152, 0.0722};  // Rec. 709 luminance of linear sRGB

using Plane = std::vector<float>;

std::string sizeOf(const Image& im) {
  // std::to_string, not a stream: a global locale's digit grouping would give "1.920x1.080"
  return std::to_string(im.width) + "x" + std::to_string(im.height);
}

// --- filters ------------------------------------------------------------------------------------

struct Kernels {
  // Spatial CSF filters (1D factors): Y, Cx, and the two Gaussians of Cz.
  std::vector<float> y, cx, cz1, cz2;
  // Feature detectors: Gaussian, its first and its second derivative (1D factors).
  std::vector<float> g, dg, ddg;
};

Kernels makeKernels(double ppd) {
  Kernels k;
  // Andersson et al. 2020, colour pipeline: each Gaussian exp(-pi^2 x^2 / b) has standard deviation
  // sqrt(b / (2 pi^2)) degrees; the filters reach 3 standard deviations of the widest one.
  double bMax = 0;
  for (int c = 0; c < 3; ++c) bMax = std::max({bMax, kB1[c], kB2[c]});
  const int rs = int(std::ceil(3.0 * std::sqrt(bMax / (2.0 * kPi * kPi)) * ppd));
  auto gaussian = [&](double b, int i) {
    const double x = i / ppd;  // degrees
    return std::exp(-kPi * kPi * x * x / b);
  };
  // A separable 2D term a sqrt(pi/b) G(x) G(y) factors into sqrt(a sqrt(pi/b)) G per axis. For Y
  // and Cx the amplitude cancels in the normalization below; for Cz it sets the two terms' mix.
  const double amp1 = std::sqrt(kA1[2] * std::sqrt(kPi / kB1[2]));
  const double amp2 = std::sqrt(kA2[2] * std::sqrt(kPi / kB2[2]));
  const int ns = 2 * rs + 1;
  std::vector<double> y(ns), cx(ns), cz1(ns), cz2(ns);
  double sy = 0, scx = 0, s1 = 0, s2 = 0;
  for (int i = -rs; i <= rs; ++i) {
    y[i + rs] = gaussian(kB1[0], i);
    cx[i + rs] = gaussian(kB1[1], i);
    cz1[i + rs] = amp1 * gaussian(kB1[2], i);
    cz2[i + rs] = amp2 * gaussian(kB2[2], i);
    sy += y[i + rs];
    scx += cx[i + rs];
    s1 += cz1[i + rs];
    s2 += cz2[i + rs];
  }
  // The 2D filters are normalized to sum to 1 (Andersson et al. 2020, colour pipeline). For Y and
  // Cx that is each 1D factor summing to 1; Cz's 2D sum is s1^2 + s2^2, so both factors are divided
  // by its square root.
  const double sz = std::sqrt(s1 * s1 + s2 * s2);
  for (int i = 0; i < ns; ++i) {
    k.y.push_back(float(y[i] / sy));
    k.cx.push_back(float(cx[i] / scx));
    k.cz1.push_back(float(cz1[i] / sz));
    k.cz2.push_back(float(cz2[i] / sz));
  }

  // Feature detectors, Andersson et al. 2020, feature pipeline: Gaussian derivatives with standard
  // deviation sigma = w/2 degrees (w = 0.082), out to 3 sigma; the positive and the negative
  // weights of each derivative filter sum to +1 and -1 (the Gaussian sums to 1). In 2D the edge
  // filter is dG(x) G(y) and the point filter ddG(x) G(y) (and transposed); the 2D weights' sums
  // are the 1D ones times G's sum of 1, so normalizing the 1D factors normalizes the 2D filters.
  const double sd = 0.5 * kFeatureWidth * ppd;  // pixels
  const int rf = int(std::ceil(3.0 * sd));
  const int nf = 2 * rf + 1;
  std::vector<double> g(nf), dg(nf), ddg(nf);
  double sg = 0, dPos = 0, dNeg = 0, ddPos = 0, ddNeg = 0;
  for (int i = -rf; i <= rf; ++i) {
    const double gi = std::exp(-double(i) * i / (2.0 * sd * sd));
    g[i + rf] = gi;
    dg[i + rf] = -i * gi;
    ddg[i + rf] = (double(i) * i / (sd * sd) - 1.0) * gi;
    sg += gi;
    (dg[i + rf] > 0 ? dPos : dNeg) += std::fabs(dg[i + rf]);
    (ddg[i + rf] > 0 ? ddPos : ddNeg) += std::fabs(ddg[i + rf]);
  }
  // At very low pixels-per-degree the outer taps underflow to 0: a sum of 0 leaves those weights
  // at 0 rather than dividing by it.
  auto norm = [](double v, double pos, double neg) {
    const double s = v > 0 ? pos : neg;
    return s > 0 ? float(v / s) : 0.0f;
  };
  for (int i = 0; i < nf; ++i) {
    k.g.push_back(float(g[i] / sg));
    k.dg.push_back(norm(dg[i], dPos, dNeg));
    k.ddg.push_back(norm(ddg[i], ddPos, ddNeg));
  }
  return k;
}

// Row pass over `rows` rows of width w: out(x,y) = sum_i taps[i] in(clamp(x + i - r), y).
// `pad` is scratch.
void convolveRows(const Plane& in, Plane& out, int w, int rows, const std::vector<float>& taps,
                  std::vector<float>& pad) {
  const int r = int(taps.size()) / 2;
  pad.resize(std::size_t(w) + 2 * r);
  out.resize(std::size_t(w) * rows);
  for (int y = 0; y < rows; ++y) {
    const float* row = &in[std::size_t(y) * w];
    for (int i = 0; i < r; ++i) {
      pad[i] = row[0];
      pad[std::size_t(w) + r + i] = row[w - 1];
    }
    std::copy(row, row + w, pad.begin() + r);
    float* o = &out[std::size_t(y) * w];
    std::fill(o, o + w, 0.0f);
    for (std::size_t i = 0; i < taps.size(); ++i) {
      const float t = taps[i];
      const float* p = pad.data() + i;
      for (int x = 0; x < w; ++x) o[x] += t * p[x];
    }
  }
}

// Rows [y0, y1) of an h-row image in bands: the filters' reach of rows around them, [ya, yb),
// clamped to the image, is what a band's column passes read.
struct Band {
  int y0, y1, ya, yb;
};

// Column pass for a band: out holds image rows [y0, y1), in holds rows [ya, yb);
// out(x,y) = sum_i taps[i] in(x, clamp(y + i - r, 0, h - 1)).
void convolveColumns(const Plane& in, Plane& out, int w, int h, const Band& b,
                     const std::vector<float>& taps) {
  const int r = int(taps.size()) / 2;
  out.resize(std::size_t(w) * (b.y1 - b.y0));
  for (int y = b.y0; y < b.y1; ++y) {
    float* o = &out[std::size_t(y - b.y0) * w];
    std::fill(o, o + w, 0.0f);
    for (int i = -r; i <= r; ++i) {
      const float t = taps[std::size_t(i + r)];
      const float* p = &in[std::size_t(std::clamp(y + i, 0, h - 1) - b.ya) * w];
      for (int x = 0; x < w; ++x) o[x] += t * p[x];
    }
  }
}

// --- colour -------------------------------------------------------------------------------------

void mul3(const float m[3][3], const float v[3], float out[3]) {
  for (int r = 0; r < 3; ++r) out[r] = m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2];
}

// Cube root of t > 0 by Newton's method from an exponent-thirding first guess; libm's cbrtf took
// about a sixth of HDR-FLIP's time. The guess is within a few per cent and the error squares with
// each step, so three steps reach float precision (largest relative error 1.6e-7 over the range
// CIELAB uses, (6/29)^3 .. 2, checked against double cbrt).
float cubeRoot(float t) {
  std::uint32_t bits;
  std::memcpy(&bits, &t, sizeof bits);
  bits = bits / 3 + 0x2a5137a0u;  // a third of the biased exponent, re-biased
  float y;
  std::memcpy(&y, &bits, sizeof y);
  for (int i = 0; i < 3; ++i) y = (2.0f * y + t / (y * y)) * (1.0f / 3.0f);
  return y;
}

// CIELAB's cube-root response with its linear toe (delta = 6/29).
float labF(float t) {
  constexpr float d = 6.0f / 29.0f;
  return t > d * d * d ? cubeRoot(t) : t / (3.0f * d * d) + 4.0f / 29.0f;
}

// Linear RGB -> CIELAB -> Hunt-adjusted (Andersson et al. 2020, colour pipeline: a and b scaled by
// 0.01 L, so that dark colours' chroma counts less).
void huntLab(const float rgb[3], float lab[3]) {
  float xyz[3];
  mul3(kRgbToXyz, rgb, xyz);
  const float fx = labF(xyz[0] / kWhite[0]), fy = labF(xyz[1] / kWhite[1]),
              fz = labF(xyz[2] / kWhite[2]);
  const float L = 116.0f * fy - 16.0f;
  lab[0] = L;
  lab[1] = 0.01f * L * 500.0f * (fx - fy);
  lab[2] = 0.01f * L * 200.0f * (fy - fz);
}

// HyAB distance (Abasi et al. 2020, used by Andersson et al. 2020, colour pipeline): city-block in
// L, Euclidean in (a, b).
float hyab(const float p[3], const float q[3]) {
  return std::fabs(p[0] - q[0]) +
         std::sqrt((p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]));
}

// c_max of Andersson et al. 2020, colour pipeline: the largest colour difference in the gamut,
// between pure green and pure blue, raised to q_c.
float maxColorDistance() {
  const float green[3] = {0, 1, 0}, blue[3] = {0, 0, 1};
  float g[3], b[3];
  huntLab(green, g);
  huntLab(blue, b);
  return std::pow(hyab(g, b), kQc);
}

// Andersson et al. 2021's tone mapper with the exposure factor 2^exposure, clamped to [0,1]. The
// curve rises through 1 near x = 12.1 (where (k0 - k3) x^2 + (k1 - k4) x - k5 = 0) and stays above
// it, so anything past 16 is 1 without evaluating it (which also keeps x^2 finite in float).
float toneMap(float v, float scale) {
  const float x = v * scale;
  if (!(x < 16.0f)) return 1.0f;
  const float t = (float(kTone[0]) * x * x + float(kTone[1]) * x + float(kTone[2])) /
                  (float(kTone[3]) * x * x + float(kTone[4]) * x + float(kTone[5]));
  return std::clamp(t, 0.0f, 1.0f);
}

// What the feature and colour pipelines keep of one image at one exposure.
struct Percept {
  Plane L, A, B;      // spatially filtered, Hunt-adjusted CIELAB
  Plane edge, point;  // feature magnitudes of the normalized achromatic channel
};

struct Scratch {
  Plane opp[3], t0, t1, t2, t3, t4;
  std::vector<float> pad;
};

// Both pipelines' per-image part for one band of non-negative linear RGB planes, tone-mapped at
// the exposure factor `scale` (HDR) or, for a negative scale, clamped to [0,1] (LDR) on the way in.
// `out` holds the band's rows.
void perceive(const Plane* rgb, double scale, int w, int h, const Band& band, const Kernels& k,
              Scratch& s, Percept& out) {
  const int rowsIn = band.yb - band.ya;
  const std::size_t nIn = std::size_t(w) * rowsIn, n = std::size_t(w) * (band.y1 - band.y0);
  const std::size_t first = std::size_t(band.ya) * w;
  // Linear RGB -> YyCxCz opponent space (Andersson et al. 2020, colour pipeline; Zhang and
  // Wandell's linearized CIELAB): Y = 116 y - 16, Cx = 500 (x - y), Cz = 200 (y - z) for
  // white-normalized XYZ. In float, an exposure past 2^128 saturates rather than turning 0 * inf
  // into NaN.
  const float fscale = float(std::min(scale, double(std::numeric_limits<float>::max())));
  for (int c = 0; c < 3; ++c) s.opp[c].resize(nIn);
  for (std::size_t i = 0; i < nIn; ++i) {
    float v[3];
    for (int c = 0; c < 3; ++c) {
      const float in = rgb[c][first + i];
      v[c] = scale >= 0 ? toneMap(in, fscale) : std::min(in, 1.0f);
    }
    float xyz[3];
    mul3(kRgbToXyz, v, xyz);
    const float x = xyz[0] / kWhite[0], y = xyz[1] / kWhite[1], z = xyz[2] / kWhite[2];
    s.opp[0][i] = 116.0f * y - 16.0f;
    s.opp[1][i] = 500.0f * (x - y);
    s.opp[2][i] = 200.0f * (y - z);
  }

  // Colour pipeline: CSF filtering per opponent channel (Cz: the sum of two separable passes).
  out.L.resize(n);
  out.A.resize(n);
  out.B.resize(n);
  convolveRows(s.opp[0], s.t0, w, rowsIn, k.y, s.pad);
  convolveColumns(s.t0, s.t1, w, h, band, k.y);  // t1: filtered Y
  convolveRows(s.opp[1], s.t0, w, rowsIn, k.cx, s.pad);
  convolveColumns(s.t0, s.t2, w, h, band, k.cx);  // t2: filtered Cx
  convolveRows(s.opp[2], s.t0, w, rowsIn, k.cz1, s.pad);
  convolveColumns(s.t0, s.t3, w, h, band, k.cz1);
  convolveRows(s.opp[2], s.t0, w, rowsIn, k.cz2, s.pad);
  convolveColumns(s.t0, s.t4, w, h, band, k.cz2);  // t3 + t4: filtered Cz
  for (std::size_t i = 0; i < n; ++i) {
    // Back to linear RGB, clamped to [0,1] (the filtered colour may leave the gamut), then the
    // Hunt-adjusted CIELAB the colour difference is measured in.
    const float y = (s.t1[i] + 16.0f) / 116.0f;
    const float xyz[3] = {(y + s.t2[i] / 500.0f) * kWhite[0], y * kWhite[1],
                          (y - (s.t3[i] + s.t4[i]) / 200.0f) * kWhite[2]};
    float v[3];
    mul3(kXyzToRgb, xyz, v);
    for (float& c : v) c = std::clamp(c, 0.0f, 1.0f);
    float lab[3];
    huntLab(v, lab);
    out.L[i] = lab[0];
    out.A[i] = lab[1];
    out.B[i] = lab[2];
  }

  // Feature pipeline (Andersson et al. 2020, feature pipeline) on the unfiltered achromatic channel
  // normalized to [0,1], (Y + 16) / 116 (the paper's erratum: 116, not 100).
  for (std::size_t i = 0; i < nIn; ++i) s.opp[1][i] = (s.opp[0][i] + 16.0f) / 116.0f;
  convolveRows(s.opp[1], s.t0, w, rowsIn, k.g, s.pad);    // G along x
  convolveRows(s.opp[1], s.t1, w, rowsIn, k.dg, s.pad);   // dG along x
  convolveRows(s.opp[1], s.t2, w, rowsIn, k.ddg, s.pad);  // ddG along x
  convolveColumns(s.t1, s.t3, w, h, band, k.g);           // edge, x component
  convolveColumns(s.t0, s.t4, w, h, band, k.dg);          // edge, y component
  out.edge.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    out.edge[i] = std::sqrt(s.t3[i] * s.t3[i] + s.t4[i] * s.t4[i]);
  convolveColumns(s.t2, s.t3, w, h, band, k.g);    // point, x component
  convolveColumns(s.t0, s.t4, w, h, band, k.ddg);  // point, y component
  out.point.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    out.point[i] = std::sqrt(s.t3[i] * s.t3[i] + s.t4[i] * s.t4[i]);
}

// LDR-FLIP of one band of two linear RGB images (as planes, brought to [0,1] as perceive() says),
// kept in the full-size `err` where larger than what it holds (HDR-FLIP's maximum over exposures).
void ldrFlip(const Plane* test, const Plane* ref, double scale, int w, int h, const Band& band,
             const Kernels& k, float cmax, Scratch& s, Percept& pt, Percept& pr, Plane& err) {
  perceive(test, scale, w, h, band, k, s, pt);
  perceive(ref, scale, w, h, band, k, s, pr);
  const std::size_t n = std::size_t(w) * (band.y1 - band.y0);
  float* bandErr = &err[std::size_t(band.y0) * w];
  const float pccmax = kPc * cmax;
  const float invSqrt2 = float(1.0 / std::sqrt(2.0));
  for (std::size_t i = 0; i < n; ++i) {
    // Colour error (Andersson et al. 2020, colour pipeline): HyAB^q_c, then the piecewise-linear
    // map that sends [0, p_c c_max) to [0, p_t) and [p_c c_max, c_max] to [p_t, 1], so small
    // differences get most of the output range.
    const float a[3] = {pt.L[i], pt.A[i], pt.B[i]}, b[3] = {pr.L[i], pr.A[i], pr.B[i]};
    const float d = std::pow(hyab(a, b), kQc);
    const float ec =
        d < pccmax ? (kPt / pccmax) * d : kPt + (d - pccmax) / (cmax - pccmax) * (1.0f - kPt);
    // Feature error (Andersson et al. 2020, feature pipeline): the larger of the edge and point
    // magnitude differences, scaled by 1/sqrt(2) to [0,1], raised to q_f.
    const float df =
        std::max(std::fabs(pr.edge[i] - pt.edge[i]), std::fabs(pr.point[i] - pt.point[i]));
    const float ef = std::pow(invSqrt2 * df, kQf);
    // Final error (Andersson et al. 2020, final error): feature differences raise the colour error
    // towards 1, Delta E = Delta E_c ^ (1 - Delta E_f).
    bandErr[i] = std::max(bandErr[i], std::pow(ec, 1.0f - ef));
  }
}

// Andersson et al. 2021, HDR-FLIP: the input x at which the tone mapper outputs kToneTarget, the
// larger root of (k0 - t k3) x^2 + (k1 - t k4) x + (k2 - t k5) = 0.
double toneMapInverseAtTarget() {
  const double t = kToneTarget;
  const double a = kTone[0] - t * kTone[3], b = kTone[1] - t * kTone[4],
               c = kTone[2] - t * kTone[5];
  return (-b + std::sqrt(b * b - 4.0 * a * c)) / (2.0 * a);
}

void checkImage(const Image& im, const char* name) {
  if (im.width <= 0 || im.height <= 0 || im.empty())
    badInput(std::string("flip: ") + name + " is empty (" + sizeOf(im) + ")");
  if (im.channels < 3)
    badInput(std::string("flip: ") + name + " has " + std::to_string(im.channels) +
             " channel(s); it needs at least 3 (linear RGB)");
  if (im.pixels.size() != std::size_t(im.width) * im.height * im.channels)
    badInput(std::string("flip: ") + name + " holds " + std::to_string(im.pixels.size()) +
             " values, not width*height*channels");
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      for (int c = 0; c < 3; ++c)
        if (!std::isfinite(im.at(x, y, c)))
          badInput(std::string("flip: ") + name + " has a non-finite value at pixel (" +
                   std::to_string(x) + ", " + std::to_string(y) + "), channel " +
                   std::to_string(c));
}

}  // namespace

FlipResult flip(const Image& test, const Image& reference, const FlipOptions& opt,
                const Image* mask) {
  checkImage(test, "test");
  checkImage(reference, "reference");
  if (test.width != reference.width || test.height != reference.height)
    badInput("flip: test is " + sizeOf(test) + " but reference is " + sizeOf(reference));
  // The filters' radii grow with pixelsPerDegree (3 standard deviations at ppd): 1000 (a 4K
  // screen 10 m away) is already 15x the papers' setup.
  if (!std::isfinite(opt.pixelsPerDegree) || opt.pixelsPerDegree <= 0 || opt.pixelsPerDegree > 1000)
    badInput("flip: pixelsPerDegree must be in (0, 1000] (got " +
             detail::numberText(opt.pixelsPerDegree) + ")");
  if (mask) {
    if (mask->width != reference.width || mask->height != reference.height || mask->channels < 1 ||
        mask->pixels.size() != std::size_t(mask->width) * mask->height * mask->channels)
      badInput("flip: mask is " + sizeOf(*mask) + " with " + std::to_string(mask->channels) +
               " channel(s); it must match the reference's " + sizeOf(reference) +
               " with >= 1 channel");
  }
  if (opt.hdr) {
    for (const auto& [v, name] : {std::pair{opt.startExposure, "startExposure"},
                                  std::pair{opt.stopExposure, "stopExposure"}})
      if (std::isinf(v))
        badInput(std::string("flip: ") + name + " must be finite or NaN (got infinity)");
  }

  const int w = reference.width, h = reference.height;
  const std::size_t n = std::size_t(w) * h;
  // Linear RGB planes; negative values (no light) count as 0.
  Plane tIn[3], rIn[3];
  for (int c = 0; c < 3; ++c) {
    tIn[c].resize(n);
    rIn[c].resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      tIn[c][i] = std::max(0.0f, test.pixels[i * test.channels + c]);
      rIn[c][i] = std::max(0.0f, reference.pixels[i * reference.channels + c]);
    }
  }

  const Kernels k = makeKernels(opt.pixelsPerDegree);
  const float cmax = maxColorDistance();
  FlipResult res;
  res.map = Image(w, h, 1, 0.0f);
  Plane& out = res.map.pixels;

  // Exposure factors: one negative entry for LDR-FLIP (clamped input), 2^exposure for HDR-FLIP.
  std::vector<double> scales{-1.0};
  if (opt.hdr) {
    double start = opt.startExposure, stop = opt.stopExposure;
    if (std::isnan(start) || std::isnan(stop)) {
      // Andersson et al. 2021, HDR-FLIP: start = log2(x / Y_max), stop = log2(x / Y_median), with x
      // the tone mapper's input that maps to 0.85 and Y the reference's luminance.
      std::vector<double> lum(n);
      double yMax = 0, yMinPositive = 0;
      for (std::size_t i = 0; i < n; ++i) {
        lum[i] =
            kLumaWeights[0] * rIn[0][i] + kLumaWeights[1] * rIn[1][i] + kLumaWeights[2] * rIn[2][i];
        yMax = std::max(yMax, lum[i]);
        if (lum[i] > 0 && (yMinPositive == 0 || lum[i] < yMinPositive)) yMinPositive = lum[i];
      }
      std::nth_element(lum.begin(), lum.begin() + n / 2, lum.end());
      double yMedian = lum[n / 2];
      // A reference that is mostly black has no usable median: the dimmest lit pixel stands in.
      if (yMedian <= 0) yMedian = yMinPositive;
      const double x = toneMapInverseAtTarget();
      const bool black = yMax <= 0;  // nothing to expose for: one range at exposure 0
      if (std::isnan(start)) start = black ? 0.0 : std::log2(x / yMax);
      if (std::isnan(stop)) stop = black ? 0.0 : std::log2(x / yMedian);
    }
    if (start > stop)
      badInput("flip: startExposure (" + detail::numberText(start) + ") exceeds stopExposure (" +
               detail::numberText(stop) + ")");
    // One exposure per stop costs one LDR-FLIP each: a range wider than kMaxExposureStops (a
    // reference whose median is 2^-128 of its maximum, or a caller's typo) would run for hours.
    if (stop - start > kMaxExposureStops)
      badInput("flip: the exposure range startExposure..stopExposure (" + detail::numberText(start) +
               ".." + detail::numberText(stop) + ") spans more than " +
               std::to_string(int(kMaxExposureStops)) + " stops");
    // Andersson et al. 2021, HDR-FLIP: max(2, ceil(stop - start)) exposures, evenly spaced.
    const int count = int(std::max(2.0, std::ceil(stop - start)));
    const double step = (stop - start) / (count - 1);
    res.startExposure = start;
    res.stopExposure = stop;
    res.exposures = count;

    scales.clear();
    for (int e = 0; e < count; ++e) scales.push_back(std::exp2(start + e * step));
  }

  // One LDR-FLIP per exposure, the per-pixel maximum over all (Andersson et al. 2021, HDR-FLIP).
  // The image is processed in bands of rows, each with the rows its filters reach, so that the
  // working planes stay small (cache-resident, no fresh pages per call); threads take whole bands,
  // so each output row has one writer.
  const int reach = int(std::max(k.y.size(), k.g.size()) / 2);
  const int bandRows = std::max(64, 4 * reach);
  std::vector<Band> bands;
  for (int y0 = 0; y0 < h; y0 += bandRows) {
    const int y1 = std::min(h, y0 + bandRows);
    bands.push_back({y0, y1, std::max(0, y0 - reach), std::min(h, y1 + reach)});
  }
  const unsigned threads =
      std::max(1u, std::min(std::thread::hardware_concurrency(), unsigned(bands.size())));
  std::vector<std::exception_ptr> failures(threads);
  auto work = [&](unsigned t) {
    try {
      Scratch s;
      Percept pt, pr;
      for (std::size_t b = t; b < bands.size(); b += threads)
        for (double scale : scales)
          ldrFlip(tIn, rIn, scale, w, h, bands[b], k, cmax, s, pt, pr, out);
    } catch (...) {
      failures[t] = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) {
    try {
      pool.emplace_back(work, t);
    } catch (...) {
      break;  // no more threads: this one does the remaining shares below
    }
  }
  work(0);
  for (unsigned t = 1; t < threads; ++t)
    if (t - 1 >= pool.size()) work(t);
  for (auto& th : pool) th.join();
  for (auto& f : failures)
    if (f) std::rethrow_exception(f);

  double sum = 0;
  std::size_t counted = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (mask && !(mask->pixels[i * mask->channels] > 0.5f)) continue;
    sum += out[i];
    ++counted;
  }
  res.mean = counted ? sum / double(counted) : 0.0;
  return res;
}

}  // namespace penumbra
