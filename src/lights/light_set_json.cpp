// Light-set files (lights.hpp): LightSet::toJson writes them, loadLightSet / lightSetFromJson read
// them back, and users write them by hand: caps, convex polygons, rectangles and ellipses,
// optionally textured. A small JSON reader of our own (the library has no JSON dependency),
// strict about what it accepts: every problem is an Error(BadInput) naming the file, the light's
// index and the field.
#include <climits>
#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include "penumbra/error.hpp"
#include "penumbra/lights.hpp"
#include "common/shared.h"

namespace penumbra {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Radians per degree as a float, the divisor toJson has always written angles with, so that the
// files stay byte for byte what they were.
constexpr float kDeg = float(kPi / 180.0);

struct Json {
  enum Kind { Null, Bool, Number, String, Array, Object } kind = Null;
  bool b = false;
  double num = 0;
  std::string str;
  std::vector<Json> items;
  std::map<std::string, Json> fields;
  const Json* get(const std::string& k) const {
    auto it = fields.find(k);
    return it == fields.end() ? nullptr : &it->second;
  }
};

class Reader {
 public:
  Reader(const std::string& text, const std::string& source) : s_(text), src_(source) {}
  Json document() {
    Json v = value(0);
    skip();
    if (i_ != s_.size()) fail("unexpected text after the JSON value");
    return v;
  }

