// The shared pieces of the CLI (common.hpp): the option registry and its strict number checks,
// the wrapping help formatter, output checks, progress lines and the outputs' self-description.
#include "common.hpp"

#include <penumbra/version.hpp>

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <locale>
#include <sstream>

namespace penumbra::cli {

namespace fs = std::filesystem;

std::string num(double v) {
  // Whole numbers in full (16777216, not 1.67772e+07), others to 6 significant digits.
  if (std::isfinite(v) && v == std::floor(v) && std::fabs(v) < 1e15)
    return std::to_string(static_cast<long long>(v));
  std::ostringstream o;
  o.imbue(std::locale::classic());
  o << v;
  return o.str();
}

std::string sizeText(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

// ---------------------------------------------------------------------------------------------
// Registry

namespace {

std::string longName(const CLI::Option* o) {
  const auto& names = o->get_lnames();
  return names.empty() ? o->get_name() : names.front();
}

std::string boundsText(const Bounds& b) {
  const bool lo = std::isfinite(b.lo), hi = std::isfinite(b.hi);
  if (lo && hi)
    return "in " + std::string(b.loOpen ? "(" : "[") + num(b.lo) + ", " + num(b.hi) +
           (b.hiOpen ? ")" : "]");
  if (lo) return std::string(b.loOpen ? "> " : ">= ") + num(b.lo);
  if (hi) return std::string(b.hiOpen ? "< " : "<= ") + num(b.hi);
  return "";
}

std::string withDefault(const std::string& what, const std::string& def) {
  if (what.empty()) return def.empty() ? "" : "default " + def;
  return what + (def.empty() ? "" : ", default " + def);
}

}  // namespace

CLI::Option* Registry::add(CLI::App& app, const std::string& names, const std::string& metavar,
                           const std::string& description, const std::string& group,
                           OptionInfo info) {
  CLI::Option* o = info.kind == OptionInfo::Kind::Flag ? app.add_flag(names, description)
                                                        : app.add_option(names, description);
  o->group(group);
  if (info.kind != OptionInfo::Kind::Flag) {
    o->type_name(metavar);
    // As the old parser did: a repeated option takes its last value (`--size 16x9 ... --size 32x18`).
    o->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  }
  options_[{&app, longName(o)}] = std::move(info);
  return o;
}

CLI::Option* Registry::flag(CLI::App& app, const std::string& names, const std::string& help,
                            const std::string& group, std::vector<std::string> fields) {
  OptionInfo info;
  info.kind = OptionInfo::Kind::Flag;
  info.fields = std::move(fields);
  return add(app, names, "", help, group, std::move(info));
}

CLI::Option* Registry::text(CLI::App& app, const std::string& names, const std::string& metavar,
                            const std::string& help, const std::string& def,
                            const std::string& group, std::vector<std::string> fields) {
  OptionInfo info;
  info.kind = OptionInfo::Kind::Text;
  info.fields = std::move(fields);
  const std::string tail = withDefault("", def);
  return add(app, names, metavar, help + (tail.empty() ? "" : " (" + tail + ")"), group,
             std::move(info));
}

CLI::Option* Registry::integer(CLI::App& app, const std::string& names, const std::string& help,
                               long long lo, long long hi, const std::string& def,
                               const std::string& group, std::vector<std::string> fields) {
  OptionInfo info;
  info.kind = OptionInfo::Kind::Integer;
  info.lo = lo;
  info.hi = hi;
  info.fields = std::move(fields);
  const std::string what =
      "integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  return add(app, names, "N", help + " (" + withDefault(what, def) + ")", group, std::move(info));
}

CLI::Option* Registry::real(CLI::App& app, const std::string& names, const std::string& help,
                            Bounds bounds, const std::string& def, const std::string& group,
                            std::vector<std::string> fields) {
  OptionInfo info;
  info.kind = OptionInfo::Kind::Real;
  info.bounds = bounds;
  info.fields = std::move(fields);
  const std::string range = boundsText(bounds);
  const std::string what = "number" + (range.empty() ? "" : " " + range);
  return add(app, names, "X", help + " (" + withDefault(what, def) + ")", group, std::move(info));
}

const OptionInfo& Registry::info(const CLI::App& app, const std::string& name) const {
  const auto it = options_.find({&app, name});
  if (it == options_.end()) throw std::logic_error("penumbra CLI: unregistered option " + name);
  return it->second;
}

std::string Registry::withOptionNames(std::string message) const {
  auto letter = [&](std::size_t i) {
    return i < message.size() &&
           (std::isalnum(static_cast<unsigned char>(message[i])) || message[i] == '_');
  };
  for (const auto& [key, info] : options_)
    for (const std::string& field : info.fields)
      for (std::size_t at = message.find(field); at != std::string::npos;
           at = message.find(field, at + 1)) {
        const std::size_t end = at + field.size();
        // not a part of a longer name (RenderOptions.shadows in RenderOptions.shadowsX, .shadows.y)
        if ((at > 0 && (letter(at - 1) || message[at - 1] == '.')) || letter(end) ||
            (end < message.size() && message[end] == '.' && letter(end + 1)))
          continue;
        message.replace(at, field.size(), "--" + key.second);
      }
  return message;
}

// ---------------------------------------------------------------------------------------------
// Numbers

long long parseInteger(const std::string& option, const std::string& text, long long lo,
                       long long hi) {
  long long v = 0;
  const char* first = text.data();
  const char* last = first + text.size();
  const auto [ptr, ec] = std::from_chars(first, last, v, 10);
  const std::size_t digits0 = text.size() > 0 && text[0] == '-' ? 1 : 0;
  if (text.empty() || ec == std::errc::invalid_argument || ptr != last)
    badInput("--" + option + ": not a decimal integer: '" + text + "'");
  if (text.size() > digits0 + 1 && text[digits0] == '0')
    badInput("--" + option + ": not a decimal integer: '" + text +
             "' (a leading zero is not allowed)");
  if (ec == std::errc::result_out_of_range || v < lo || v > hi)
    badInput("--" + option + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
             "], got " + text);
  return v;
}

double parseReal(const std::string& option, const std::string& text) {
  double v = 0;
  const char* first = text.data();
  const char* last = first + text.size();
  const auto [ptr, ec] = std::from_chars(first, last, v, std::chars_format::general);
  if (text.empty() || ec != std::errc() || ptr != last || !std::isfinite(v) ||
      !std::isfinite(float(v)))
    badInput("--" + option + ": not a finite number: '" + text + "'");
  return v;
}

void parseSize(const std::string& option, const std::string& text, int max, int& w, int& h) {
  const auto x = text.find('x');
  if (x == std::string::npos)
    badInput("--" + option + " must look like WIDTHxHEIGHT, got '" + text + "'");
  w = int(parseInteger(option, text.substr(0, x), 1, max));
  h = int(parseInteger(option, text.substr(x + 1), 1, max));
}

// ---------------------------------------------------------------------------------------------
// Args

namespace {
// An option by its long name, or a positional argument by its name.
const CLI::Option* findOption(const CLI::App& app, const std::string& name) {
  const CLI::Option* o = app.get_option_no_throw("--" + name);
  return o ? o : app.get_option_no_throw(name);
}
}  // namespace

bool Args::has(const std::string& name) const {
  const CLI::Option* o = findOption(app_, name);
  if (!o || o->count() == 0) return false;
  if (o->get_expected_max() > 0 || o->results().empty()) return true;
  // A flag given a value (--rect=false): the last one decides.
  std::string v = o->results().back();
  for (char& c : v) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (v == "true" || v == "1" || v == "yes" || v == "on") return true;
  if (v == "false" || v == "0" || v == "no" || v == "off") return false;
  badInput("--" + name + " is a flag: true or false, got '" + o->results().back() + "'");
}

std::string Args::get(const std::string& name, const std::string& def) const {
  const CLI::Option* o = findOption(app_, name);
  if (!o || o->count() == 0 || o->results().empty()) return def;
  return o->results().back();
}

long long Args::integer(const std::string& name) const {
  const OptionInfo& info = registry_.info(app_, name);
  return parseInteger(name, get(name), info.lo, info.hi);
}

double Args::real(const std::string& name) const {
  const OptionInfo& info = registry_.info(app_, name);
  const std::string text = get(name);
  const double v = parseReal(name, text);
  const Bounds& b = info.bounds;
  const bool below = b.loOpen ? !(v > b.lo) : !(v >= b.lo);
  const bool above = b.hiOpen ? !(v < b.hi) : !(v <= b.hi);
  if (below || above) badInput("--" + name + " must be " + boundsText(b) + ", got " + text);
  return v;
}

std::string Args::commandLine() const {
  std::string line;
  for (const std::string& a : argv_) {
    const bool plain =
        !a.empty() && std::all_of(a.begin(), a.end(), [](char c) {
          return std::isalnum(static_cast<unsigned char>(c)) ||
                 std::string("-_./=:,+@%").find(c) != std::string::npos;
        });
    std::string quoted = "'";
    for (char c : a) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
    quoted += "'";
    line += (line.empty() ? "" : " ") + (plain ? a : quoted);
  }
  return line;
}

ImageText Args::imageText(const std::string& technique) const {
  ImageText text = {{"penumbra:version", PENUMBRA_VERSION}, {"penumbra:command", commandLine()}};
  if (!technique.empty()) text["penumbra:technique"] = technique;
  return text;
}

// ---------------------------------------------------------------------------------------------
// Help

int terminalWidth() {
  int width = 0;
  winsize ws{};
  if (ioctl(STDOUT_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0) width = ws.ws_col;
  if (width == 0)
    if (const char* columns = std::getenv("COLUMNS")) {
      int v = 0;
      const char* end = columns + std::char_traits<char>::length(columns);
      if (std::from_chars(columns, end, v).ptr == end) width = v;
    }
  if (width <= 0) width = 80;
  return std::clamp(width, 60, 160);
}

std::string wrap(const std::string& text, std::size_t indent, std::size_t width,
                 std::size_t used) {
  std::string out;
  std::size_t column = used;
  bool lineHasWord = false;
  const std::string newline = "\n" + std::string(indent, ' ');
  std::istringstream words(text);
  for (std::string word; words >> word;) {
    if (lineHasWord && column + 1 + word.size() > width) {
      out += newline;
      column = indent;
      lineHasWord = false;
    }
    if (lineHasWord) {
      out += ' ';
      ++column;
    }
    // A word longer than a whole line is cut where the line ends.
    while (column + word.size() > width && width > column) {
      out += word.substr(0, width - column) + newline;
      word = word.substr(width - column);
      column = indent;
    }
    out += word;
    column += word.size();
    lineHasWord = true;
  }
  return out;
}

namespace {
constexpr std::size_t kNameColumn = 30;  // where option help starts
}

std::string Formatter::make_option(const CLI::Option* opt, bool isPositional) const {
  std::string left = "  ";
  if (isPositional) {
    left += opt->get_name();
  } else {
    std::string names;
    for (const std::string& s : opt->get_snames()) names += (names.empty() ? "-" : ", -") + s;
    for (const std::string& l : opt->get_lnames()) names += (names.empty() ? "--" : ", --") + l;
    // long-only options line up with the long names of those with a short one
    left += (opt->get_snames().empty() ? "    " : "") + names;
    if (!opt->get_type_name().empty() && opt->get_expected_max() > 0)
      left += " " + opt->get_type_name();
  }
  const std::size_t width = std::size_t(width_);
  std::string line = left;
  if (left.size() + 2 > kNameColumn) {
    line += "\n" + std::string(kNameColumn, ' ');
  } else {
    line += std::string(kNameColumn - left.size(), ' ');
  }
  line += wrap(opt->get_description(), kNameColumn, width, kNameColumn);
  return line + "\n";
}

std::string Formatter::make_help(const CLI::App* app, std::string, CLI::AppFormatMode) const {
  const std::size_t width = std::size_t(width_);
  std::string usage = "usage: penumbra " + app->get_name();
  std::vector<const CLI::Option*> positionals =
      app->get_options([](const CLI::Option* o) { return o->get_positional(); });
  for (const CLI::Option* p : positionals) usage += " " + p->get_name();
  usage += " [options]";
  std::string out = wrap(usage, 4, width, 0) + "\n";
  // Paragraphs of the description are separated by blank lines.
  const std::string description = app->get_description();
  for (std::size_t at = 0; at < description.size();) {
    std::size_t end = description.find("\n\n", at);
    if (end == std::string::npos) end = description.size();
    out += "\n" + wrap(description.substr(at, end - at), 0, width, 0) + "\n";
    at = end + 2;
  }
  if (!positionals.empty()) {
    out += "\narguments:\n";
    for (const CLI::Option* p : positionals) out += make_option(p, true);
  }
  for (const std::string& group : app->get_groups()) {
    std::vector<const CLI::Option*> opts = app->get_options([&](const CLI::Option* o) {
      return o->get_group() == group && o->nonpositional();
    });
    if (group.empty() || opts.empty()) continue;
    out += "\n" + group + ":\n";
    for (const CLI::Option* o : opts) out += make_option(o, false);
  }
  const std::string footer = app->get_footer();
  if (!footer.empty()) out += "\n" + wrap(footer, 0, width, 0) + "\n";
  return out;
}

// ---------------------------------------------------------------------------------------------
// Outputs

void checkOutput(const std::string& path, const std::vector<std::string>& exts,
                 const std::string& option, bool imageFormat) {
  std::string ext = fs::path(path).extension().string();
  for (auto& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (exts.empty()) {
    if (imageFormat && !canWriteImage(path))
      badInput("--" + option + " " + path + ": unsupported extension '" + ext +
               "' (use an image format OpenImageIO writes: .exr, .hdr, .png, .jpg, .tif, ...)");
  } else if (std::find(exts.begin(), exts.end(), ext) == exts.end()) {
    std::string list;
    for (auto& e : exts) list += (list.empty() ? "" : ", ") + e;
    badInput("--" + option + " " + path + ": unsupported extension '" + ext + "' (use " + list +
             ")");
  }
  fs::path dir = fs::path(path).parent_path();
  std::error_code ec;  // a directory the user cannot search is "does not exist" to us, not a crash
  if (!dir.empty() && !fs::is_directory(dir, ec))
    badInput("--" + option + " " + path + ": directory " + dir.string() +
             (ec ? " cannot be read (" + ec.message() + ")" : " does not exist"));
  if (fs::is_directory(path, ec)) badInput("--" + option + " " + path + ": is a directory");
}

void writeTextAtomic(const std::string& path, const std::string& text) {
  fs::path target(path);
  fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  fs::path tmp = dir / ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()));
  {
    std::ofstream f(tmp);
    f << text;
    f.close();
    if (!f) {
      std::error_code ec;
      fs::remove(tmp, ec);
      badInput(path + ": cannot write");
    }
  }
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    badInput(path + ": cannot move into place (" + ec.message() + ")");
  }
}

std::vector<std::string> splitList(const std::string& option, const std::string& text) {
  std::vector<std::string> items;
  std::string cur;
  std::istringstream in(text);
  while (std::getline(in, cur, ',')) items.push_back(cur);
  if (!text.empty() && text.back() == ',') items.push_back("");
  if (items.empty()) items.push_back("");
  for (auto& i : items)
    if (i.empty()) badInput("--" + option + ": empty entry in '" + text + "'");
  return items;
}

std::string framePath(const std::string& out, int i, int frames) {
  fs::path p(out);
  int digits = std::max(4, int(std::to_string(std::max(0, frames - 1)).size()));
  std::string n = std::to_string(i);
  n = std::string(std::size_t(std::max(0, digits - int(n.size()))), '0') + n;
  return (p.parent_path() / (p.stem().string() + "_" + n + p.extension().string())).string();
}

std::string percentText(double v) {
  if (!std::isfinite(v)) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f%%", 100.0 * v);
  return buf;
}

std::string durationText(double s) {
  char buf[32];
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 10) std::snprintf(buf, sizeof buf, "%.1f s", s);
  else if (s < 60) std::snprintf(buf, sizeof buf, "%d s", int(std::lround(s)));
  else if (s < 3600) {
    const long t = std::lround(s);
    std::snprintf(buf, sizeof buf, "%ldm%02lds", t / 60, t % 60);
  } else {
    const long t = std::lround(s / 60);
    std::snprintf(buf, sizeof buf, "%ldh%02ldm", t / 60, t % 60);
  }
  return buf;
}

