// penumbra command-line interface: devices | render | reference | compare | evaluate | lights.
// CLI11 parses the command line into subcommands; this file maps its outcomes onto penumbra's
// conventions: help and --version on stdout with exit 0; every error (a CLI11 parse error, an
// unknown option or command with a suggestion, a penumbra::Error) as one line on stderr, exit 2.
#include "options.hpp"

#include <penumbra/suggest.hpp>
#include <penumbra/version.hpp>

#include <iostream>

using namespace penumbra;
using namespace penumbra::cli;

namespace {

// Usage asked for (--help) goes to stdout; usage as the answer to a missing command is an error
// and goes to stderr, so that a script capturing stdout never takes it for a result.
void usage(std::ostream& out) {
  out << "penumbra " PENUMBRA_VERSION
         " - soft shadows from area lights and HDR environment maps (OpenCL)\n\n"
         "usage: penumbra COMMAND [options]    (penumbra COMMAND --help for details)\n\n"
         "commands:\n"
         "  devices     list OpenCL devices\n"
         "  render      render a frame or an animation (extracted lights, "
      << toString(RenderOptions{}.shadows)
      << " soft shadows)\n"
         "  reference   ray-traced ground truth with Embree\n"
         "  compare     error metrics of an image against a reference\n"
         "  evaluate    the error budget of a frame against Embree truths\n"
         "  lights      extract area lights from an environment map\n\n"
         "options:\n"
         "  -h, --help  show this help\n"
         "  --version   print penumbra's version\n";
}

struct Command {
  CLI::App* app;
  int (*run)(const Args&);
};

// Every option name of `app` as typed (--size, -s), for suggestions.
std::vector<std::string> optionNames(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::Option* o : app.get_options()) {
    for (const std::string& l : o->get_lnames()) names.push_back("--" + l);
    for (const std::string& s : o->get_snames()) names.push_back("-" + s);
  }
  return names;
}

// What CLI11 left over (allow_extras): an unknown option, or an argument no one takes.
void refuseExtras(const CLI::App& app, const std::vector<std::string>& extras) {
  if (extras.empty()) return;
  const std::string where = app.get_parent() ? app.get_name() + ": " : "";
  for (const std::string& e : extras)
    if (e.size() > 1 && e[0] == '-') {
      const std::string name = e.substr(0, e.find('='));
      std::string hint = didYouMean(name, optionNames(app), "");
      if (hint.empty())
        hint = " (see penumbra" + (app.get_parent() ? " " + app.get_name() : "") + " --help)";
      badInput(where + "unknown option " + name + hint);
    }
  badInput(where + "unexpected argument '" + extras.front() + "'" +
           (app.get_parent() ? " (see penumbra " + app.get_name() + " --help)" : ""));
}

}  // namespace

int main(int argc, char** argv) {
  markMain();
  const std::vector<std::string> command(argv, argv + argc);
  if (argc < 2) {
    usage(std::cerr);
    return 2;
  }
  Registry registry;
  CLI::App root("soft shadows from area lights and HDR environment maps", "penumbra");
  root.formatter(std::make_shared<Formatter>(terminalWidth()));
  // Subcommands copy the help flag when they are added.
  root.set_help_flag("-h,--help", "show this help")->group(kGroupGeneral);
  root.set_version_flag("--version", PENUMBRA_VERSION, "print penumbra's version")
      ->group(kGroupGeneral);
  root.allow_extras();
  root.require_subcommand(0, 1);
  const std::vector<Command> commands = {
      {addDevicesCommand(root, registry), runDevices},
      {addRenderCommand(root, registry), runRender},
      {addReferenceCommand(root, registry), runReference},
      {addCompareCommand(root, registry), runCompare},
      {addEvaluateCommand(root, registry), runEvaluate},
      {addLightsCommand(root, registry), runLights},
  };
  for (const Command& c : commands) {
    c.app->allow_extras();
    c.app->get_help_ptr()->group(kGroupGeneral);
  }
  auto chosen = [&]() -> const Command* {
    for (const Command& c : commands)
      if (c.app->parsed()) return &c;
    return nullptr;
  };

  try {
    try {
      root.parse(argc, argv);
    } catch (const CLI::CallForHelp&) {
      const Command* c = chosen();
      if (c) std::cout << c->app->help();
      else usage(std::cout);
      return 0;
    } catch (const CLI::CallForVersion& e) {
      std::cout << e.what() << "\n";
      return 0;
    } catch (const CLI::ArgumentMismatch& e) {
      // "--lights: 1 required N missing" and the like: the option is named before the colon.
      const std::string what = e.what();
      const Command* c = chosen();
      const std::string where = c ? c->app->get_name() + ": " : "";
      badInput(where + what.substr(0, what.find(':')) + " needs a value");
    } catch (const CLI::ParseError& e) {
      const Command* c = chosen();
      badInput((c ? c->app->get_name() + ": " : std::string()) + e.what());
    }
    const Command* c = chosen();
    const std::vector<std::string> rest = root.remaining();
    if (!c) {
      if (!rest.empty() && rest.front() == "help") {
        // `penumbra help [COMMAND]`
        for (const Command& k : commands)
          if (rest.size() > 1 && k.app->get_name() == rest[1]) {
            std::cout << k.app->help();
            return 0;
          }
        usage(std::cout);
        return 0;
      }
      if (!rest.empty() && rest.front().rfind("-", 0) != 0) {
        std::vector<std::string> names;
        for (const Command& k : commands) names.push_back(k.app->get_name());
        std::string hint = didYouMean(rest.front(), names, "");
        std::cerr << "penumbra: unknown command '" << oneLine(rest.front()) << "'"
                  << (hint.empty() ? " (see penumbra --help)" : hint) << "\n";
        return 2;
      }
      refuseExtras(root, rest);
      usage(std::cerr);
      return 2;
    }
    refuseExtras(root, rest);
    refuseExtras(*c->app, c->app->remaining());
    return c->run(Args(*c->app, registry, command));
  } catch (const Error& e) {
    std::cerr << "penumbra: " << toString(e.kind()) << ": "
              << oneLine(registry.withOptionNames(e.what())) << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "penumbra: internal error: " << oneLine(e.what()) << "\n";
    return 2;
  }
}
