// What every `penumbra` command shares: the registry of options (CLI11 parses the command line,
// the registry remembers each option's kind, range and the library fields it sets), strict
// locale-free number parsing, the help formatter that wraps to the terminal, output checks,
// progress lines and the self-description written into every output.
#pragma once

#include <penumbra/penumbra.hpp>

#include <CLI/CLI.hpp>

#include <chrono>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::cli {

// Option groups, in the order help lists them.
inline const std::string kGroupGeneral = "General";
inline const std::string kGroupScene = "Scene";
inline const std::string kGroupLights = "Lights";
inline const std::string kGroupShadows = "Shadows";
inline const std::string kGroupAnimation = "Animation";
inline const std::string kGroupSampling = "Sampling";
inline const std::string kGroupOutput = "Output";
inline const std::string kGroupAdvanced = "Advanced";

// A default as help prints it: 6 significant digits (3e-05, 0.002, 27), whatever the locale.
std::string num(double v);
std::string sizeText(int w, int h);

// Bounds of a real-valued option; open ends exclude the bound.
struct Bounds {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool loOpen = false, hiOpen = false;
  static Bounds positive() { return {0.0, std::numeric_limits<double>::infinity(), true, false}; }
  static Bounds nonNegative() { return {0.0, std::numeric_limits<double>::infinity(), false, false}; }
  static Bounds any() { return {}; }
};

struct OptionInfo {
  enum class Kind { Flag, Text, Integer, Real };
  Kind kind = Kind::Text;
  long long lo = 0, hi = 0;  // Integer
  Bounds bounds;             // Real
  // The library fields the option sets, as its errors name them ("RenderOptions.cssm.order"):
  // an error naming one is reported with the option instead.
  std::vector<std::string> fields;
};

// Adds options to CLI11 apps with their help text (type, range, default) composed in one place,
// and remembers how each one's value is checked. Every value is kept as the text the user typed
// and read through Args, which checks it strictly.
class Registry {
 public:
  CLI::Option* flag(CLI::App& app, const std::string& names, const std::string& help,
                    const std::string& group, std::vector<std::string> fields = {});
  // def: the default as shown ("" when there is none to show).
  CLI::Option* text(CLI::App& app, const std::string& names, const std::string& metavar,
                    const std::string& help, const std::string& def, const std::string& group,
                    std::vector<std::string> fields = {});
  CLI::Option* integer(CLI::App& app, const std::string& names, const std::string& help,
                       long long lo, long long hi, const std::string& def,
                       const std::string& group, std::vector<std::string> fields = {});
  CLI::Option* real(CLI::App& app, const std::string& names, const std::string& help,
                    Bounds bounds, const std::string& def, const std::string& group,
                    std::vector<std::string> fields = {});

  // The option `name` (long name, no dashes) of `app`; throws if it was never registered.
  const OptionInfo& info(const CLI::App& app, const std::string& name) const;

  // A library error names the options field at fault ("RenderOptions.cssm.order must be in [1,
  // 32], got 40"); the user typed an option. Each field an option sets is replaced by that option
  // ("--cssm-order must be ..."); fields no option sets stay as they are.
  std::string withOptionNames(std::string message) const;

 private:
  CLI::Option* add(CLI::App& app, const std::string& names, const std::string& metavar,
                   const std::string& description, const std::string& group, OptionInfo info);
  std::map<std::pair<const CLI::App*, std::string>, OptionInfo> options_;
};

// Strict decimal numbers (std::from_chars: no locale, no hex, no octal, no leading '+').
// An integer with a leading zero ("010") is refused rather than read as 10 or as octal 8.
long long parseInteger(const std::string& option, const std::string& text, long long lo,
                       long long hi);
// A finite number; "nan", "inf", "0x1p3", "1,5" and out-of-range values are refused.
double parseReal(const std::string& option, const std::string& text);
// WIDTHxHEIGHT, each in [1, max].
void parseSize(const std::string& option, const std::string& text, int max, int& w, int& h);