 private:
  [[noreturn]] void fail(const std::string& what) {
    // line of the error, for a hand-written file
    int line = 1;
    for (std::size_t k = 0; k < i_ && k < s_.size(); ++k) line += s_[k] == '\n';
    badInput(src_ + ": invalid JSON at line " + std::to_string(line) + ": " + what);
  }
  void skip() {
    while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\n' || s_[i_] == '\r'))
      ++i_;
  }
  bool eat(char c) {
    skip();
    if (i_ < s_.size() && s_[i_] == c) {
      ++i_;
      return true;
    }
    return false;
  }
  Json value(int depth) {
    if (depth > 64) fail("nested too deeply");
    skip();
    if (i_ >= s_.size()) fail("unexpected end of file");
    Json v;
    char c = s_[i_];
    if (c == '{') {
      ++i_;
      v.kind = Json::Object;
      if (eat('}')) return v;
      do {
        skip();
        if (i_ >= s_.size() || s_[i_] != '"') fail("expected a field name");
        std::string k = string();
        if (!eat(':')) fail("expected ':' after \"" + k + "\"");
        v.fields[k] = value(depth + 1);
      } while (eat(','));
      if (!eat('}')) fail("expected ',' or '}'");
    } else if (c == '[') {
      ++i_;
      v.kind = Json::Array;
      if (eat(']')) return v;
      do v.items.push_back(value(depth + 1));
      while (eat(','));
      if (!eat(']')) fail("expected ',' or ']'");
    } else if (c == '"') {
      v.kind = Json::String;
      v.str = string();
    } else if (s_.compare(i_, 4, "true") == 0) {
      v.kind = Json::Bool, v.b = true, i_ += 4;
    } else if (s_.compare(i_, 5, "false") == 0) {
      v.kind = Json::Bool, i_ += 5;
    } else if (s_.compare(i_, 4, "null") == 0) {
      i_ += 4;
    } else {
      // numbers; NaN and Infinity are not JSON and are refused here
      const char* b = s_.c_str() + i_;
      char* e = nullptr;
      if (!(c == '-' || (c >= '0' && c <= '9'))) fail(std::string("unexpected character '") + c + "'");
      v.num = std::strtod(b, &e);
      if (e == b) fail("bad number");
      i_ += std::size_t(e - b);
      v.kind = Json::Number;
    }
    return v;
  }
  std::string string() {
    ++i_;  // opening quote
    std::string out;
    while (i_ < s_.size() && s_[i_] != '"') {
      if (s_[i_] == '\\' && i_ + 1 < s_.size()) {
        ++i_;
        char e = s_[i_];
        out += e == 'n' ? '\n' : e == 't' ? '\t' : e;
      } else {
        out += s_[i_];
      }
      ++i_;
    }
    if (i_ >= s_.size()) fail("unterminated string");
    ++i_;
    return out;
  }
  const std::string& s_;
  std::string src_;
  std::size_t i_ = 0;
};

struct LightReader {
  const std::string& src;
  int index;
  [[noreturn]] void fail(const std::string& what) const {
    badInput(src + ": light " + std::to_string(index) + ": " + what);
  }
  double number(const Json& o, const char* key) const {
    const Json* v = o.get(key);
    if (!v) fail(std::string("missing \"") + key + "\"");
    if (v->kind != Json::Number || !std::isfinite(v->num))
      fail(std::string("\"") + key + "\" must be a finite number");
    return v->num;
  }
  std::array<float, 3> vec3(const Json& v, const std::string& key) const {
    if (v.kind != Json::Array || v.items.size() != 3)
      fail("\"" + key + "\" must be an array of 3 numbers");
    std::array<float, 3> r;
    for (int c = 0; c < 3; ++c) {
      if (v.items[c].kind != Json::Number || !std::isfinite(v.items[c].num) ||
          !std::isfinite(float(v.items[c].num)))
        fail("\"" + key + "\" must hold finite numbers");
      r[c] = float(v.items[c].num);
    }
    return r;
  }
  std::array<float, 3> vec3(const Json& o, const char* key, bool required) const {
    const Json* v = o.get(key);
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

}  // namespace

LightSet lightSetFromJson(const std::string& text, const std::string& source) {
  Json doc = Reader(text, source).document();
  if (doc.kind != Json::Object) badInput(source + ": a light set must be a JSON object");
  const Json* lights = doc.get("lights");
  if (!lights || lights->kind != Json::Array)
    badInput(source + ": missing \"lights\" (an array of lights)");
  if (lights->items.size() > PB_MAX_LIGHTS)
    badInput(source + ": " + std::to_string(lights->items.size()) + " lights, at most " +
             std::to_string(PB_MAX_LIGHTS));
  LightSet set;
  set.method = "user";
  if (const Json* m = doc.get("method"); m && m->kind == Json::String) set.method = m->str;
  if (const Json* f = doc.get("face_size"); f && f->kind == Json::Number && f->num >= 0 && f->num < 1e6)
    set.faceSize = int(f->num);
  for (std::size_t i = 0; i < lights->items.size(); ++i) {
    const Json& o = lights->items[i];
    LightReader r{source, int(i)};
    if (o.kind != Json::Object) r.fail("must be a JSON object");
    std::string shape = "cap";
    if (const Json* s = o.get("shape")) {
      if (s->kind != Json::String) r.fail("\"shape\" must be \"cap\", \"polygon\", \"rect\" or \"ellipse\"");
      shape = s->str;
    }
    const bool hasRad = o.get("radiance") != nullptr, hasPow = o.get("power") != nullptr;
    const bool hasTex = o.get("texture") != nullptr;
    if (!hasRad && !hasPow && !hasTex) r.fail("needs \"radiance\", \"power\" or \"texture\"");
    std::array<float, 3> rad = r.vec3(o, "radiance", false), pow = r.vec3(o, "power", false);
    for (int c = 0; c < 3; ++c)
      if (rad[c] < 0 || pow[c] < 0) r.fail("negative radiance or power");
    AreaLight l;
    try {
      if (shape == "cap") {
        l.direction = r.unitDir(o, "direction");
        double ca;
        if (o.get("cos_alpha")) {
          ca = r.number(o, "cos_alpha");
        } else {
          const double a = r.number(o, "half_angle_deg");
          if (!(a > 0 && a < 90)) r.fail("\"half_angle_deg\" must be in (0, 90)");
          ca = std::cos(a * kPi / 180);
        }
        if (!(ca > 0 && ca < 1)) r.fail("the cap's half-angle must be in (0, 90) degrees");
        l.cosAlpha = float(ca);
      } else if (shape == "polygon") {
        const Json* v = o.get("vertices");
        if (!v || v->kind != Json::Array) r.fail("missing \"vertices\" (an array of directions)");
        std::vector<std::array<float, 3>> verts;
        for (auto& item : v->items) verts.push_back(r.vec3(item, "vertices"));
        l = makePolygonLight(verts, {0, 0, 0});
      } else if (shape == "rect" || shape == "ellipse") {
        // A rectangle seen from afar, or the ellipse inscribed in it (an ellipsoid's silhouette):
        // centre direction d, `up` turned into the tangent plane, half-angles (a, b) along
        // right = d x up and up (makeRectLight, makeEllipseLight).
        auto d = r.unitDir(o, "direction");
        auto up = r.unitDir(o, "up");
        const Json* h = o.get("half_angles_deg");
        if (!h || h->kind != Json::Array || h->items.size() != 2)
          r.fail("\"half_angles_deg\" must be an array of 2 numbers");
        std::array<double, 2> ha;
        for (int k = 0; k < 2; ++k) {
          if (h->items[k].kind != Json::Number || !(h->items[k].num > 0 && h->items[k].num < 90))
            r.fail("\"half_angles_deg\" must be in (0, 90), got " +
                   (h->items[k].kind == Json::Number ? std::to_string(h->items[k].num) : std::string("a non-number")));
          ha[k] = h->items[k].num * kPi / 180;
        }
        l = shape == "rect" ? makeRectLight(d, up, ha, {0, 0, 0}) : makeEllipseLight(d, up, ha, {0, 0, 0});
      } else {
        r.fail("unknown \"shape\" \"" + shape + "\" (accepted: cap, polygon, rect, ellipse)");
      }
      if (const Json* t = o.get("texture")) {
        if (t->kind != Json::Object) r.fail("\"texture\" must be an object {width, height, radiance}");
        LightTexture tex;
        const double w = r.number(*t, "width"), hgt = r.number(*t, "height");
        if (!(w >= 1 && w <= 4096 && w == std::floor(w)) || !(hgt >= 1 && hgt <= 4096 && hgt == std::floor(hgt)))
          r.fail("texture \"width\" and \"height\" must be integers in [1, 4096], got " +
                 std::to_string(w) + " x " + std::to_string(hgt));
        tex.width = int(w);
        tex.height = int(hgt);
        const Json* rv = t->get("radiance");
        if (!rv || rv->kind != Json::Array) r.fail("texture needs \"radiance\" (an array of 3 w h numbers)");
        tex.radiance.reserve(rv->items.size());
        for (std::size_t k = 0; k < rv->items.size(); ++k) {
          const Json& x = rv->items[k];
          if (x.kind != Json::Number || !std::isfinite(x.num) || !std::isfinite(float(x.num)) || x.num < 0)
            r.fail("texture \"radiance\" value " + std::to_string(k) + " must be a finite number >= 0");
          tex.radiance.push_back(float(x.num));
        }
        if (shape == "cap" && o.get("up")) {
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
    if (const Json* g = o.get("regions"); g && g->kind == Json::Array)
      for (auto& reg : g->items) {
        if (reg.kind != Json::Array || reg.items.size() != 5) r.fail("\"regions\" entries must be 5 integers");
        std::array<int, 5> q;
        for (int k = 0; k < 5; ++k) {
          // Checked before the conversion: a double outside int's range converts undefinedly.
          const Json& v = reg.items[k];
          if (v.kind != Json::Number || !(v.num >= 0 && v.num <= INT_MAX) || v.num != std::floor(v.num))
            r.fail("\"regions\" entries must be 5 integers in 0.." + std::to_string(INT_MAX));
          q[k] = int(v.num);
        }
        l.regions.push_back(q);
      }
    set.lights.push_back(l);
  }
  if (const Json* a = doc.get("ambient_sh"); a && a->kind == Json::Array) {
    if (a->items.size() != 9) badInput(source + ": \"ambient_sh\" must hold 9 RGB coefficients");
    for (int k = 0; k < 9; ++k) {
      if (a->items[k].kind != Json::Array || a->items[k].items.size() != 3)
        badInput(source + ": \"ambient_sh\" must hold 9 RGB coefficients");
      for (int c = 0; c < 3; ++c) {
        const Json& x = a->items[k].items[c];
        if (x.kind != Json::Number || !std::isfinite(x.num))
          badInput(source + ": \"ambient_sh\" must hold finite numbers");
        set.ambientSH[k][c] = float(x.num);
      }
    }
    const Json* flag = doc.get("ambient");
    set.hasAmbient = !flag || flag->kind != Json::Bool || flag->b;
  }
  // The pre-integrated irradiance map (LightSet::ambientMap); without it the SH9 above shades.
  if (const Json* a = doc.get("ambient_map")) {
    if (a->kind != Json::Object)
      badInput(source + ": \"ambient_map\" must be an object with width, height, irradiance");
    auto size = [&](const char* field) {
      const Json* v = a->get(field);
      if (!v || v->kind != Json::Number || !(v->num >= 1 && v->num <= 1024) ||
          v->num != std::floor(v->num))
        badInput(source + ": \"ambient_map." + field + "\" must be an integer in 1..1024" +
                 (v && v->kind == Json::Number ? ", got " + std::to_string(v->num) : ""));
      return int(v->num);
    };
    AmbientMap m;
    m.width = size("width");
    m.height = size("height");
    const Json* e = a->get("irradiance");
    const std::size_t want = std::size_t(m.width) * m.height * 3;
    if (!e || e->kind != Json::Array || e->items.size() != want)
      badInput(source + ": \"ambient_map.irradiance\" must hold width * height * 3 = " +
               std::to_string(want) + " numbers" +
               (e && e->kind == Json::Array ? ", got " + std::to_string(e->items.size()) : ""));
    m.rgb.resize(want);
    for (std::size_t i = 0; i < want; ++i) {
      const Json& x = e->items[i];
      if (x.kind != Json::Number || !std::isfinite(x.num) || !std::isfinite(float(x.num)))
        badInput(source + ": \"ambient_map.irradiance\" must hold finite numbers (entry " +
                 std::to_string(i) + ")");
      m.rgb[i] = float(x.num);
    }
    set.ambientMap = std::move(m);
    const Json* flag = doc.get("ambient");
    set.hasAmbient = !flag || flag->kind != Json::Bool || flag->b;
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

std::string LightSet::toJson() const {
  std::ostringstream o;
  o.precision(9);
  o << "{\n  \"method\": \"" << method << "\",\n  \"face_size\": " << faceSize
    << ",\n  \"count\": " << lights.size() << ",\n  \"lights\": [";
  for (std::size_t i = 0; i < lights.size(); ++i) {
    auto& l = lights[i];
    const bool framed = l.shape == LightShape::Polygon && l.outline != AreaLight::Outline::Vertices;
    const char* shape = !framed ? toString(l.shape) : l.outline == AreaLight::Outline::Rect ? "rect" : "ellipse";
    o << (i ? ",\n" : "\n") << "    {\"shape\": \"" << shape << "\", ";
    if (framed || !l.texture.empty()) {
      // the frame: rects and ellipses load from it; a textured cap keeps its texture's orientation
      const auto up = l.axisV();
      o << "\"up\": [" << up[0] << ", " << up[1] << ", " << up[2] << "], ";
      if (framed)
        o << "\"half_angles_deg\": [" << std::atan(double(l.tanHalf[0])) / kDeg << ", "
          << std::atan(double(l.tanHalf[1])) / kDeg << "], ";
    }
    if (!l.texture.empty()) {
      o << "\"texture\": {\"width\": " << l.texture.width << ", \"height\": " << l.texture.height
        << ", \"radiance\": [";
      for (std::size_t k = 0; k < l.texture.radiance.size(); ++k) o << (k ? ", " : "") << l.texture.radiance[k];
      o << "]}, ";
    }
    if (l.shape == LightShape::Polygon) {
      o << "\"vertices\": [";
      for (std::size_t k = 0; k < l.vertices.size(); ++k)
        o << (k ? ", " : "") << "[" << l.vertices[k][0] << ", " << l.vertices[k][1] << ", "
          << l.vertices[k][2] << "]";
      o << "], ";
    }
    o << "\"direction\": [" << l.direction[0] << ", " << l.direction[1]
      << ", " << l.direction[2] << "], \"half_angle_deg\": " << l.halfAngle() / kDeg
      << ", \"cos_alpha\": " << l.cosAlpha << ", \"solid_angle_sr\": " << l.solidAngle()
      << ", \"radiance\": [" << l.radiance[0] << ", " << l.radiance[1] << ", " << l.radiance[2]
      << "], \"power\": [" << l.power[0] << ", " << l.power[1] << ", " << l.power[2]
      << "], \"regions\": [";
    for (std::size_t r = 0; r < l.regions.size(); ++r) {
      auto& g = l.regions[r];
      o << (r ? ", " : "") << "[" << g[0] << ", " << g[1] << ", " << g[2] << ", " << g[3] << ", "
        << g[4] << "]";
    }
    o << "]}";
  }
  // The ambient residual: 9 RGB SH coefficients of radiance (order in lights.hpp), and its power.
  auto ap = ambientPower();
  o << "\n  ],\n  \"ambient\": " << (hasAmbient ? "true" : "false") << ",\n  \"ambient_sh\": [";
  for (int i = 0; i < 9; ++i)
    o << (i ? ", " : "") << "[" << ambientSH[i][0] << ", " << ambientSH[i][1] << ", "
      << ambientSH[i][2] << "]";
  o << "],\n  \"ambient_power\": [" << ap[0] << ", " << ap[1] << ", " << ap[2] << "]";
  // The pre-integrated irradiance map (lights.hpp AmbientMap), when the set has one.
  if (!ambientMap.empty()) {
    o << ",\n  \"ambient_map\": {\"width\": " << ambientMap.width
      << ", \"height\": " << ambientMap.height << ", \"irradiance\": [";
    for (std::size_t i = 0; i < ambientMap.rgb.size(); ++i)
      o << (i ? (i % 3 ? ", " : ",\n    ") : "") << ambientMap.rgb[i];
    o << "]}";
  }
  o << "\n}\n";
  return o.str();
}

}  // namespace penumbra
