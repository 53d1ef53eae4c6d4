// The library's JSON as users meet it (issue 16): light sets and reports round-trip quotes,
// backslashes, newlines and non-ASCII text; what JSON does not allow (hex and leading-zero
// numbers, NaN, trailing commas, duplicate keys, a number beyond double's range) is refused with
// the source, line and column; unknown fields are refused with a suggestion; the report holds only
// the option blocks of the technique used; and every number read or written is the same text under
// a German locale (decimal comma, digit grouping) as under the C locale.
#include <gtest/gtest.h>

#include <clocale>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <locale>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <unistd.h>

#include "penumbra/environment.hpp"
#include "penumbra/evaluate.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/reference.hpp"
#include "penumbra/renderer.hpp"
#include "penumbra/scene.hpp"
#include "shadows/shadow_options.hpp"
#include "support/expect_error.hpp"

namespace {

using namespace penumbra;
using penumbra::test::expectBadInput;
using nlohmann::json;
namespace fs = std::filesystem;

// A light set with one cap light, `method` as given.
LightSet oneCap(const std::string& method) {
  LightSet set;
  set.method = method;
  AreaLight l;
  l.direction = {0, 1, 0};
  l.cosAlpha = 0.99f;
  l.setPower({1, 2, 3});
  set.lights.push_back(l);
  return set;
}

// A light set of every kind of light and number, written by hand.
const char* kLightSetText = R"({
  "method": "user", "face_size": 16,
  "lights": [
    {"shape": "rect", "direction": [0.25, 1, -0.5], "up": [0, 0, 1],
     "half_angles_deg": [12.5, 7.25], "radiance": [1.5, 2.25, 0.125]},
    {"direction": [0, 1, 0.1], "half_angle_deg": 4.5, "power": [1234.5, 0.5, 2e-3],
     "regions": [[1, 2, 3, 4, 5]]},
    {"shape": "polygon", "vertices": [[0.1, 1, 0.1], [-0.1, 1, 0.1], [0, 1, -0.1]],
     "radiance": [0.75, 0.75, 0.75]}
  ],
  "ambient_sh": [[0.5, 0.25, 0.125], [0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0],
                 [0, 0, 0], [0, 0, 0], [-0.0625, 1e-7, 1000.5]],
  "ambient_map": {"width": 2, "height": 1, "irradiance": [0.5, 1.25, 2, 1000.5, 3, 4e-5]}
})";

TEST(Json, LightSetMethodRoundTripsEscapesAndUnicode) {
  for (const std::string method :
       {std::string("say \"hi\""), std::string("back\\slash"), std::string("two\nlines"),
        std::string("caf\xc3\xa9"), std::string("tab\tand \x01 control")}) {
    const std::string text = oneCap(method).toJson();
    const json j = json::parse(text);  // valid JSON
    EXPECT_EQ(j["method"], method) << text;
    EXPECT_EQ(lightSetFromJson(text, "round trip").method, method) << text;
  }
  // \u escapes read as the character they name (the hand parser gave "cafu00e9").
  const LightSet set = lightSetFromJson(
      R"({"method": "caf\u00e9 \"q\" \\ \n \ud83d\ude00", "lights": []})", "escapes.json");
  EXPECT_EQ(set.method, "caf\xc3\xa9 \"q\" \\ \n \xf0\x9f\x98\x80");
  // Text that is not UTF-8 (a Latin-1 name set in code) still gives valid JSON, with U+FFFD.
  const json latin = json::parse(oneCap("caf\xe9").toJson());
  EXPECT_EQ(latin["method"], "caf\xef\xbf\xbd");
}

TEST(Json, ReportNamesTheEnvironmentExactly) {
  Environment env;
  env.source = "stu\"dio.exr";
  LightSet lights = oneCap("caf\xc3\xa9");
  RenderOptions opt;
  Frame f;
  f.stats = {{"a\\b", 1.5}};
  ReportInfo info;
  info.command = {"penumbra", "render", "--env", "stu\"dio.exr"};
  info.environment = "stu\"dio.exr";
  const json j = json::parse(renderReportJson("dev \"0\"", lights, env, opt, f, info));
  EXPECT_EQ(j["environment"], "stu\"dio.exr");
  EXPECT_EQ(j["inputs"]["environment"], "stu\"dio.exr");
  EXPECT_EQ(j["command"][3], "stu\"dio.exr");
  EXPECT_EQ(j["device"], "dev \"0\"");
  EXPECT_EQ(j["extract"], "caf\xc3\xa9");
  EXPECT_EQ(j["stats"]["a\\b"].get<double>(), 1.5);
}

