// Directional area lights extracted from an environment map, and the extraction itself.
//
// Light model (seed 003 §4.1.3): a uniform spherical cap of half-angle alpha around `direction`
// with RGB radiance L. Its "power" M = L * 2 pi (1 - cos alpha) is the integral of the map's
// radiance over the region it replaces (seed 003 eqs. 11, 16-17), so lights conserve energy.
#pragma once
#include <array>
#include <string>
#include <vector>

namespace penumbra {

class Context;
struct Environment;

// A light's shape on the sphere of directions (all lights are at infinity).
//   Cap:     a uniform spherical cap (a disc or a sphere seen from afar), half-angle alpha.
//   Polygon: a convex spherical polygon (great-circle edges): a rectangle, a cube-face region, any
//            convex polygon a user gives. `direction` is its normalized vertex centroid and
//            cosAlpha the cosine of its bounding cap about that direction (the cap every
//            filtered technique sizes its filters by); radiance is uniform over the polygon and
//            power = radiance * the polygon's solid angle.
enum class LightShape { Cap, Polygon };
const char* toString(LightShape s);  // "cap" | "polygon"

struct AreaLight {
  LightShape shape = LightShape::Cap;
  // Polygon only: 3..PB_MAX_POLY_VERTS unit directions, counter-clockwise about `direction` by
  // the right-hand rule: (v_i x v_i+1) . direction > 0 for every edge (i+1 modulo the count).
  // Empty for caps.
  std::vector<std::array<float, 3>> vertices;
  std::array<float, 3> direction{0, 1, 0};  // unit vector towards the light, world space
  float cosAlpha = 1.0f;                    // cosine of the half-angle
  std::array<float, 3> radiance{0, 0, 0};   // uniform radiance inside the cap
  std::array<float, 3> power{0, 0, 0};      // M = radiance * solid angle (irradiance at normal incidence / ((1+cos alpha)/2))
  // Cube-face region(s) the light came from, for overlays: face, x0, y0, x1, y1 (texels, x1/y1
  // exclusive) on a cube of faceSize.
  std::vector<std::array<int, 5>> regions;

