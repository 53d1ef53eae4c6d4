// Declared-size checks for PLY and glTF/GLB files (see mesh_declarations.hpp). The formats'
// layouts are from their specifications: PLY (Turk, 1994: an ASCII header of element and
// property lines ending in "end_header", then the data) and glTF 2.0 (Khronos: a 12-byte GLB
// header, then 8-byte chunk headers, JSON first; buffers, bufferViews and accessors in the JSON).
#include "scene/mesh_declarations.hpp"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "penumbra/error.hpp"

namespace penumbra::detail {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr std::size_t kMaxPlyHeader = 1u << 20;  // no real PLY header comes close

std::string readPrefix(const std::string& path, std::size_t n) {
  std::ifstream in(path, std::ios::binary);
  std::string s(n, '\0');
  in.read(s.data(), static_cast<std::streamsize>(n));
  s.resize(static_cast<std::size_t>(std::max<std::streamsize>(in.gcount(), 0)));
  return s;
}

std::string lowerExtension(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

// ----- PLY --------------------------------------------------------------------------------------

// Bytes of one PLY scalar type; 0 for a name the format does not define.
std::uintmax_t plyTypeBytes(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" ||
      t == "float32")
    return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

struct PlyElement {
  std::string name;
  std::uintmax_t count = 0;
  std::uintmax_t minBytes = 0;  // the least one element can take in this file's format
};

void checkPly(const std::string& path, std::uintmax_t fileBytes) {
  const std::string head = readPrefix(path, kMaxPlyHeader);
  std::size_t end = std::string::npos;
  // "end_header" must start a line and end it.
  for (std::size_t at = head.find("end_header"); at != std::string::npos;
       at = head.find("end_header", at + 1)) {
    const bool lineStart = at > 0 && head[at - 1] == '\n';
    const std::size_t after = at + 10;
    if (!lineStart) continue;
    if (after < head.size() && head[after] == '\n') end = after + 1;
    if (after + 1 < head.size() && head[after] == '\r' && head[after + 1] == '\n') end = after + 2;
    if (end != std::string::npos) break;
  }
  if (end == std::string::npos) {
    if (head.size() >= kMaxPlyHeader)
      badInput(path + ": the PLY header has no end_header line in its first " +
               std::to_string(kMaxPlyHeader >> 20) + " MiB");
    badInput(path + ": the PLY header is cut short (no end_header line in the file's " +
             std::to_string(fileBytes) + " bytes)");
  }
  std::istringstream lines(head.substr(0, end));
  std::string line;
  bool ascii = true;
  std::vector<PlyElement> elements;
  while (std::getline(lines, line)) {
    std::istringstream words(line);
    std::string key;
    words >> key;
    if (key == "format") {
      std::string f;
      words >> f;
      ascii = f == "ascii";
    } else if (key == "element") {
      PlyElement e;
      std::string count;
      words >> e.name >> count;
      if (count.empty() || count.size() > 19 ||
          !std::all_of(count.begin(), count.end(), [](char c) { return c >= '0' && c <= '9'; }))
        badInput(path + ": the PLY header's element '" + e.name + "' has count '" + count +
                 "', which is not a count");
      e.count = std::stoull(count);
      elements.push_back(e);
    } else if (key == "property" && !elements.empty()) {
      std::string type;
      words >> type;
      // An ASCII value is at least a digit and a separator. A binary list costs at least its
      // count; a type the format does not define is left to the importer (1 byte here).
      std::uintmax_t bytes = 2;
      if (!ascii) {
        std::string sized = type;
        if (type == "list") words >> sized;
        bytes = std::max<std::uintmax_t>(1, plyTypeBytes(sized));
      }
      elements.back().minBytes += bytes;
    }
  }
  const std::uintmax_t data = fileBytes - std::min<std::uintmax_t>(fileBytes, end);
  std::uintmax_t need = 0;
  for (const PlyElement& e : elements) {
    const std::uintmax_t per = std::max<std::uintmax_t>(1, e.minBytes);
    // An ASCII file may omit the separator after its very last value: one byte of slack.
    const bool over = e.count > (data + 1 - std::min(need, data + 1)) / per;
    if (over)
      badInput(path + ": the PLY header declares " + std::to_string(e.count) + " '" + e.name +
               "' elements, at least " + std::to_string(per) + " bytes each, but only " +
               std::to_string(data) + " bytes of data follow the header");
    need += e.count * per;
  }
}

// ----- glTF / GLB -------------------------------------------------------------------------------

std::uint32_t le32(const std::string& s, std::size_t at) {
  std::uint32_t v = 0;
  for (int k = 3; k >= 0; --k) v = (v << 8) | static_cast<unsigned char>(s[at + k]);
  return v;
}

// A non-negative integer field, or `fallback` when it is absent or not one (the importer then
// reports the file's own problem).
std::uintmax_t sizeField(const Json& o, const char* key, std::uintmax_t fallback) {
  if (!o.is_object()) return fallback;
  const auto it = o.find(key);
  if (it == o.end() || !it->is_number_unsigned()) return fallback;
  return it->get<std::uintmax_t>();
}

std::uintmax_t componentBytes(std::uintmax_t componentType) {
  switch (componentType) {
    case 5120: case 5121: return 1;  // BYTE, UNSIGNED_BYTE
    case 5122: case 5123: return 2;  // SHORT, UNSIGNED_SHORT
    case 5125: case 5126: return 4;  // UNSIGNED_INT, FLOAT
    default: return 0;
  }
}

std::uintmax_t componentCount(const std::string& type) {
  if (type == "SCALAR") return 1;
  if (type == "VEC2") return 2;
  if (type == "VEC3") return 3;
  if (type == "VEC4" || type == "MAT2") return 4;
  if (type == "MAT3") return 9;
  if (type == "MAT4") return 16;
  return 0;
}

// The bytes behind buffer i: the GLB's BIN chunk, a base64 data URI or a file beside the glTF.
// Returns max() when it cannot tell (the importer then reports what is missing).
std::uintmax_t bufferAvailable(const std::string& path, const Json& buffer, std::size_t index,
                               std::uintmax_t binChunk, bool glb) {
  const auto uri = buffer.is_object() ? buffer.find("uri") : Json::const_iterator{};
  const std::uintmax_t unknown = std::numeric_limits<std::uintmax_t>::max();
  if (!buffer.is_object() || uri == buffer.end()) return glb && index == 0 ? binChunk : unknown;
  if (!uri->is_string()) return unknown;
  const std::string u = uri->get<std::string>();
  if (u.rfind("data:", 0) == 0) {
    const auto comma = u.find(',');
    if (comma == std::string::npos || u.find(";base64", 0) > comma) return unknown;
    return (u.size() - comma - 1) / 4 * 3 + 3;
  }
  if (u.find("://") != std::string::npos || u.find('%') != std::string::npos) return unknown;
  std::error_code ec;
  const fs::path file = fs::path(path).parent_path() / u;
  const std::uintmax_t size = fs::file_size(file, ec);
  return ec ? unknown : size;
}

void checkGltfJson(const std::string& path, const std::string& text, std::uintmax_t binChunk,
                   bool glb) {
  Json doc;
  try {
    doc = Json::parse(text);
  } catch (const Json::parse_error& e) {
    badInput(path + ": the glTF JSON cannot be parsed (" + e.what() + ")");
  }
  const auto arrayOf = [&](const char* key) -> const Json* {
    const auto it = doc.is_object() ? doc.find(key) : doc.end();
    return it != doc.end() && it->is_array() ? &*it : nullptr;
  };
  std::vector<std::uintmax_t> bufferBytes;
  if (const Json* buffers = arrayOf("buffers")) {
    for (std::size_t i = 0; i < buffers->size(); ++i) {
      const std::uintmax_t declared = sizeField((*buffers)[i], "byteLength", 0);
      const std::uintmax_t held = bufferAvailable(path, (*buffers)[i], i, binChunk, glb);
      if (declared > held)
        badInput(path + ": glTF buffer " + std::to_string(i) + " declares " +
                 std::to_string(declared) + " bytes but its data holds " + std::to_string(held));
      bufferBytes.push_back(declared);
    }
  }
  std::vector<std::uintmax_t> viewBytes;
  if (const Json* views = arrayOf("bufferViews")) {
    for (std::size_t i = 0; i < views->size(); ++i) {
      const Json& v = (*views)[i];
      const std::uintmax_t buffer = sizeField(v, "buffer", 0);
      const std::uintmax_t offset = sizeField(v, "byteOffset", 0);
      const std::uintmax_t length = sizeField(v, "byteLength", 0);
      if (buffer < bufferBytes.size() &&
          (offset > bufferBytes[buffer] || length > bufferBytes[buffer] - offset))
        badInput(path + ": glTF bufferView " + std::to_string(i) + " spans bytes " +
                 std::to_string(offset) + ".." + std::to_string(offset + length) + " of buffer " +
                 std::to_string(buffer) + ", which has " + std::to_string(bufferBytes[buffer]));
      viewBytes.push_back(length);
    }
  }
  if (const Json* accessors = arrayOf("accessors")) {
    for (std::size_t i = 0; i < accessors->size(); ++i) {
      const Json& a = (*accessors)[i];
      const std::uintmax_t none = std::numeric_limits<std::uintmax_t>::max();
      const std::uintmax_t view = sizeField(a, "bufferView", none);
      const std::uintmax_t count = sizeField(a, "count", 0);
      const auto type = a.is_object() ? a.find("type") : a.end();
      const std::uintmax_t element =
          componentBytes(sizeField(a, "componentType", 0)) *
          (type != a.end() && type->is_string() ? componentCount(type->get<std::string>()) : 0);
      if (view >= viewBytes.size() || element == 0 || count == 0) continue;
      const std::uintmax_t offset = sizeField(a, "byteOffset", 0);
      const std::uintmax_t avail = viewBytes[view] - std::min(offset, viewBytes[view]);
      // Tightly packed is the least a count can take; a stride only adds to it.
      if (count > avail / element)
        badInput(path + ": glTF accessor " + std::to_string(i) + " declares " +
                 std::to_string(count) + " elements of " + std::to_string(element) +
                 " bytes but its bufferView " + std::to_string(view) + " holds " +
                 std::to_string(avail) + " bytes from its offset");
    }
  }
}

void checkGlb(const std::string& path, std::uintmax_t fileBytes) {
  if (fileBytes < 12)
    badInput(path + ": the GLB header is cut short (" + std::to_string(fileBytes) +
             " bytes; the header alone is 12)");
  const std::string head = readPrefix(path, 20);
  const std::uint32_t version = le32(head, 4);
  const std::uint32_t length = le32(head, 8);
  if (length > fileBytes)
    badInput(path + ": the GLB header declares " + std::to_string(length) +
             " bytes but the file has " + std::to_string(fileBytes));
  if (version != 2) return;  // glTF 1.0 binaries: the importer checks its own layout
  // Chunks: JSON first, then an optional BIN. Each header is 8 bytes: length, then type.
  std::ifstream in(path, std::ios::binary);
  std::uintmax_t at = 12, binChunk = 0;
  std::string json;
  for (int chunk = 0; at + 8 <= length; ++chunk) {
    std::string h(8, '\0');
    in.seekg(static_cast<std::streamoff>(at));
    in.read(h.data(), 8);
    const std::uint32_t bytes = le32(h, 0), type = le32(h, 4);
    const std::uintmax_t left = length - at - 8;
    if (bytes > left)
      badInput(path + ": GLB chunk " + std::to_string(chunk) + " declares " +
               std::to_string(bytes) + " bytes but only " + std::to_string(left) +
               " remain in the file");
    if (chunk == 0) {
      if (type != 0x4E4F534Au)  // "JSON"
        badInput(path + ": the first GLB chunk is not JSON");
      json.resize(bytes);
      in.read(json.data(), bytes);
    } else if (type == 0x004E4942u && binChunk == 0) {  // "BIN\0"
      binChunk = bytes;
    }
    at += 8 + ((static_cast<std::uintmax_t>(bytes) + 3) & ~std::uintmax_t{3});
  }
  if (json.empty()) badInput(path + ": the GLB file has no JSON chunk");
  checkGltfJson(path, json, binChunk, true);
}

}  // namespace

std::uintmax_t checkMeshDeclarations(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) badInput(path + ": is a directory, not a mesh file");
  const std::uintmax_t bytes = fs::file_size(path, ec);
  if (ec) badInput(path + ": cannot open the mesh file (" + ec.message() + ")");
  const std::string magic = readPrefix(path, 4);
  if (magic.rfind("ply", 0) == 0 && (magic.size() < 4 || magic[3] == '\n' || magic[3] == '\r')) {
    checkPly(path, bytes);
  } else if (magic == "glTF") {
    checkGlb(path, bytes);
  } else if (lowerExtension(path) == ".gltf") {
    checkGltfJson(path, readPrefix(path, static_cast<std::size_t>(bytes)), 0, false);
  }
  return bytes;
}

}  // namespace penumbra::detail