// What JSON does not allow is refused with the source, and a position.
TEST(Json, RefusesWhatJsonDoesNotAllow) {
  const char* bad[] = {
      R"({"lights": [], "face_size": 0x5})",
      R"({"lights": [], "face_size": 01})",
      R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": NaN, "radiance": [1, 1, 1]}]})",
      R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": 5, "radiance": [1, 1, 1],}]})",
      R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": 5, "radiance": [1, 1, 1]},]})",
      R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": 5, "radiance": [1, 1, 1e999]}]})",
      R"({"lights": [], "lights": []})",
      R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": 5, "half_angle_deg": 6, "radiance": [1, 1, 1]}]})",
      R"({"lights": [], /* a comment */ "method": "x"})",
      "{\"lights\": [], \"method\": \"caf\xe9\"}",  // not UTF-8
  };
  for (const char* text : bad)
    expectBadInput([&] { lightSetFromJson(text, "user.json"); },
                   {"user.json: invalid JSON at line 1, column "});
  // The duplicate is named, the number overflow too.
  expectBadInput([&] { lightSetFromJson(bad[6], "user.json"); }, "duplicate key \"lights\"");
  expectBadInput([&] { lightSetFromJson(bad[5], "user.json"); }, "1e999");
  // Nesting is bounded (64 levels), so a hostile file cannot exhaust the stack.
  const std::string deep = "{\"lights\": " + std::string(100, '[') + std::string(100, ']') + "}";
  expectBadInput([&] { lightSetFromJson(deep, "deep.json"); },
                 {"deep.json: invalid JSON at line 1", "nested too deeply"});
}

// Line and column count from 1, as an editor shows them: the first character nlohmann could not
// take, the end of a duplicate key.
TEST(Json, ParseErrorsGiveLineAndColumn) {
  expectBadInput([&] { lightSetFromJson("{\n  \"lights\": [,]\n}", "pos.json"); },
                 "pos.json: invalid JSON at line 2, column 14: ");
  expectBadInput([&] { lightSetFromJson(R"({"lights": [], "lights": []})", "dup.json"); },
                 "dup.json: invalid JSON at line 1, column 23: duplicate key \"lights\"");
  expectBadInput([&] { lightSetFromJson("{\"lights\": [\n\n  {\"power\": [1, 1, 1]},\n  tru]}", "lit.json"); },
                 "lit.json: invalid JSON at line 4, column 6: ");
}

TEST(Json, UnknownFieldsAreRefusedWithASuggestion) {
  const std::string light = R"({"direction": [0, 1, 0], "half_angle_deg": 5, "powr": [1, 1, 1]})";
  try {
    lightSetFromJson("{\"lights\": [" + light + "]}", "typo.json");
    ADD_FAILURE() << "accepted \"powr\"";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    EXPECT_STREQ(e.what(), "typo.json: light 0: unknown field \"powr\" (did you mean \"power\"?)");
  }
  expectBadInput([] { lightSetFromJson(R"({"lihgts": []})", "top.json"); },
                 "top.json: unknown field \"lihgts\" in the light set (did you mean \"lights\"?)");
  expectBadInput(
      [] {
        lightSetFromJson(R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": 5,
            "texture": {"widht": 1, "height": 1, "radiance": [1, 1, 1]}}]})", "tex.json");
      },
      "tex.json: light 0: unknown field \"widht\" in \"texture\" (did you mean \"width\"?)");
  expectBadInput(
      [] {
        lightSetFromJson(R"({"lights": [], "ambient_map": {"width": 1, "height": 1,
            "irradiance": [0, 0, 0], "gamma": 2}})", "map.json");
      },
      "map.json: unknown field \"gamma\" in \"ambient_map\"");
  // Nothing close: no suggestion.
  try {
    lightSetFromJson(R"({"lights": [], "zzzzzz": 1})", "far.json");
    ADD_FAILURE() << "accepted \"zzzzzz\"";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).find("did you mean"), std::string::npos) << e.what();
  }
  // What penumbra writes loads back, its derived fields and `lights`' sanitized_pixels included.
  json written = json::parse(lightSetFromJson(kLightSetText, "all.json").toJson());
  written["sanitized_pixels"] = 3;
  for (const char* derived : {"count", "ambient_power"}) EXPECT_TRUE(written.contains(derived));
  EXPECT_TRUE(written["lights"][0].contains("solid_angle_sr"));
  EXPECT_EQ(lightSetFromJson(written.dump(), "written.json").lights.size(), 3u);
}