  float halfAngle() const;
  float solidAngle() const;  // cap: 2 pi (1 - cos alpha); polygon: its spherical excess
  // Sets the power M and the radiance M / solid angle (seed 003 eqs. 16-17); set cosAlpha first.
  void setPower(const std::array<float, 3>& m);
  // Unshadowed irradiance on unit normal n (cap clipped by the horizon; shared.h).
  std::array<float, 3> irradiance(const std::array<float, 3>& n) const;
};

// Makes a polygon light from its vertices (unit directions, any winding, convex): orders them
// counter-clockwise, sets direction and the bounding cosAlpha, and the power from `radiance`.
// Throws Error(BadInput) for fewer than 3 or more than PB_MAX_POLY_VERTS vertices, a non-convex
// or degenerate polygon, or one wider than a hemisphere.
AreaLight makePolygonLight(const std::vector<std::array<float, 3>>& vertices,
                           const std::array<float, 3>& radiance);

// n light sample directions, stratified and uniform in solid angle over the light (cap:
// spherical Fibonacci over the cap; polygon: stratified over the polygon), rotated about the light's direction by `rotation` radians (jitter between frames,
// seed 001 §4.3). Deterministic. Used by brute force, the bitmask technique and the references.
std::vector<std::array<float, 3>> lightSampleDirections(const AreaLight& light, int n,
                                                        float rotation = 0.0f);

// The ambient residual's irradiance as a table over normals (kernels/irradiance.cl). Texel (i, j)
// holds the RGB irradiance E_res(n_ij) = E_map(n_ij) - sum of every light's unshadowed irradiance,
// at the normal of longitude phi_i = ((i + 0.5) / width - 0.5) 2 pi (pb_equirect_dir's columns)
// and colatitude theta_j = j pi / (height - 1) (pi / 2 when height is 1): rows are nodes from
// the +y pole (row 0) to the -y pole, so the poles are table entries themselves (see
// pb_ambient_map_taps in shared.h for why). Read bilinearly, wrapping in longitude.
struct AmbientMap {
  int width = 0, height = 0;
  std::vector<float> rgb;  // height x width x 3, row-major, RGB interleaved
  bool empty() const { return width <= 0 || height <= 0; }
};

struct LightSet {
  std::vector<AreaLight> lights;
  int faceSize = 0;                 // cube face size used for extraction
  std::string method;               // "median-cut" | "greedy" | "center-surround" | "user"
  // Ambient residual (seed 004 §3; Ramamoorthi & Hanrahan 2001): the radiance the lights do not
  // carry, map minus the lights' caps, projected onto the 9 real spherical harmonics of order
  // <= 2, RGB. Applied unshadowed. Coefficient order: (l,m) = (0,0) (1,-1) (1,0) (1,1) (2,-2)
  // (2,-1) (2,0) (2,1) (2,2). All zero when hasAmbient is false.
  std::array<std::array<float, 3>, 9> ambientSH{};
  bool hasAmbient = false;
  // The same residual pre-integrated into irradiance (seed 004 abstract, §3: "pre-integrated
  // irradiance mapping"; AmbientModel::IrradianceMap, the default): what shading adds on normal n
  // when present, else the SH9 irradiance of ambientSH. Empty (width 0) with AmbientModel::SH9.
  AmbientMap ambientMap;
  std::array<double, 3> power() const;  // sum of the lights' M plus the ambient's power
  std::array<double, 3> lightsPower() const;  // sum of the lights' M only
  std::array<double, 3> ambientPower() const;  // integral of the ambient radiance over the sphere
  // Unshadowed irradiance on unit normal n: every light's cap plus the ambient's.
  std::array<double, 3> irradiance(const std::array<float, 3>& n) const;
  // The ambient alone: ambientMap's bilinear lookup (pb_ambient_map_taps, as the kernels and the
  // GL shader read it) when the map is present, else R&H 2001's SH9 irradiance of ambientSH.
  std::array<double, 3> ambientIrradiance(const std::array<float, 3>& n) const;
  // JSON: method, face_size, count, lights (each with "shape" "cap" or "polygon", direction,
  // half_angle_deg, cos_alpha, solid_angle_sr, radiance, power, regions; polygons add
  // "vertices"), ambient, ambient_sh, ambient_power, and "ambient_map" {"width", "height",
  // "irradiance": [height * width * 3 numbers, row-major RGB]} when the map is present.
  // loadLightSet reads it back.
  std::string toJson() const;
};

// A light-set file (render/reference --light-set FILE): {"lights": [...], "ambient_sh": [...]
// optional}. Each light is an object with "shape" (default "cap") and "radiance" or "power" (RGB,
// finite, >= 0; with both, both are kept as given):
//   cap:     "direction" [x,y,z], "half_angle_deg" in (0, 90) or "cos_alpha"
//   polygon: "vertices" [[x,y,z], ...] 3..PB_MAX_POLY_VERTS directions of a convex polygon,
//            any winding (makePolygonLight)
//   rect:    "direction", "up" (any vector not parallel to it) and "half_angles_deg" [a, b], each
//            in (0, 90): the polygon with corners direction +- tan(a) right +- tan(b) up
// What LightSet::toJson writes loads back. Throws Error(BadInput) naming the file and the light's
// index for unreadable files, invalid JSON, missing fields, non-finite or negative values,
// non-convex polygons or too many vertices.
LightSet loadLightSet(const std::string& path);
LightSet lightSetFromJson(const std::string& text, const std::string& source = "light set");

struct MedianCutOptions {
  int lights = 32;        // number of regions/lights, >= 1 (any N, not only powers of two)
  int faceSize = 256;     // cube face resolution used for the SATs, 1..4096
  int supersample = 4;    // sub-samples per equirect texel side when splatting to the cube
  float minHalfAngleDeg = 0.0f;  // lower clamp on the extracted half-angle (0: one texel's cap)
  float maxHalfAngleDeg = 85.0f; // upper clamp: the cap model needs alpha < 90 degrees
  // Merge lights whose regions touch across a cube-face edge and whose caps overlap (angle
  // between directions < sum of half-angles) into one light with their summed moments: a source
  // cut by a face edge stays one light, with one shadow instead of two with a seam between them.
  // The light count can then end below `lights` (`lights` regions are still cut). Default true;
  // false keeps one light per median-cut region.
  bool mergeAcrossFaces = true;
  // Only compact lights are merged: those whose cap covers at most this fraction of their
  // regions' solid angle (a source brighter than its surroundings; the cap of a uniformly bright
  // region is about as large as the region, 1.05 for a square). In (0, 1], default 0.5.
  float mergeCompactness = 0.5f;
  // Shape of the extracted lights. Cap: seed 003's disc of the region's moments. Polygon: a light
  // made from a single region is that region's exact shape, the convex spherical quadrilateral
  // whose edges are the region's (great circles, since a cube face is a gnomonic projection),
  // with radiance = region power / region solid angle (exact power). Lights merged from several
  // regions (across face edges, or whole faces when fewer than 6 lights are asked for) stay caps:
  // their union is not one convex polygon.
  // Measured (tests/test_polygon_lights.cpp): the polygon is exact where the map is uniform over
  // each region, but median-cut regions are not (they are cut at the energy median, so a bright
  // source shares its region with darker texels), and a uniform polygon moves the region's first
  // moment to the polygon's centroid, which the cap keeps. On the test maps the polygon shape's
  // irradiance error on issue 4's 26 normals is 3-9x the cap's (see the test's report); the cap
  // is the default for that reason.
  LightShape shape = LightShape::Cap;
};

// Median cut on the device (seed 003 §3.1, §4.1): resample to a cube map, luminance and RGB SATs
// over the solid-angle weighted faces, split at the illuminance median along the longer edge until
// `lights` regions, then resolve each region to a light. Throws Error(BadInput) for lights < 1,
// lights > 6*faceSize^2 or a faceSize out of range.
LightSet extractMedianCut(Context& ctx, const Environment& env, const MedianCutOptions& opt = {});

// Greedy fitting of square or rectangular lights to each cube face (seed 000 §4.2, Figure 6).
struct GreedyOptions {
  float threshold = 0.02f;  // a side grows while (energy it adds) / (energy of the grown light) > t
  bool square = true;       // square lights (the paper's results); false: rectangular
  int faceSize = 64;        // cube face resolution the fit runs on, 1..1024
  int maxLights = 64;       // the strongest this many are kept; the rest goes to the ambient
  int supersample = 4;
};
LightSet extractGreedy(Context& ctx, const Environment& env, const GreedyOptions& opt = {});

// Center-surround filter bank on the sphere (seed 004 §3).
struct CenterSurroundOptions {
  int width = 512;              // working equirect resolution (width x width/2) the filters run on
  int sizes = 20;               // filter sizes, geometric from minDeg to maxDeg (outer diameter)
  float minDeg = 4.5f, maxDeg = 45.0f;
  float innerRatio = 0.75f;     // inner radius / outer radius
  float surroundWeight = -10.0f;// weight of the ring; the centre's is +1
  float candidateFraction = 0.10f;  // the brightest this fraction of texels are candidate centres
  float stopFraction = 0.02f;   // stop when a light carries less than this of the lights so far
  int maxLights = 256;
};
LightSet extractCenterSurround(Context& ctx, const Environment& env,
                               const CenterSurroundOptions& opt = {});

// How the ambient residual is represented for shading.
//   IrradianceMap: the residual's irradiance tabulated over normals (LightSet::ambientMap, seed
//                  004's pre-integrated irradiance map): exact at the table's normals, bilinear
//                  between them; lights + ambient reproduce the map's irradiance on every normal
//                  to the table's interpolation error (tests/test_ambient.cpp measures it).
//   SH9:           the residual's radiance as 9 SH coefficients only (R&H 2001): smooth, but
//                  it drops the residual's bands l >= 3, up to several % of the irradiance.
enum class AmbientModel { IrradianceMap, SH9 };
AmbientModel parseAmbientModel(const std::string& name);  // "map" | "sh9"
const char* toString(AmbientModel m);
struct AmbientOptions {
  AmbientModel model = AmbientModel::IrradianceMap;
  // Table size (IrradianceMap), texels; each in 1..1024. Default 128 x 64, chosen by measurement
  // (lights + ambient against the map's irradiance on 26 + 200 random normals, every method and
  // test map, two random sets): the worst error is 2.9% at 64 x 32, 1.8% at 80 x 40 and
  // 96 x 48, 1.4% at 128 x 64 (interior.exr, center-surround), 1.3% at 160 x 80; it falls slower than the square of the spacing because compact bright sources left
  // in the residual, and lights whose shape differs from their region, make the irradiance kink
  // where their horizon passes, which bilinear interpolation resolves only to first order.
  int mapWidth = 128, mapHeight = 64;
};

// Sets set.ambientSH to SH9(map) - sum of SH9(each light), computed on the device, and
// set.hasAmbient = true; with AmbientModel::IrradianceMap also set.ambientMap (on the device,
// kernels/irradiance.cl), else clears it. Honours env.rotationYDeg. Throws Error(BadInput) for a
// table size outside 1..1024.
void addAmbientResidual(Context& ctx, const Environment& env, LightSet& set,
                        const AmbientOptions& opt = {});

enum class ExtractionMethod { MedianCut, Greedy, CenterSurround };
ExtractionMethod parseExtractionMethod(const std::string& name);  // "median-cut" | "greedy" | "center-surround"
const char* toString(ExtractionMethod m);
struct ExtractOptions {
  ExtractionMethod method = ExtractionMethod::MedianCut;
  MedianCutOptions medianCut;
  GreedyOptions greedy;
  CenterSurroundOptions centerSurround;
  bool ambient = true;  // add the ambient residual (addAmbientResidual)
  AmbientOptions ambientOptions;  // its representation (default: the irradiance map, 128 x 64)
};
// Runs the chosen method, then the ambient residual when opt.ambient.
LightSet extractLights(Context& ctx, const Environment& env, const ExtractOptions& opt = {});

// Draws the map (tone-mapped) with each light's region(s) outlined and its centre marked; a light
// without regions (center-surround) gets its cap's outline, the circle at its half-angle.
// Writes PNG atomically.
void writeLightOverlay(const std::string& path, const Environment& env, const LightSet& lights);

}  // namespace penumbra
