// Light-set files (lights.hpp): LightSet::toJson writes them, loadLightSet / lightSetFromJson read
// them back, and users write them by hand: caps, convex polygons, rectangles and ellipses,
// optionally textured. nlohmann-json parses and writes (core/json.hpp); this file checks what the
// document holds: every problem, an unknown field included, is an Error(BadInput) naming the file,
// the light's index and the field.
#include <algorithm>
#include <climits>
#include <cmath>
#include <fstream>
#include <sstream>
#include <vector>

#include "core/json.hpp"
#include "penumbra/error.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/suggest.hpp"
#include "common/shared.h"

namespace penumbra {
namespace {

using detail::Json;

constexpr double kPi = 3.14159265358979323846;
// Radians per degree as a float, the divisor toJson has always written angles with.
constexpr float kDeg = float(kPi / 180.0);

// The keys each object of a light-set file may hold. Besides what the reader uses, the derived
// values toJson writes ("count", "solid_angle_sr", "ambient_power") and the "sanitized_pixels"
// that `penumbra lights` adds, so that every file penumbra writes loads back.
const std::vector<std::string> kSetKeys = {"method",     "face_size",  "count",
                                           "lights",     "ambient",    "ambient_sh",
                                           "ambient_power", "ambient_map", "sanitized_pixels"};
const std::vector<std::string> kLightKeys = {"shape",          "direction",       "cos_alpha",
                                             "half_angle_deg", "solid_angle_sr",  "vertices",
                                             "up",             "half_angles_deg", "radiance",
                                             "power",          "texture",         "regions"};
const std::vector<std::string> kTextureKeys = {"width", "height", "radiance"};
const std::vector<std::string> kAmbientMapKeys = {"width", "height", "irradiance"};

const Json* field(const Json& o, const char* key) {
  const auto it = o.find(key);
  return it == o.end() ? nullptr : &*it;
}

// The first key of object `o` not in `known`, given to `fail` as `unknown field "powr"` + `where`
// + ` (did you mean "power"?)`; nothing when every key is known.
template <class Fail>
void refuseUnknownFields(const Json& o, const std::vector<std::string>& known,
                         const std::string& where, Fail fail) {
  for (const auto& item : o.items())
    if (std::find(known.begin(), known.end(), item.key()) == known.end())
      fail("unknown field \"" + item.key() + "\"" + where + didYouMean(item.key(), known));
}

// A finite number: nlohmann keeps integers apart (is_number covers all three kinds).
bool finiteNumber(const Json& v) { return v.is_number() && std::isfinite(v.get<double>()); }

struct LightReader {
  const std::string& src;
  int index;
  [[noreturn]] void fail(const std::string& what) const {
    badInput(src + ": light " + std::to_string(index) + ": " + what);
  }
  double number(const Json& o, const char* key) const {
    const Json* v = field(o, key);
    if (!v) fail(std::string("missing \"") + key + "\"");
    if (!finiteNumber(*v)) fail(std::string("\"") + key + "\" must be a finite number");
    return v->get<double>();
  }
  std::array<float, 3> vec3(const Json& v, const std::string& key) const {
    if (!v.is_array() || v.size() != 3) fail("\"" + key + "\" must be an array of 3 numbers");
    std::array<float, 3> r;
    for (int c = 0; c < 3; ++c) {
      if (!finiteNumber(v[c]) || !std::isfinite(float(v[c].get<double>())))
        fail("\"" + key + "\" must hold finite numbers");
      r[c] = float(v[c].get<double>());
    }
    return r;
  }
  std::array<float, 3> vec3(const Json& o, const char* key, bool required) const {
    const Json* v = field(o, key);
    if (!v) {
      if (required) fail(std::string("missing \"") + key + "\"");
      return {0, 0, 0};
    }
    return vec3(*v, key);
  }
  std::array<float, 3> unitDir(const Json& o, const char* key) const {
    auto d = vec3(o, key, true);
    double l = std::sqrt(double(d[0]) * d[0] + double(d[1]) * d[1] + double(d[2]) * d[2]);
    if (!(l > 0)) fail(std::string("\"") + key + "\" must not be zero");
    return {float(d[0] / l), float(d[1] / l), float(d[2] / l)};
  }
};

// "ambient": true when absent, else it must say.
bool ambientFlag(const Json& doc, const std::string& source) {
  const Json* flag = field(doc, "ambient");
  if (flag && !flag->is_boolean()) badInput(source + ": \"ambient\" must be true or false");
  return !flag || flag->get<bool>();
}

}  // namespace

LightSet lightSetFromJson(const std::string& text, const std::string& source) {
  const Json doc = detail::parseJson(text, source);
  if (!doc.is_object()) badInput(source + ": a light set must be a JSON object");
  refuseUnknownFields(doc, kSetKeys, " in the light set",
                      [&](const std::string& what) { badInput(source + ": " + what); });
  const Json* lights = field(doc, "lights");
  if (!lights || !lights->is_array())
    badInput(source + ": missing \"lights\" (an array of lights)");
  if (lights->size() > PB_MAX_LIGHTS)
    badInput(source + ": " + std::to_string(lights->size()) + " lights, at most " +
             std::to_string(PB_MAX_LIGHTS));
  LightSet set;
  set.method = "user";
  if (const Json* m = field(doc, "method")) {
    if (!m->is_string()) badInput(source + ": \"method\" must be a string");
    set.method = m->get<std::string>();
  }
  if (const Json* f = field(doc, "face_size")) {
    const double v = f->is_number() ? f->get<double>() : -1.0;
    if (!(v >= 0 && v < 1e6) || v != std::floor(v))
      badInput(source + ": \"face_size\" must be an integer in 0..999999");
    set.faceSize = int(v);
  }
  const bool ambientOn = ambientFlag(doc, source);
  for (std::size_t i = 0; i < lights->size(); ++i) {
    const Json& o = (*lights)[i];
    LightReader r{source, int(i)};
    if (!o.is_object()) r.fail("must be a JSON object");
    refuseUnknownFields(o, kLightKeys, "", [&](const std::string& what) { r.fail(what); });
    std::string shape = "cap";
    if (const Json* s = field(o, "shape")) {
      if (!s->is_string()) r.fail("\"shape\" must be \"cap\", \"polygon\", \"rect\" or \"ellipse\"");
      shape = s->get<std::string>();
    }
    const bool hasRad = field(o, "radiance") != nullptr, hasPow = field(o, "power") != nullptr;
    const bool hasTex = field(o, "texture") != nullptr;
    if (!hasRad && !hasPow && !hasTex) r.fail("needs \"radiance\", \"power\" or \"texture\"");
    std::array<float, 3> rad = r.vec3(o, "radiance", false), pow = r.vec3(o, "power", false);
    for (int c = 0; c < 3; ++c)
      if (rad[c] < 0 || pow[c] < 0) r.fail("negative radiance or power");
    AreaLight l;
    try {
      if (shape == "cap") {
        l.direction = r.unitDir(o, "direction");
        double ca;
        if (field(o, "cos_alpha")) {
          ca = r.number(o, "cos_alpha");
        } else {
          const double a = r.number(o, "half_angle_deg");
          if (!(a > 0 && a < 90)) r.fail("\"half_angle_deg\" must be in (0, 90)");
          ca = std::cos(a * kPi / 180);
        }
        if (!(ca > 0 && ca < 1)) r.fail("the cap's half-angle must be in (0, 90) degrees");
        l.cosAlpha = float(ca);
      } else if (shape == "polygon") {
        const Json* v = field(o, "vertices");
        if (!v || !v->is_array()) r.fail("missing \"vertices\" (an array of directions)");
        std::vector<std::array<float, 3>> verts;
        for (const Json& item : *v) verts.push_back(r.vec3(item, "vertices"));
        l = makePolygonLight(verts, {0, 0, 0});
      } else if (shape == "rect" || shape == "ellipse") {
        // A rectangle seen from afar, or the ellipse inscribed in it (an ellipsoid's silhouette):
        // centre direction d, `up` turned into the tangent plane, half-angles (a, b) along
        // right = d x up and up (makeRectLight, makeEllipseLight).
        auto d = r.unitDir(o, "direction");
        auto up = r.unitDir(o, "up");
        const Json* h = field(o, "half_angles_deg");
        if (!h || !h->is_array() || h->size() != 2)
          r.fail("\"half_angles_deg\" must be an array of 2 numbers");
        std::array<double, 2> ha;
        for (std::size_t k = 0; k < 2; ++k) {
          const Json& x = (*h)[k];
          if (!x.is_number() || !(x.get<double>() > 0 && x.get<double>() < 90))
            r.fail("\"half_angles_deg\" must be in (0, 90), got " +
                   (x.is_number() ? detail::numberText(x.get<double>()) : std::string("a non-number")));
          ha[k] = x.get<double>() * kPi / 180;
        }
        l = shape == "rect" ? makeRectLight(d, up, ha, {0, 0, 0}) : makeEllipseLight(d, up, ha, {0, 0, 0});
      } else {
        r.fail("unknown \"shape\" \"" + shape + "\" (accepted: cap, polygon, rect, ellipse)");
      }
      if (const Json* t = field(o, "texture")) {
        if (!t->is_object()) r.fail("\"texture\" must be an object {width, height, radiance}");
        refuseUnknownFields(*t, kTextureKeys, " in \"texture\"",
                            [&](const std::string& what) { r.fail(what); });
        LightTexture tex;
        const double w = r.number(*t, "width"), hgt = r.number(*t, "height");
        if (!(w >= 1 && w <= 4096 && w == std::floor(w)) || !(hgt >= 1 && hgt <= 4096 && hgt == std::floor(hgt)))
          r.fail("texture \"width\" and \"height\" must be integers in [1, 4096], got " +
                 detail::numberText(w) + " x " + detail::numberText(hgt));
        tex.width = int(w);
        tex.height = int(hgt);
        const Json* rv = field(*t, "radiance");
        if (!rv || !rv->is_array()) r.fail("texture needs \"radiance\" (an array of 3 w h numbers)");
        tex.radiance.reserve(rv->size());
        for (std::size_t k = 0; k < rv->size(); ++k) {
          const Json& x = (*rv)[k];
          if (!finiteNumber(x) || !std::isfinite(float(x.get<double>())) || x.get<double>() < 0)
            r.fail("texture \"radiance\" value " + std::to_string(k) + " must be a finite number >= 0");
          tex.radiance.push_back(float(x.get<double>()));
        }
        if (shape == "cap" && field(o, "up")) {
          // the texture's up: axisU = direction x up
          auto up = r.unitDir(o, "up");
          const double dd[3] = {l.direction[0], l.direction[1], l.direction[2]};
          double u[3] = {up[0], up[1], up[2]};
          const double du = u[0] * dd[0] + u[1] * dd[1] + u[2] * dd[2];
          for (int c = 0; c < 3; ++c) u[c] -= du * dd[c];
          const double ul = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
          if (!(ul > 1e-6)) r.fail("\"up\" must not be parallel to \"direction\"");
          for (double& c : u) c /= ul;
          l.axisU = {float(dd[1] * u[2] - dd[2] * u[1]), float(dd[2] * u[0] - dd[0] * u[2]),
                     float(dd[0] * u[1] - dd[1] * u[0])};
        }
        setLightTexture(l, std::move(tex));
      }
    } catch (const Error& e) {
      if (e.kind() != ErrorKind::BadInput) throw;
      const std::string msg = e.what();
      if (msg.rfind(source + ":", 0) == 0) throw;
      r.fail(msg);
    }
    if (hasTex && !hasRad && !hasPow) {
      // radiance and power as setLightTexture computed them
    } else if (hasTex && !hasRad) {
      // The texture gives the shape, "power" the scale (scaleLightTexture); a channel the
      // texture leaves black cannot carry power.
      for (int c = 0; c < 3; ++c)
        if (!(l.power[c] > 0) && pow[c] > 0)
          r.fail("\"power\" has channel " + std::to_string(c) + " > 0 where the texture is black");
      scaleLightTexture(l, pow);
    } else if (hasRad) {
      l.radiance = rad;
      const float omega = l.solidAngle();
      for (int c = 0; c < 3; ++c) l.power[c] = hasPow ? pow[c] : rad[c] * omega;
    } else {
      l.setPower(pow);
    }
    if (const Json* g = field(o, "regions")) {
      if (!g->is_array()) r.fail("\"regions\" must be an array of entries of 5 integers");
      for (const Json& reg : *g) {
        if (!reg.is_array() || reg.size() != 5) r.fail("\"regions\" entries must be 5 integers");
        std::array<int, 5> q;
        for (std::size_t k = 0; k < 5; ++k) {
          // Checked before the conversion: a double outside int's range converts undefinedly.
          const Json& v = reg[k];
          const double x = v.is_number() ? v.get<double>() : -1.0;
          if (!(x >= 0 && x <= INT_MAX) || x != std::floor(x))
            r.fail("\"regions\" entries must be 5 integers in 0.." + std::to_string(INT_MAX));
          q[k] = int(x);
        }
        l.regions.push_back(q);
      }
    }
    set.lights.push_back(l);
  }
  if (const Json* a = field(doc, "ambient_sh")) {
    if (!a->is_array() || a->size() != 9)
      badInput(source + ": \"ambient_sh\" must hold 9 RGB coefficients");
    for (std::size_t k = 0; k < 9; ++k) {
      const Json& coefficient = (*a)[k];
      if (!coefficient.is_array() || coefficient.size() != 3)
        badInput(source + ": \"ambient_sh\" must hold 9 RGB coefficients");
      for (std::size_t c = 0; c < 3; ++c) {
        if (!finiteNumber(coefficient[c]))
          badInput(source + ": \"ambient_sh\" must hold finite numbers");
        set.ambientSH[k][c] = float(coefficient[c].get<double>());
      }
    }
    set.hasAmbient = ambientOn;
  }
  // The pre-integrated irradiance map (LightSet::ambientMap); without it the SH9 above shades.
  if (const Json* a = field(doc, "ambient_map")) {
    if (!a->is_object())
      badInput(source + ": \"ambient_map\" must be an object with width, height, irradiance");
    refuseUnknownFields(*a, kAmbientMapKeys, " in \"ambient_map\"",
                        [&](const std::string& what) { badInput(source + ": " + what); });
    auto size = [&](const char* name) {
      const Json* v = field(*a, name);
      const double x = v && v->is_number() ? v->get<double>() : 0.0;
      if (!(x >= 1 && x <= 1024) || x != std::floor(x))
        badInput(source + ": \"ambient_map." + name + "\" must be an integer in 1..1024" +
                 (v && v->is_number() ? ", got " + detail::numberText(x) : ""));
      return int(x);
    };
    AmbientMap m;
    m.width = size("width");
    m.height = size("height");
    const Json* e = field(*a, "irradiance");
    const std::size_t want = std::size_t(m.width) * m.height * 3;
    if (!e || !e->is_array() || e->size() != want)
      badInput(source + ": \"ambient_map.irradiance\" must hold width * height * 3 = " +
               std::to_string(want) + " numbers" +
               (e && e->is_array() ? ", got " + std::to_string(e->size()) : ""));
    m.rgb.resize(want);
    for (std::size_t i = 0; i < want; ++i) {
      const Json& x = (*e)[i];
      if (!finiteNumber(x) || !std::isfinite(float(x.get<double>())))
        badInput(source + ": \"ambient_map.irradiance\" must hold finite numbers (entry " +
                 std::to_string(i) + ")");
      m.rgb[i] = float(x.get<double>());
    }
    set.ambientMap = std::move(m);
    set.hasAmbient = ambientOn;
  }
  return set;
}

LightSet loadLightSet(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) badInput(path + ": cannot open light-set file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return lightSetFromJson(ss.str(), path);
}

namespace {

// Floats as the shortest decimal that reads back as the same float.
Json floats(const float* v, std::size_t n) {
  Json a = Json::array();
  for (std::size_t i = 0; i < n; ++i) a.push_back(detail::shortestDecimal(v[i]));
  return a;
}
Json floats(const std::array<float, 3>& v) { return floats(v.data(), 3); }

}  // namespace

std::string LightSet::toJson() const {
  Json o;
  o["method"] = method;
  o["face_size"] = faceSize;
  o["count"] = lights.size();
  Json list = Json::array();
  for (const AreaLight& l : lights) {
    Json j;
    const bool framed = l.shape == LightShape::Polygon && l.outline != AreaLight::Outline::Vertices;
    j["shape"] = !framed ? toString(l.shape) : l.outline == AreaLight::Outline::Rect ? "rect" : "ellipse";
    if (framed || !l.texture.empty()) {
      // the frame: rects and ellipses load from it; a textured cap keeps its texture's orientation
      j["up"] = floats(l.axisV());
      if (framed)
        j["half_angles_deg"] = {detail::shortestDecimal(float(std::atan(double(l.tanHalf[0])) / kDeg)),
                                detail::shortestDecimal(float(std::atan(double(l.tanHalf[1])) / kDeg))};
    }
    if (!l.texture.empty())
      j["texture"] = {{"width", l.texture.width},
                      {"height", l.texture.height},
                      {"radiance", floats(l.texture.radiance.data(), l.texture.radiance.size())}};
    if (l.shape == LightShape::Polygon) {
      Json vertices = Json::array();
      for (const auto& v : l.vertices) vertices.push_back(floats(v));
      j["vertices"] = vertices;
    }
    j["direction"] = floats(l.direction);
    j["half_angle_deg"] = detail::shortestDecimal(l.halfAngle() / kDeg);
    j["cos_alpha"] = detail::shortestDecimal(l.cosAlpha);
    j["solid_angle_sr"] = detail::shortestDecimal(l.solidAngle());
    j["radiance"] = floats(l.radiance);
    j["power"] = floats(l.power);
    j["regions"] = l.regions;
    list.push_back(j);
  }
  o["lights"] = list;
  // The ambient residual: 9 RGB SH coefficients of radiance (order in lights.hpp), and its power.
  o["ambient"] = hasAmbient;
  Json sh = Json::array();
  for (const auto& c : ambientSH) sh.push_back(floats(c));
  o["ambient_sh"] = sh;
  const auto ap = ambientPower();
  o["ambient_power"] = {detail::shortestDecimal(float(ap[0])), detail::shortestDecimal(float(ap[1])),
                        detail::shortestDecimal(float(ap[2]))};
  // The pre-integrated irradiance map (lights.hpp AmbientMap), when the set has one.
  if (!ambientMap.empty())
    o["ambient_map"] = {{"width", ambientMap.width},
                        {"height", ambientMap.height},
                        {"irradiance", floats(ambientMap.rgb.data(), ambientMap.rgb.size())}};
  return detail::dumpJson(o, 2) + "\n";
}

}  // namespace penumbra