// A field of the wrong type is an error naming it, not silently ignored.
TEST(Json, WrongTypesAreRefused) {
  expectBadInput([] { lightSetFromJson(R"({"lights": [], "method": 5})", "m.json"); },
                 {"m.json", "\"method\""});
  expectBadInput([] { lightSetFromJson(R"({"lights": [], "face_size": "16"})", "f.json"); },
                 {"f.json", "\"face_size\""});
  expectBadInput([] { lightSetFromJson(R"({"lights": [], "face_size": 1.5})", "f.json"); },
                 {"f.json", "\"face_size\""});
  expectBadInput([] { lightSetFromJson(R"({"lights": [], "ambient": "yes"})", "a.json"); },
                 {"a.json", "\"ambient\""});
  expectBadInput(
      [] {
        lightSetFromJson(R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": 5,
            "radiance": [1, 1, 1], "regions": 3}]})", "r.json");
      },
      {"r.json: light 0", "\"regions\""});
}

// Only the shared "shadow" block and the blocks of the technique used (auto: those it picked).
TEST(Json, ReportHoldsOnlyTheOptionsOfTheTechniqueUsed) {
  const std::vector<std::string> all = {"mssm", "cssm", "pcss", "brute", "bitmask", "area_approx", "auto"};
  auto blocks = [&](ShadowTechnique t, const Frame& f) {
    RenderOptions opt;
    opt.shadows = t;
    const json j = json::parse(renderReportJson("dev", LightSet{}, Environment{}, opt, f));
    EXPECT_TRUE(j.contains("shadow")) << toString(t);
    std::vector<std::string> found;
    for (const std::string& b : all)
      if (j.contains(b)) found.push_back(b);
    return found;
  };
  const Frame none;
  using V = std::vector<std::string>;
  EXPECT_EQ(blocks(ShadowTechnique::None, none), V{});
  EXPECT_EQ(blocks(ShadowTechnique::Hard, none), V{});
  EXPECT_EQ(blocks(ShadowTechnique::MSSM4, none), V{"mssm"});
  EXPECT_EQ(blocks(ShadowTechnique::MSSM6, none), V{"mssm"});
  EXPECT_EQ(blocks(ShadowTechnique::CSSM, none), V{"cssm"});
  EXPECT_EQ(blocks(ShadowTechnique::PCSS, none), V{"pcss"});
  EXPECT_EQ(blocks(ShadowTechnique::Brute, none), V{"brute"});
  EXPECT_EQ(blocks(ShadowTechnique::Bitmask, none), V{"bitmask"});
  EXPECT_EQ(blocks(ShadowTechnique::BitmaskHard, none), V{"bitmask"});
  EXPECT_EQ(blocks(ShadowTechnique::AreaApprox, none), V{"area_approx"});
  EXPECT_EQ(blocks(ShadowTechnique::Auto, none), V{"auto"});
  Frame picked;  // auto's per-light choices, as src/shadows/auto.cpp reports them
  picked.stats = {{"auto/light_0", double(int(ShadowTechnique::Bitmask))},
                  {"auto/light_1", double(int(ShadowTechnique::Hard))},
                  {"auto/light_2", double(int(ShadowTechnique::MSSM4))}};
  EXPECT_EQ(blocks(ShadowTechnique::Auto, picked), (V{"mssm", "bitmask", "auto"}));
}

// ---------------------------------------------------------------------------------------------
// Locale independence.

// A decimal comma and digit grouping by thousands ("1.234,5"), as a German user's C++ locale has.
struct CommaDecimal : std::numpunct<char> {
  char do_decimal_point() const override { return ','; }
  char do_thousands_sep() const override { return '.'; }
  std::string do_grouping() const override { return "\3"; }
};