std::string oneLine(std::string s) {
  for (auto& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// ---------------------------------------------------------------------------------------------
// Progress

namespace {
std::chrono::steady_clock::time_point gMainStart = std::chrono::steady_clock::now();
double gLoaderMs = -1.0;
}  // namespace

void markMain() {
  gMainStart = std::chrono::steady_clock::now();
  // Field 22 of /proc/self/stat: the start time in clock ticks after boot; /proc/uptime: now.
  std::ifstream stat("/proc/self/stat"), uptime("/proc/uptime");
  std::string text;
  double up = 0;
  if (!std::getline(stat, text) || !(uptime >> up)) return;
  std::istringstream rest(text.substr(text.rfind(')') + 2));  // after "pid (comm) "
  std::string field;
  for (int i = 3; i <= 22 && rest >> field; ++i) {
    if (i != 22) continue;
    const long ticks = sysconf(_SC_CLK_TCK);
    if (ticks > 0) gLoaderMs = std::max(0.0, (up - std::stod(field) / double(ticks)) * 1e3);
  }
}

double loaderMs() { return gLoaderMs; }
std::chrono::steady_clock::time_point mainStart() { return gMainStart; }

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

Progress::Progress(std::string label, bool quiet)
    : label_(std::move(label)), quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()) {}

Progress::~Progress() {
  if (quiet_) return;
  // Unwinding from an error: no "100%", only the bar cleared, so the error is the last word.
  if (std::uncaught_exceptions() > 0) {
    if (tty_) std::fprintf(stderr, "\r\033[K");
    return;
  }
  const std::string took = durationText(secondsSince(start_));
  if (tty_)
    std::fprintf(stderr, "\r%s [##########] 100%% in %s\033[K\n", label_.c_str(), took.c_str());
  else
    std::fprintf(stderr, "%s: 100%% in %s\n", label_.c_str(), took.c_str());
}

std::function<void(double)> Progress::callback() {
  return [this](double f) { update(f); };
}

void Progress::update(double f) {
  if (quiet_ || !(f > 0)) return;
  f = std::min(f, 1.0);
  const double elapsed = secondsSince(start_);
  const std::string eta = durationText(elapsed * (1.0 - f) / f);
  if (tty_) {
    const int filled = int(f * 10);
    std::fprintf(stderr, "\r%s [%s%s] %3d%% ETA %s\033[K", label_.c_str(),
                 std::string(std::size_t(filled), '#').c_str(),
                 std::string(std::size_t(10 - filled), '.').c_str(), int(f * 100), eta.c_str());
  } else if (int(f * 10) > lastTenth_ && int(f * 10) < 10) {
    lastTenth_ = int(f * 10);
    std::fprintf(stderr, "%s: %d%% (ETA %s)\n", label_.c_str(), lastTenth_ * 10, eta.c_str());
  }
}

}  // namespace penumbra::cli
