/// \file
/// The light model: directional area lights (caps and convex spherical polygons, optionally
/// textured), their samples, the light set with its ambient residual, and light-set files. How
/// lights are found in a map is extraction.hpp; how the ambient residual is computed, ambient.hpp.
///
/// Light model (Kneiphof 2017 §4.1.3): a uniform spherical cap of half-angle alpha around
/// `direction`
/// with RGB radiance L. Its "power" M = L * 2 pi (1 - cos alpha) is the integral of the map's
/// radiance over the region it replaces (Kneiphof 2017 eqs. 11, 16-17), so lights conserve energy.
#pragma once
#include <array>
#include <string>
#include <vector>

namespace penumbra {

struct Environment;

/// A light's shape on the sphere of directions (all lights are at infinity).
///   Cap:     a uniform spherical cap (a disc or a sphere seen from afar), half-angle alpha.
///   Polygon: a convex spherical polygon (great-circle edges): a rectangle, a cube-face region, any
///            convex polygon a user gives. `direction` is its normalized vertex centroid and
///            cosAlpha the cosine of its bounding cap about that direction (the cap every
///            filtered technique sizes its filters by); radiance is uniform over the polygon and
///            power = radiance * the polygon's solid angle.
/// Most lights a frame may have (the kernels' PB_MAX_LIGHTS; src/lights/lights.cpp checks they
/// agree).
constexpr int kMaxLights = 1024;

enum class LightShape { Cap, Polygon };
const char* toString(LightShape s);  // "cap" | "polygon"

/// A radiance texture over a light's tangent-plane square (AreaLight::axisU, tanHalf): texel
/// (i, j), column i of `width`, row j of `height`, covers frame coordinates
/// x in [-1 + 2i/width, -1 + 2(i+1)/width], y in [1 - 2(j+1)/height, 1 - 2j/height] (row 0 at the
/// top, +y along the light's up). A rect covers the whole square; a disk (cap) or an ellipse the
/// disk x^2 + y^2 <= 1 inscribed in it, so its corner texels are partly unused. The radiance is
/// piecewise constant (nearest texel).
struct LightTexture {
  int width = 0, height = 0;    ///< 0 x 0: no texture, the light's radiance is uniform
  std::vector<float> radiance;  ///< RGB, row-major, 3 * width * height values, finite, >= 0
  bool empty() const { return width <= 0 || height <= 0; }
};

struct AreaLight {
  LightShape shape = LightShape::Cap;
  /// What a polygon light stands for: plain vertices, a rect (makeRectLight) or an ellipse
  /// (makeEllipseLight; `vertices` then hold the PB_ELLIPSE_VERTS-gon that shading and the
  /// filtered techniques use; the bitmask technique, brute force and the Embree reference sample
  /// the ellipse itself, and solidAngle() is the ellipse's).
  enum class Outline { Vertices, Rect, Ellipse };
  Outline outline = Outline::Vertices;
  /// Tangent-plane frame of rects, ellipses and textured caps: frame point (x, y) is the direction
  /// normalize(direction + x tanHalf[0] axisU + y tanHalf[1] axisV()), axisV = axisU x direction
  /// (the light's up; axisU its right seen from the scene, facing the light).
  /// The rect is the square [-1, 1]^2, the ellipse and the cap's disk x^2 + y^2 <= 1 (a cap has
  /// tanHalf = tan(alpha) twice). tanHalf {0, 0}: no frame (plain polygons, untextured caps).
  std::array<float, 3> axisU{0, 0, 0};
  std::array<float, 2> tanHalf{0, 0};
  /// Radiance over the frame's square (setLightTexture); empty: uniform `radiance`. With a
  /// texture, `radiance` is the mean over the light (power / solid angle), which the unshadowed
  /// irradiance uses; the shadow techniques weight their light samples by the texture.
  LightTexture texture;
  /// Polygon only: 3..PB_MAX_POLY_VERTS unit directions, counter-clockwise about `direction` by
  /// the right-hand rule: (v_i x v_i+1) . direction > 0 for every edge (i+1 modulo the count).
  /// Empty for caps.
  std::vector<std::array<float, 3>> vertices;
  std::array<float, 3> direction{0, 1, 0};  ///< unit vector towards the light, world space
  float cosAlpha = 1.0f;                    ///< cosine of the half-angle
  std::array<float, 3> radiance{0, 0, 0};   ///< uniform radiance inside the cap
  std::array<float, 3> power{0, 0, 0};      ///< M = radiance * solid angle (irradiance at normal
                                            ///< incidence / ((1+cos alpha)/2))
  /// Cube-face region(s) the light came from, for overlays: face, x0, y0, x1, y1 (texels, x1/y1
  /// exclusive) on a cube of faceSize.
  std::vector<std::array<int, 5>> regions;