// Every text the library writes with numbers in it, and what it reads back from them.
std::vector<std::string> numberTexts() {
  std::vector<std::string> out;
  const LightSet set = lightSetFromJson(kLightSetText, "locale.json");
  out.push_back(set.toJson());
  Environment env;
  env.source = "builtin";
  RenderOptions opt;
  opt.shadows = ShadowTechnique::MSSM4;
  opt.mssm.momentBias = 3.5e-5f;
  opt.shadow.depthBias = 0.0125f;
  Frame f;
  f.stats = {{"count", 1234567.0}, {"fraction", 1234.5}};
  f.timingsMs = {{"total", 1234.25}};
  out.push_back(renderReportJson("dev", set, env, opt, f));
  ImageMetrics m;
  m.rmse = 1234.5;
  m.relativeRmse = 0.015625;
  m.psnr = 42.25;
  m.maxAbsError = 2.5;
  m.pixels = 1234567;
  out.push_back(toJson(m));
  ErrorBudget b;
  b.shadows = "mssm4";
  b.lights = 12;
  b.frameMs = 1234.5;
  b.total.relativeRmse = 0.0525;
  b.total.noise = 0.0125;
  b.cross = 1.5e-4;
  b.biasTotal = {0.0125, -0.25, 0};
  b.geometryPixels = 123456;
  b.penumbraLow = 0.025;
  b.penumbraHigh = 0.975;
  out.push_back(toJson(b));
  out.push_back(toText(b));
  // Numbers read: a camera, and numbers in messages.
  const Camera c = parseCamera("0.5, 1.25, -2.5, 0, 0.125, 0, 45.5");
  out.push_back(json{c.eye[0], c.eye[1], c.eye[2], c.target[1], c.fovyDeg}.dump());
  for (const char* text :
       {R"({"lights": [{"shape": "rect", "direction": [0, 1, 0], "up": [0, 0, 1],
            "half_angles_deg": [95.5, 10], "radiance": [1, 1, 1]}]})",
        R"({"lights": [], "ambient_map": {"width": 1234.5, "height": 1, "irradiance": []}})"}) {
    try {
      lightSetFromJson(text, "bad.json");
      out.push_back("accepted");
    } catch (const Error& e) {
      out.push_back(e.what());
    }
  }
  try {
    detail::badOption("RenderOptions.shadow.depthBias", "be small", 1234.5);
  } catch (const Error& e) {
    out.push_back(e.what());
  }
  return out;
}

// Sets the C locale (strtod, printf) to a compiled de_DE.UTF-8 and the C++ global locale (streams)
// to a decimal comma with grouping, and puts both back when it goes.
class GermanLocale {
 public:
  explicit GermanLocale(const fs::path& dir) : cxx_(std::locale()) {
    const char* c = std::setlocale(LC_ALL, nullptr);
    c_ = c ? c : "C";
    if (const char* p = std::getenv("LOCPATH")) locpath_ = p, hadLocpath_ = true;
    setenv("LOCPATH", dir.c_str(), 1);
    ok_ = std::setlocale(LC_ALL, "de_DE.UTF-8") != nullptr;
    std::locale::global(std::locale(std::locale::classic(), new CommaDecimal));
  }
  ~GermanLocale() {
    std::locale::global(cxx_);
    std::setlocale(LC_ALL, c_.c_str());
    if (hadLocpath_)
      setenv("LOCPATH", locpath_.c_str(), 1);
    else
      unsetenv("LOCPATH");
  }
  bool ok() const { return ok_; }

 private:
  std::locale cxx_;
  std::string c_, locpath_;
  bool hadLocpath_ = false, ok_ = false;
};

TEST(Json, NumbersIgnoreTheLocale) {
  const std::vector<std::string> c = numberTexts();
  // The reads above succeeded under the C locale (no "accepted" where a refusal is due).
  EXPECT_NE(c[5].find("0.5"), std::string::npos) << c[5];
  EXPECT_NE(c[6].find("got 95.5"), std::string::npos) << c[6];
  EXPECT_NE(c[7].find("got 1234.5"), std::string::npos) << c[7];
  EXPECT_NE(c[8].find("got 1234.5"), std::string::npos) << c[8];

  // de_DE.UTF-8 compiled for this test (the locales package; a fresh system has only C).
  const fs::path dir = fs::path(testing::TempDir()) / ("penumbra_json_locale_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string cmd = "localedef -i de_DE -f UTF-8 '" + (dir / "de_DE.UTF-8").string() + "' 2>&1";
  const int rc = std::system(cmd.c_str());
  std::vector<std::string> de;
  {
    GermanLocale german(dir);
    ASSERT_TRUE(german.ok()) << "setlocale(de_DE.UTF-8) failed; `" << cmd << "` returned " << rc;
    // Both locales are in effect: printf and streams write decimal commas.
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f", 1234.5);
    ASSERT_STREQ(buf, "1234,5");
    std::ostringstream s;
    s << 1234.5;
    ASSERT_EQ(s.str(), "1.234,5");
    de = numberTexts();
  }
  std::error_code ec;
  fs::remove_all(dir, ec);
  ASSERT_EQ(de.size(), c.size());
  for (std::size_t i = 0; i < c.size(); ++i) EXPECT_EQ(de[i], c[i]) << "text " << i;
}

}  // namespace
