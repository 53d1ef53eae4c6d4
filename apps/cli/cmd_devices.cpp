// `penumbra devices`: the OpenCL devices penumbra can use, with their index.
#include "options.hpp"

#include <iostream>

namespace penumbra::cli {

CLI::App* addDevicesCommand(CLI::App& root, Registry&) {
  CLI::App* app = root.add_subcommand("devices", "list OpenCL devices");
  app->description("Lists the OpenCL devices penumbra can use, with their index (--device or "
                   "$PENUMBRA_DEVICE takes the index or a part of the name).");
  return app;
}

int runDevices(const Args&) {
  for (auto& d : listDevices())
    std::cout << d.index << ": " << d.name << " [" << d.platform << "] " << d.version << ", "
              << (d.globalMemBytes >> 20) << " MiB (" << (d.maxAllocBytes >> 20)
              << " MiB per buffer), max work-group " << d.maxWorkGroupSize
              << (d.fp64 ? ", fp64" : "") << (d.int64Atomics ? ", int64 atomics" : "") << "\n";
  return 0;
}

}  // namespace penumbra::cli
