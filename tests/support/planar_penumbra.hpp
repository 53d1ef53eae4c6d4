// The planar-penumbra fixture every shadow technique's accuracy test renders: a ground plane, one
// or more straight-edged blockers parallel to it, one light, and a camera standing below the
// blockers that looks across their shadow edges; the driver that renders it with a technique and
// returns each ground pixel's visibility; the analytic penumbra profile of a cap light over a
// straight edge; and the per-pixel comparison of the two. In this configuration (receiver and
// blocker planes parallel and facing the light) PCSS-style filtering is exact, so the profile is
// what every filtered technique converges to.
#pragma once
#include <penumbra/penumbra.hpp>

#include <functional>
#include <string>
#include <vector>

namespace penumbra::test {

// A blocker: the quad {start < x < edge, -3 < z < zEnd} at `height` over the ground. The default
// (start -3, zEnd 3: across the whole ground) is the half-plane {x < edge}.
struct PlanarBlocker {
  double edge = 0, height = 1, start = -3.0;
  float zEnd = 3;
};

// A cap light of half-angle alphaDeg straight above (+y), radiance 1.
AreaLight capLightAbove(double alphaDeg);

struct PlanarPenumbra {
  // What the light sees: the ground [-3,3]^2 at y = 0, optionally a raised receiver (the platform
  // {x < receiverEdge} at receiverHeight > 0), the blockers, then any further meshes.
  std::vector<PlanarBlocker> blockers{PlanarBlocker{}};
  double receiverHeight = 0, receiverEdge = 3;
  std::vector<Mesh> extraMeshes;
  bool vertexNormals = true;  // false: quads without normals (flat shading)
  AreaLight light = capLightAbove(5);
  // The camera. eye[1] < 0 stands for "receiverHeight + 0.45 times the lowest blocker's height
  // above the receiver, at least minEyeHeight": on the lit side below the blockers, looking
  // across the shadow edge at a receiver that faces it and the light.
  Vec3 eye{2.2f, -1.0f, 0.3f};
  Vec3 target{-1.2f, 0.0f, 0.0f};
  float fovyDeg = 50;
  double minEyeHeight = 0;
  // The frame: image and map size; renderPlanar() also turns the environment background off and
  // lets the filters reach 64 texels (the wide penumbrae are wider than the default limit).
  int imageWidth = 128, imageHeight = 96, mapSize = 256;
  // Which receiver pixels count: their ground point (x, z) within `border` of the origin on both
  // axes, and, when set, keep(x, z) (e.g. away from the blockers' far edges, which the analytic
  // half-plane does not have).
  double border = 2.9;
  std::function<bool(double x, double z)> keep;
  // Several blocker layers or a raised receiver: the receiver hit is solved in double precision,
  // and pixels that see a blocker's top face (a camera above a blocker) or the platform's edge
  // are left out. Otherwise the ground hit is -eye.y / d.y in float, as the single-blocker tests
  // have always measured it.
  bool layered = false;

  Scene scene() const;
  Camera camera() const;
};

// One receiver pixel: its column and row, its ground point and its visibility.
struct ReceiverPixel {
  int col, row;
  double x, z, vis;
};

struct PlanarFrame {
  Image image;
  std::vector<float> visibility;  // the whole buffer, row by row
  std::vector<ReceiverPixel> receivers;
};

// Renders the configuration with the technique options in `ro` (technique, its own options,
// prefilter); the fixture sets the frame's size, the map size, the background and the filter
// limit.
PlanarFrame renderPlanar(const PlanarPenumbra& s, RenderOptions ro);

// A visibility profile across the penumbra [lo, hi] on the ground, tabulated at n + 1 points and
// read by linear interpolation (clamped to its ends outside).
struct PenumbraProfile {
  double lo = 0, hi = 0;
  std::vector<double> table;
  PenumbraProfile(double lo, double hi, int n, const std::function<double(double)>& visibility);
  double operator()(double x) const;
};

// The exact profile of a cap of half-angle alpha around +y over the half-plane {x < 0} at height
// h: the irradiance-weighted unblocked share of the cap seen from x on the ground, by quadrature
// over the cap (200 rings x 400 directions), across [-R, R], R = h tan(alpha), at 1/n of its width.
PenumbraProfile halfPlaneProfile(double h, double alpha, int n = 2000);

// The same share by a quadrature over rings alone (nt of them): the ring at theta meets the
// blocker's plane in a circle of radius r = h tan(theta) around x whose lit share acos(-x/r)/pi is
// exact. cosWeighted: weighted by the irradiance each direction brings; otherwise by solid angle.
double halfPlaneVisibilityByRings(double x, double h, double alpha, bool cosWeighted = true);

struct ComparedPixel {
  int col, row;
  double x, got, expect;  // x relative to the profile's edge
};

struct ProfileComparison {
  std::vector<ComparedPixel> pixels;
  double maxError = 0;     // max |V - V_profile| over every receiver
  double rmsPenumbra = 0;  // RMS of it over the receivers inside the penumbra (lo < x < hi)
  int samples = 0, penumbraSamples = 0;
};

// Every receiver against the profile, the blocker's edge at x = edge.
ProfileComparison compareWithProfile(const std::vector<ReceiverPixel>& receivers,
                                     const PenumbraProfile& profile, double edge = 0);

}  // namespace penumbra::test