  float halfAngle() const;
  float solidAngle() const;  // cap: 2 pi (1 - cos alpha); polygon: its spherical excess
  /// Sets the power M and the radiance M / solid angle (Kneiphof 2017 eqs. 16-17); set cosAlpha
  /// first.
  void setPower(const std::array<float, 3>& m);
  /// Unshadowed irradiance on unit normal n (cap clipped by the horizon; shared.h). An ellipse
  /// uses its polygon; a textured light its mean radiance (exact at normal incidence where the
  /// texture is symmetric, otherwise off by the texture's first moment times the light's size).
  std::array<float, 3> irradiance(const std::array<float, 3>& n) const;
  std::array<float, 3> axisV() const;  // axisU x direction
  /// Frame coordinates (x, y) of direction d (d . direction > 0; any length).
  std::array<float, 2> frameCoords(const std::array<float, 3>& d) const;
  /// The texture's radiance at direction d (nearest texel; outside the square: the border
  /// texel); the uniform radiance without a texture.
  std::array<float, 3> radianceAt(const std::array<float, 3>& d) const;
  /// Weight of a light sample in direction d: the texture's luminance there over its largest
  /// texel luminance, in [0, 1]; exactly 1 without a texture or with a uniform one.
  float sampleWeight(const std::array<float, 3>& d) const;
};

/// A rect light: centre direction, `up` (any vector not parallel to it, turned into the tangent
/// plane) and half-angles (a, b) in radians, each in (0, pi/2), along right = direction x up (the
/// right of a viewer facing the light, `up` up) and up: the polygon with corners
/// direction +- tan(a) right +- tan(b) up (great-circle edges).
AreaLight makeRectLight(const std::array<float, 3>& direction, const std::array<float, 3>& up,
                        const std::array<double, 2>& halfAngles,
                        const std::array<float, 3>& radiance);
/// An ellipse light (an ellipsoid seen from afar: its silhouette cone is elliptic; Sintorn et al.
/// 2008 §4.1
/// approximates volumetric sources by ellipsoids): the directions
/// normalize(direction + x tan(a) right + y tan(b) up) with x^2 + y^2 <= 1, frame as makeRectLight.
/// Its polygon is the PB_ELLIPSE_VERTS-gon of the same frame area (for shading); its solid angle
/// the ellipse's own. Throws Error(BadInput) for half-angles outside (0, pi/2) or a polygon wider
/// than a hemisphere.
AreaLight makeEllipseLight(const std::array<float, 3>& direction, const std::array<float, 3>& up,
                           const std::array<double, 2>& halfAngles,
                           const std::array<float, 3>& radiance);
/// Gives the light a radiance texture: checks it (sizes 1..4096, 3 w h finite values >= 0, not
/// all zero; the light a cap, rect or ellipse), sets a cap's frame when it has none (the frame
/// lightSampleDirections uses), and sets power = the integral of the textured radiance over the
/// light (exact per texel for rects and for texels inside a disk or ellipse; texels on its rim
/// exact in y over 64 midpoint columns) and radiance = power / solid angle. A texture whose texels
/// are all equal gives that radiance exactly, so the light renders as the untextured one bit for
/// bit. Throws Error(BadInput) naming the problem.
void setLightTexture(AreaLight& light, LightTexture texture);
/// Scales a textured light's texture, channel by channel, so that its power is `power` (radiance =
/// power / solid angle, the texture's mean); a channel the texture leaves black is filled with that
/// uniform radiance. Used where the power is given and the texture gives only the shape: a light-set
/// file's "texture" beside "power", extracted lights textured from their map.
void scaleLightTexture(AreaLight& light, const std::array<float, 3>& power);

/// sampleWeight for many directions at once (the texture's largest luminance found once).
std::vector<float> lightSampleWeights(const AreaLight& light,
                                      const std::vector<std::array<float, 3>>& dirs);

/// A light sample: a direction and its weight. lightSamples' weights are in [0, 1] and stand for
/// the sample's share of the light's radiance times its solid angle, up to one common factor.
struct LightSample {
  std::array<float, 3> dir;
  float weight;
};
/// n samples of the light: a cap's or polygon's lightSampleDirections (uniform in solid angle,
/// weight = sampleWeight), an ellipse's Fibonacci disk points (as the bitmask technique's)
/// mapped into the ellipse, weight = sampleWeight times the solid angle its area stands for,
/// (1 + x'^2 + y'^2)^(-3/2) at frame point (x', y') = (x tan a, y tan b). Deterministic.
std::vector<LightSample> lightSamples(const AreaLight& light, int n, float rotation = 0.0f);

/// Makes a polygon light from its vertices (unit directions, any winding, convex): orders them
/// counter-clockwise, sets direction and the bounding cosAlpha, and the power from `radiance`.
/// Throws Error(BadInput) for fewer than 3 or more than PB_MAX_POLY_VERTS vertices, a non-convex
/// or degenerate polygon, or one wider than a hemisphere.
AreaLight makePolygonLight(const std::vector<std::array<float, 3>>& vertices,
                           const std::array<float, 3>& radiance);

/// n light sample directions, stratified and uniform in solid angle over the light (cap:
/// spherical Fibonacci over the cap; polygon: stratified over the polygon), rotated about the
/// light's direction by `rotation` radians (jitter between frames, Sintorn et al. 2008 §4.3).
/// Deterministic.
/// Used by lightSamples (brute force) and the ambient residual. An ellipse light gets its shading
/// polygon's samples here; lightSamples samples the ellipse itself.
std::vector<std::array<float, 3>> lightSampleDirections(const AreaLight& light, int n,
                                                        float rotation = 0.0f);

/// The ambient residual's irradiance as a table over normals (kernels/environment/irradiance.cl).
/// Texel (i, j) holds the RGB irradiance E_res(n_ij) = E_map(n_ij) - sum of every light's unshadowed
/// irradiance, at the normal of longitude phi_i = ((i + 0.5) / width - 0.5) 2 pi (pb_equirect_dir's
/// columns) and colatitude theta_j = j pi / (height - 1) (pi / 2 when height is 1): rows are nodes
/// from the +y pole (row 0) to the -y pole, so the poles are table entries themselves (see
/// pb_ambient_map_taps in shared.h for why). Read bilinearly, wrapping in longitude.
struct AmbientMap {
  int width = 0, height = 0;
  std::vector<float> rgb;  ///< height x width x 3, row-major, RGB interleaved
  bool empty() const { return width <= 0 || height <= 0; }
  /// Throws Error(BadInput) when rgb does not hold width x height x 3 values (a table set by hand,
  /// e.g. from Python): every reader (LightSet::ambientIrradiance, the renderer, the GL pass)
  /// checks it before indexing.
  void check() const;
};

struct LightSet {
  std::vector<AreaLight> lights;
  int faceSize = 0;                 ///< cube face size used for extraction
  std::string method;               ///< "median-cut" | "greedy" | "center-surround" | "user"
  /// Ambient residual (Arbree et al. 2005 §3; Ramamoorthi & Hanrahan 2001): the radiance the lights
  /// do not
  /// carry, map minus the lights' caps, projected onto the 9 real spherical harmonics of order
  /// <= 2, RGB. Applied unshadowed. Coefficient order: (l,m) = (0,0) (1,-1) (1,0) (1,1) (2,-2)
  /// (2,-1) (2,0) (2,1) (2,2). All zero when hasAmbient is false.
  std::array<std::array<float, 3>, 9> ambientSH{};
  bool hasAmbient = false;
  /// The same residual pre-integrated into irradiance (Arbree et al. 2005 abstract, §3:
  /// "pre-integrated
  /// irradiance mapping"; AmbientModel::IrradianceMap, the default): what shading adds on normal n
  /// when present, else the SH9 irradiance of ambientSH. Empty (width 0) with AmbientModel::SH9.
  AmbientMap ambientMap;
  std::array<double, 3> power() const;  // sum of the lights' M plus the ambient's power
  std::array<double, 3> lightsPower() const;  // sum of the lights' M only
  std::array<double, 3> ambientPower() const;  // integral of the ambient radiance over the sphere
  /// Unshadowed irradiance on unit normal n: every light's cap plus the ambient's.
  std::array<double, 3> irradiance(const std::array<float, 3>& n) const;
  /// The ambient alone: ambientMap's bilinear lookup (pb_ambient_map_taps, as the kernels and the
  /// GL shader read it) when the map is present, else R&H 2001's SH9 irradiance of ambientSH.
  std::array<double, 3> ambientIrradiance(const std::array<float, 3>& n) const;
  /// JSON: method, face_size, count, lights (each with "shape" "cap" or "polygon", direction,
  /// half_angle_deg, cos_alpha, solid_angle_sr, radiance, power, regions; polygons add
  /// "vertices", rects and ellipses are written as such with "up" and "half_angles_deg", textured
  /// lights add "texture"), ambient, ambient_sh, ambient_power, and "ambient_map" {"width",
  /// "height", "irradiance": [height * width * 3 numbers, row-major RGB]} when the map is present.
  /// loadLightSet reads it back. Valid UTF-8 JSON (text that is not UTF-8 is written with U+FFFD),
  /// floats as the shortest decimal that reads back as the same float, whatever the locale.
  std::string toJson() const;
};

/// Checks a light set built in code as the light-set file reader checks a file. Throws
/// Error(BadInput) "LightSet: light 3: <problem>" for more than PB_MAX_LIGHTS lights, a direction
/// that is not a finite unit vector, cosAlpha outside [-1, 1], radiance or power non-finite or
/// negative, a polygon with a vertex count outside 3..PB_MAX_POLY_VERTS or a non-finite vertex, a
/// texture whose size and values disagree or are non-finite or negative; and for non-finite
/// ambient coefficients or an ambient map whose size and values disagree. Renderer::render calls it
/// on every frame.
void validateLightSet(const LightSet& set);

/// The light set of the same map turned `degrees` further about +y (Environment::rotationYDeg's
/// sense: counter-clockwise seen from above, +x towards -z). Every light's direction, frame and
/// vertices turn with it (its size, radiance, power and texture are kept); the ambient's SH9
/// coefficients are rotated exactly (to float rounding); its irradiance map is shifted by
/// degrees / 360 of its width, read linearly between the two nearest columns (exact for a whole
/// number of columns: 90 degrees of a 128-wide map). `regions` are cleared: they are cells of
/// the unturned map's cube. Whole turns return the set unchanged, bit for bit.
///
/// What an animation of a turning map should use: extracting from each turned map instead lets
/// median cut's cells, which stay fixed to the cube, cut the map differently every frame, and
/// lights jump (with 32 lights, the sets extracted after turns of 1 to 3 degrees have lights up to
/// 29 degrees from the first set's, turned, on a studio map). `render
/// --frames` extracts once per map and turns the set (--extract-each-frame: the old way).
/// Throws Error(BadInput) for a non-finite angle or an ambient map whose size and values disagree.
LightSet rotateLightSet(const LightSet& set, float degrees);

/// A light-set file (render/reference --light-set FILE): {"lights": [...], "ambient_sh": [...]
/// optional}. Each light is an object with "shape" (default "cap") and "radiance" or "power" (RGB,
/// finite, >= 0; with both, both are kept as given):
///   cap:     "direction" [x,y,z], "half_angle_deg" in (0, 90) or "cos_alpha"; with a texture,
///            "up" optional (its frame's up; default the frame lightSampleDirections uses)
///   polygon: "vertices" [[x,y,z], ...] 3..PB_MAX_POLY_VERTS directions of a convex polygon,
///            any winding (makePolygonLight)
///   rect:    "direction", "up" (any vector not parallel to it) and "half_angles_deg" [a, b], each
///            in (0, 90): the polygon with corners direction +- tan(a) right +- tan(b) up
///   ellipse: "direction", "up" and "half_angles_deg" [a, b] as rect: the ellipse inscribed in that
///            rect (makeEllipseLight)
/// Cap, rect and ellipse lights may carry "texture": {"width": w, "height": h, "radiance":
/// [r, g, b, ...]} (3 w h values, row 0 at the top; LightTexture): "radiance" and "power" are then
/// optional, computed from the texture (setLightTexture) where not given.
/// What LightSet::toJson writes loads back (its derived "count", "solid_angle_sr" and
/// "ambient_power", and the "sanitized_pixels" `penumbra lights` adds, are accepted and not read).
/// Throws Error(BadInput) naming the file and the light's index for unreadable files, invalid JSON
/// ("<file>: invalid JSON at line L, column C: ...": syntax, numbers beyond double's range, a key
/// twice in one object, nesting deeper than 64), an unknown field (with "did you mean" when one is
/// close), a field of the wrong type, missing fields, non-finite or negative values, non-convex
/// polygons or too many vertices.
LightSet loadLightSet(const std::string& path);
LightSet lightSetFromJson(const std::string& text, const std::string& source = "light set");

/// Gives every cap light of `set` a size x size texture of the map's radiance over its disk
/// (LightTexture's mapping; supersample^2 nearest-texel look-ups per texel, averaged), scaled per
/// channel so that its integral is the light's power: power and mean radiance stay as extracted
/// (Kneiphof's (2017) energy conservation), and the shadow techniques weight each light sample by
/// the
/// map's luminance there. Polygon lights (no frame) and lights over black map regions are left
/// untextured. Throws Error(BadInput) for size outside [1, 64] or supersample outside [1, 16].
void textureLightsFromMap(const Environment& env, LightSet& set, int size = 8, int supersample = 4);

}  // namespace penumbra