// One parsed command: the values the user gave, read through the registry's checks.
class Args {
 public:
  Args(const CLI::App& app, const Registry& registry, std::vector<std::string> argv)
      : app_(app), registry_(registry), argv_(std::move(argv)) {}
  bool has(const std::string& name) const;
  std::string get(const std::string& name, const std::string& def = "") const;
  // The value of an Integer or Real option, checked against its registered range.
  long long integer(const std::string& name) const;
  double real(const std::string& name) const;
  bool quiet() const { return has("quiet"); }
  const std::vector<std::string>& argv() const { return argv_; }
  // argv joined with POSIX shell quoting: what a user would paste to run it again.
  std::string commandLine() const;
  // The metadata every image the command writes carries; technique "" leaves it out.
  ImageText imageText(const std::string& technique) const;

 private:
  const CLI::App& app_;
  const Registry& registry_;
  std::vector<std::string> argv_;
};

// The help's width: the terminal's (TIOCGWINSZ on stdout), else $COLUMNS, else 80; 60..160.
int terminalWidth();

// Help in paragraphs wrapped to a width: "usage: penumbra CMD [options]", the description, then
// each group with its options, names on the left and their help (type, range, default) wrapped
// beside them. CLI11 2.1.2 does not wrap.
class Formatter : public CLI::Formatter {
 public:
  explicit Formatter(int width) : width_(width) {}
  std::string make_help(const CLI::App* app, std::string name,
                        CLI::AppFormatMode mode) const override;
  std::string make_option(const CLI::Option* opt, bool isPositional) const override;

 private:
  int width_;
};

// `text` broken into lines of at most `width` characters, each after `indent` spaces except the
// first, which continues a line that already holds `used` characters.
std::string wrap(const std::string& text, std::size_t indent, std::size_t width,
                 std::size_t used);

// Refuses an output path before any work is done: a known extension (the given ones, or any
// format writeImage can write when `exts` is empty), an existing directory, not a directory itself.
// imageFormat false leaves out the image-format question (for a format other than PNG it loads
// the OpenImageIO module: render and reference ask it after the scene is read, see cmd_render).
void checkOutput(const std::string& path, const std::vector<std::string>& exts,
                 const std::string& option, bool imageFormat = true);
// Text files are written like images: to a temporary file, then renamed into place.
void writeTextAtomic(const std::string& path, const std::string& text);
// Comma-separated list, every entry non-empty.
std::vector<std::string> splitList(const std::string& option, const std::string& text);
// Frame i of an animation written to `out`: STEM_iiii.EXT, at least 4 digits.
std::string framePath(const std::string& out, int i, int frames);
// A relative figure as a percentage, "n/a" when not finite (a noise estimate from 1 spp).
std::string percentText(double v);
// A duration for people: "0.4 s", "12 s", "3m05s", "1h02m".
std::string durationText(double seconds);
// Error output is one line whatever the message holds (a path with a line break, a build log).
std::string oneLine(std::string s);

// Progress of a long job on stderr. A terminal gets a bar rewritten in place
// ("reference [#####.....]  43% ETA 1m12s"); a log gets a line per 10% ("reference: 50% (ETA
// 12 s)"), so a long run under a script still shows that it advances. The last line,
// "LABEL: 100% in N s", is written when the object goes out of scope. quiet: nothing at all.
class Progress {
 public:
  Progress(std::string label, bool quiet);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;
  std::function<void(double)> callback();

 private:
  void update(double fraction);
  std::string label_;
  bool quiet_, tty_;
  int lastTenth_ = 0;
  std::chrono::steady_clock::time_point start_;
};

// Seconds since `start`.
double secondsSince(std::chrono::steady_clock::time_point start);

// Start-up as the report states it: the milliseconds from the process's start (the kernel's
// record in /proc/self/stat, 10 ms ticks) to main(), which is the dynamic loader and static
// constructors (about 265 shared libraries, almost all OpenImageIO's); -1 where /proc is not
// readable. markMain() records when main() began.
void markMain();
double loaderMs();
std::chrono::steady_clock::time_point mainStart();

}  // namespace penumbra::cli
