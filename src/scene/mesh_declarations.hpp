// What a mesh file declares, checked against what it holds before any importer sees it: PLY
// element counts against the bytes after the header, GLB lengths against the file, glTF buffer,
// view and accessor sizes against the data behind them. Importers size their allocations from
// these declarations, so a file that lies here costs gigabytes or loops before it fails.
#pragma once
#include <cstdint>
#include <string>

namespace penumbra::detail {

// Throws Error(BadInput) "<path>: <what the file declares> but <what it holds>" for a PLY or
// glTF/GLB file whose declared sizes cannot fit its data, or whose header is cut short. Other
// formats, and anything these checks cannot read, are left to the importer. Returns the size of
// the file in bytes (throws BadInput naming the path when it cannot be opened).
std::uintmax_t checkMeshDeclarations(const std::string& path);

}  // namespace penumbra::detail
