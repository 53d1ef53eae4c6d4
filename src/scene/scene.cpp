// Scenes: the built-in default scene, mesh loading through Assimp, camera framing and parsing.
#include "penumbra/scene.hpp"

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <unistd.h>

#include <algorithm>
#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <locale>
#include <new>
#include <sstream>

#include "penumbra/error.hpp"
#include "core/contained.hpp"
#include "core/number_text.hpp"
#include "core/vec3.hpp"
#include "scene/mesh_declarations.hpp"

namespace penumbra {
namespace {

constexpr float kPi = 3.14159265358979323846f;

using detail::cross;
using detail::dot;
using detail::isFinite;
using detail::length;
using detail::operator+;
using detail::operator-;
using detail::operator*;
// Shorter vectors have no usable direction (detail::normalizeOr).
constexpr float kMinLength = 1e-20f;

std::string vecText(const Vec3& v) {
  std::ostringstream s;
  s.imbue(std::locale::classic());  // "0.5", whatever the global locale
  s << "(" << v[0] << ", " << v[1] << ", " << v[2] << ")";
  return s.str();
}

// ---------------------------------------------------------------------------------------------
// Built-in scene construction.
// ---------------------------------------------------------------------------------------------

// Appends one triangle, wound so that its geometric normal agrees with `outward`. Building every
// primitive through this keeps the winding counter-clockwise seen from outside without having to
// get each parametrisation's orientation right by hand.
void addTriangle(Mesh& m, int a, int b, int c, const Vec3& outward) {
  const Vec3 n = cross(m.positions[b] - m.positions[a], m.positions[c] - m.positions[a]);
  if (dot(n, outward) < 0) std::swap(b, c);
  m.triangles.push_back({a, b, c});
}

int addVertex(Mesh& m, const Vec3& p, const Vec3& n) {
  m.positions.push_back(p);
  m.normals.push_back(n);
  return static_cast<int>(m.positions.size()) - 1;
}

// Rotation about +y by `yaw` radians (positive turns +x towards -z, the usual right-handed sense).
Vec3 rotateY(const Vec3& v, float yaw) {
  const float c = std::cos(yaw), s = std::sin(yaw);
  return {c * v[0] + s * v[2], v[1], -s * v[0] + c * v[2]};
}

// A closed box with per-face vertices (flat normals, so its edges stay sharp under smooth shading).
void addBox(Mesh& m, const Vec3& centre, const Vec3& half, float yaw) {
  for (int axis = 0; axis < 3; ++axis) {
    for (int sign = -1; sign <= 1; sign += 2) {
      Vec3 nLocal{0, 0, 0};
      nLocal[axis] = static_cast<float>(sign);
      const Vec3 n = rotateY(nLocal, yaw);
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      int idx[4];
      const float corner[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
      for (int k = 0; k < 4; ++k) {
        Vec3 p{0, 0, 0};
        p[axis] = sign * half[axis];
        p[u] = corner[k][0] * half[u];
        p[v] = corner[k][1] * half[v];
        idx[k] = addVertex(m, centre + rotateY(p, yaw), n);
      }
      addTriangle(m, idx[0], idx[1], idx[2], n);
      addTriangle(m, idx[0], idx[2], idx[3], n);
    }
  }
}

// A horizontal square grid facing +y, `cells` x `cells` quads, so no triangle gets large (large
// triangles interpolate shading and shadow-map texel lookups poorly).
Mesh makeGround(const std::string& name, float cx, float y, float cz, float side, int cells,
                const Vec3& albedo) {
  Mesh m;
  m.name = name;
  m.albedo = albedo;
  const Vec3 up{0, 1, 0};
  const float step = side / cells;
  for (int i = 0; i <= cells; ++i)
    for (int j = 0; j <= cells; ++j)
      addVertex(m, {cx - side / 2 + j * step, y, cz - side / 2 + i * step}, up);
  for (int i = 0; i < cells; ++i) {
    for (int j = 0; j < cells; ++j) {
      const int a = i * (cells + 1) + j, b = a + 1, c = a + cells + 1, d = c + 1;
      addTriangle(m, a, b, d, up);
      addTriangle(m, a, d, c, up);
    }
  }
  return m;
}

// UV sphere with single pole vertices (no degenerate triangles, closed by index).
Mesh makeSphere(const Vec3& centre, float radius, int segments, int rings, const Vec3& albedo) {
  Mesh m;
  m.name = "sphere";
  m.albedo = albedo;
  const int top = addVertex(m, centre + Vec3{0, radius, 0}, {0, 1, 0});
  for (int r = 1; r < rings; ++r) {
    const float theta = kPi * r / rings;  // polar angle from +y
    for (int s = 0; s < segments; ++s) {
      const float phi = 2 * kPi * s / segments;
      const Vec3 n{std::sin(theta) * std::cos(phi), std::cos(theta),
                   std::sin(theta) * std::sin(phi)};
      addVertex(m, centre + n * radius, n);
    }
  }
  const int bottom = addVertex(m, centre + Vec3{0, -radius, 0}, {0, -1, 0});
  auto ring = [&](int r, int s) { return 1 + (r - 1) * segments + (s % segments); };
  auto outward = [&](int a, int b, int c) {
    return (m.positions[a] + m.positions[b] + m.positions[c]) * (1.0f / 3) - centre;
  };
  for (int s = 0; s < segments; ++s) {
    const int a = ring(1, s), b = ring(1, s + 1);
    addTriangle(m, top, a, b, outward(top, a, b));
    const int c = ring(rings - 1, s), d = ring(rings - 1, s + 1);
    addTriangle(m, bottom, c, d, outward(bottom, c, d));
  }
  for (int r = 1; r + 1 < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      const int a = ring(r, s), b = ring(r, s + 1), c = ring(r + 1, s), d = ring(r + 1, s + 1);
      addTriangle(m, a, b, d, outward(a, b, d));
      addTriangle(m, a, d, c, outward(a, d, c));
    }
  }
  return m;
}

// Torus standing upright: its ring lies in the vertical plane through `centre` spanned by +y and
// the horizontal direction `yaw` turns +x into. The sample at major angle 3*pi/2 with tube angle 0
// is the lowest point, at exactly centre.y - major - minor (segment counts are multiples of 4).
Mesh makeTorus(const Vec3& centre, float major, float minor, float yaw, int majorSegs,
               int minorSegs, const Vec3& albedo) {
  Mesh m;
  m.name = "torus";
  m.albedo = albedo;
  const Vec3 e1 = rotateY({1, 0, 0}, yaw), e2{0, 1, 0}, axis = cross(e1, e2);
  for (int i = 0; i < majorSegs; ++i) {
    const float u = 2 * kPi * i / majorSegs;
    const Vec3 radial = e1 * std::cos(u) + e2 * std::sin(u);
    for (int j = 0; j < minorSegs; ++j) {
      const float v = 2 * kPi * j / minorSegs;
      const Vec3 n = radial * std::cos(v) + axis * std::sin(v);
      addVertex(m, centre + (radial * major + n * minor), n);
    }
  }
  auto at = [&](int i, int j) { return (i % majorSegs) * minorSegs + (j % minorSegs); };
  for (int i = 0; i < majorSegs; ++i) {
    for (int j = 0; j < minorSegs; ++j) {
      const int a = at(i, j), b = at(i + 1, j), c = at(i, j + 1), d = at(i + 1, j + 1);
      // The vertex normals of a quad all point away from the tube's core: their sum is outward.
      const Vec3 out = (m.normals[a] + m.normals[b]) + (m.normals[c] + m.normals[d]);
      addTriangle(m, a, b, d, out);
      addTriangle(m, a, d, c, out);
    }
  }
  return m;
}

// A vertical lattice of thin bars standing on the ground: square holes and thin parts, the cases
// where shadow techniques that blur or bias lose detail. Vertical bars are slightly deeper than
// horizontal ones so no corners of crossing bars coincide (each bar stays a separate closed box).
Mesh makeLattice(const Vec3& base, float width, float height, int holes, float bar, float yaw,
                 const Vec3& albedo) {
  Mesh m;
  m.name = "lattice";
  m.albedo = albedo;
  const float pitch = (width - bar) / holes;
  const int rows = static_cast<int>(std::lround((height - bar) / pitch));
  const float h = rows * pitch + bar;
  for (int k = 0; k <= holes; ++k) {
    const Vec3 local{-width / 2 + bar / 2 + k * pitch, h / 2, 0};
    addBox(m, base + rotateY(local, yaw), {bar / 2, h / 2, bar / 2}, yaw);
  }
  for (int k = 0; k <= rows; ++k) {
    const Vec3 local{0, bar / 2 + k * pitch, 0};
    addBox(m, base + rotateY(local, yaw), {width / 2, bar / 2, bar * 0.4f}, yaw);
  }
  return m;
}

// ---------------------------------------------------------------------------------------------
// Assimp loading.
// ---------------------------------------------------------------------------------------------

// Collects Assimp's warnings during one import. Some importers repair bad data silently (glTF2
// drops faces with out-of-range indices and only logs it), so the log is the only place where we
// learn that the file was broken.
class WarningCollector : public Assimp::LogStream {
 public:
  void write(const char* message) override { messages.emplace_back(message ? message : ""); }
  std::vector<std::string> messages;
};

class ScopedWarningCapture {
 public:
  ScopedWarningCapture() {
    if (Assimp::DefaultLogger::isNullLogger()) {
      Assimp::DefaultLogger::create("", Assimp::Logger::NORMAL, 0);
      created_ = true;
    }
    Assimp::DefaultLogger::get()->attachStream(&collector_,
                                               Assimp::Logger::Warn | Assimp::Logger::Err);
  }
  ~ScopedWarningCapture() {
    // Detach first: the logger would otherwise delete our (member) stream when it is killed.
    Assimp::DefaultLogger::get()->detachStream(&collector_,
                                               Assimp::Logger::Warn | Assimp::Logger::Err);
    if (created_) Assimp::DefaultLogger::kill();
  }
  ScopedWarningCapture(const ScopedWarningCapture&) = delete;
  ScopedWarningCapture& operator=(const ScopedWarningCapture&) = delete;
  const std::vector<std::string>& messages() const { return collector_.messages; }

 private:
  WarningCollector collector_;
  bool created_ = false;
};

std::string oneLine(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// Assimp's log lines start with "Warn,  T0: "; the file's problem is what follows.
std::string logText(const std::string& line) {
  const auto colon = line.find(": ");
  const bool prefixed = line.rfind("Warn,", 0) == 0 || line.rfind("Error,", 0) == 0;
  return oneLine(prefixed && colon != std::string::npos ? line.substr(colon + 2) : line);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string meshLabel(const aiMesh* mesh, unsigned index) {
  std::string name = mesh->mName.length ? mesh->mName.C_Str() : "";
  return "mesh #" + std::to_string(index) + (name.empty() ? "" : " '" + name + "'");
}

bool hasSurface(const aiMesh* mesh) {
  return (mesh->mPrimitiveTypes & (aiPrimitiveType_TRIANGLE | aiPrimitiveType_POLYGON)) != 0 &&
         mesh->mNumFaces > 0;
}

// The problems a file can have that Assimp may or may not catch itself (it depends on the format
// and on whether validation ran). Used both on the post-processed scene and, when Assimp refused
// the file, on a raw re-read so that the message says what is wrong rather than just "failed".
void checkAiScene(const std::string& path, const aiScene* scene) {
  unsigned surfaces = 0;
  bool anyVertices = false;
  for (unsigned mi = 0; mi < scene->mNumMeshes; ++mi) {
    const aiMesh* mesh = scene->mMeshes[mi];
    if (!mesh) continue;
    anyVertices = anyVertices || mesh->mNumVertices > 0;
    if (hasSurface(mesh)) ++surfaces;
  }
  if (surfaces == 0) {
    if (anyVertices) badInput(path + ": no triangles (the file holds only points or lines)");
    badInput(path + ": no triangles (no mesh data found in the file)");
  }
  for (unsigned mi = 0; mi < scene->mNumMeshes; ++mi) {
    const aiMesh* mesh = scene->mMeshes[mi];
    if (!mesh || !hasSurface(mesh)) continue;
    if (!mesh->mVertices) badInput(path + ": " + meshLabel(mesh, mi) + " has no vertex positions");
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      for (unsigned k = 0; k < face.mNumIndices; ++k) {
        if (face.mIndices[k] >= mesh->mNumVertices) {
          badInput(path + ": index out of range: " + meshLabel(mesh, mi) + ", face " +
                   std::to_string(f) + " refers to vertex " + std::to_string(face.mIndices[k]) +
                   " but the mesh has " + std::to_string(mesh->mNumVertices) + " vertices");
        }
      }
    }
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
        badInput(path + ": non-finite vertex coordinate in " + meshLabel(mesh, mi) + ", vertex " +
                 std::to_string(v) + " = " + vecText({p.x, p.y, p.z}));
      }
    }
  }
}

Vec3 materialAlbedo(const aiScene* scene, const aiMesh* mesh) {
  const Vec3 fallback{0.8f, 0.8f, 0.8f};
  if (mesh->mMaterialIndex >= scene->mNumMaterials) return fallback;
  const aiMaterial* mat = scene->mMaterials[mesh->mMaterialIndex];
  if (!mat) return fallback;
  // Assimp invents a material (diffuse 0.6) for files without one; that is not the file's colour.
  aiString name;
  if (mat->Get(AI_MATKEY_NAME, name) == aiReturn_SUCCESS &&
      std::string(name.C_Str()) == AI_DEFAULT_MATERIAL_NAME)
    return fallback;
  aiColor3D c;
  if (mat->Get(AI_MATKEY_COLOR_DIFFUSE, c) != aiReturn_SUCCESS) return fallback;
  Vec3 out{c.r, c.g, c.b};
  if (!isFinite(out)) return fallback;
  // 0.95 at most: a white albedo of 1 would reflect everything, which no real material does and
  // which makes interreflection-free shading look blown out.
  for (float& x : out) x = std::clamp(x, 0.0f, 0.95f);
  return out;
}

// Converts one triangle mesh: keeps only referenced vertices (stray vertices would distort the
// bounds and so the ground and the framing), drops triangles that repeat a vertex, and makes the
// normals unit, falling back to the (area weighted) face normal where Assimp's are unusable.
Mesh convertMesh(const aiScene* scene, const aiMesh* mesh, unsigned index) {
  Mesh out;
  out.name = mesh->mName.length ? std::string(mesh->mName.C_Str()) : "mesh" + std::to_string(index);
  out.albedo = materialAlbedo(scene, mesh);
  std::vector<int> remap(mesh->mNumVertices, -1);
  for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
    const aiFace& face = mesh->mFaces[f];
    if (face.mNumIndices != 3) continue;
    const unsigned a = face.mIndices[0], b = face.mIndices[1], c = face.mIndices[2];
    if (a == b || b == c || a == c) continue;
    std::array<int, 3> tri{};
    const unsigned src[3] = {a, b, c};
    for (int k = 0; k < 3; ++k) {
      int& r = remap[src[k]];
      if (r < 0) {
        const aiVector3D& p = mesh->mVertices[src[k]];
        r = static_cast<int>(out.positions.size());
        out.positions.push_back({p.x, p.y, p.z});
        if (mesh->mNormals) {
          const aiVector3D& n = mesh->mNormals[src[k]];
          out.normals.push_back({n.x, n.y, n.z});
        } else {
          out.normals.push_back({0, 0, 0});  // replaced by the face normal below
        }
      }
      tri[k] = r;
    }
    out.triangles.push_back(tri);
  }
  std::vector<Vec3> faceSum(out.positions.size(), Vec3{0, 0, 0});
  for (const auto& t : out.triangles) {
    const Vec3 n = cross(out.positions[t[1]] - out.positions[t[0]],
                         out.positions[t[2]] - out.positions[t[0]]);
    for (int k = 0; k < 3; ++k) faceSum[t[k]] = faceSum[t[k]] + n;
  }
  for (std::size_t v = 0; v < out.normals.size(); ++v) {
    const Vec3 faceNormal = detail::normalizeOr(faceSum[v], {0, 1, 0}, kMinLength);
    out.normals[v] = isFinite(out.normals[v])
                         ? detail::normalizeOr(out.normals[v], faceNormal, kMinLength)
                         : faceNormal;
  }
  return out;
}

Bounds boundsOf(const std::vector<const Mesh*>& meshes) {
  Bounds b;
  bool any = false;
  for (const Mesh* m : meshes) {
    for (const Vec3& p : m->positions) {
      for (int k = 0; k < 3; ++k) {
        b.lo[k] = any ? std::min(b.lo[k], p[k]) : p[k];
        b.hi[k] = any ? std::max(b.hi[k], p[k]) : p[k];
      }
      any = true;
    }
  }
  return b;
}

std::string cameraError(const std::string& text, const std::string& problem) {
  return "camera '" + oneLine(text) + "': " + problem;
}

// Whether a decimal that from_chars found beyond double's range is too small (strtod's 0) rather
// than too large: a negative exponent, or no exponent and a zero integer part ("0.000...1").
bool tooSmall(const char* first, const char* last) {
  const char* e = std::find_if(first, last, [](char c) { return c == 'e' || c == 'E'; });
  if (e != last) return e + 1 < last && e[1] == '-';
  if (first != last && *first == '-') ++first;
  return std::all_of(first, std::find(first, last, '.'), [](char c) { return c == '0'; });
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Bounds and Scene.
// ---------------------------------------------------------------------------------------------

Vec3 Bounds::center() const { return (lo + hi) * 0.5f; }

float Bounds::radius() const { return 0.5f * length(hi - lo); }

Bounds Scene::bounds() const {
  std::vector<const Mesh*> all;
  for (const Mesh& m : meshes) all.push_back(&m);
  return boundsOf(all);
}

std::size_t Scene::triangleCount() const {
  std::size_t n = 0;
  for (const Mesh& m : meshes) n += m.triangles.size();
  return n;
}

// ---------------------------------------------------------------------------------------------
// The built-in scene.
// ---------------------------------------------------------------------------------------------

// Motion of builtinScene(t): the sphere's bounce (seconds per hop, metres of lift) and the slab's
// turn (seconds per revolution).
constexpr float kBouncePeriod = 1.5f;
constexpr float kBounceHeight = 0.8f;
constexpr float kSlabTurnPeriod = 10.0f;

Scene builtinScene(float t) {
  if (!std::isfinite(t)) badInput("builtin scene time must be finite, got " + detail::numberText(t));
  Scene s;
  // 12 m square, 16 x 16 cells of 0.75 m: it reaches well past the objects (all within about
  // |x|,|z| < 3) so that long shadows from low lights still land on it.
  s.meshes.push_back(makeGround("ground", 0, 0, 0, 12.0f, 16, {0.7f, 0.7f, 0.7f}));

  // Box and sphere rest on the ground: contact shadows, where the penumbra shrinks to zero.
  Mesh box;
  box.name = "box";
  box.albedo = {0.75f, 0.42f, 0.28f};
  addBox(box, {-0.3f, 0.5f, 1.3f}, {0.5f, 0.5f, 0.5f}, 0.5f);
  s.meshes.push_back(std::move(box));

  // The sphere bounces in place: height |sin| (a ball's parabolic arcs, close enough to look
  // right, with a sharp turn at each contact), touching the ground at t = 0 so time 0 is the
  // static scene. Its top stays below the slab's (2.1 m) and it never reaches the slab's column,
  // so the objects' bounds, and hence frameCamera, do not change over time.
  const float bounce = kBounceHeight * std::fabs(std::sin(kPi * t / kBouncePeriod));
  s.meshes.push_back(
      makeSphere({1.5f, 0.6f + bounce, 0.7f}, 0.6f, 32, 16, {0.28f, 0.48f, 0.78f}));

  // Slab floating 2 m up: its shadow has a wide penumbra and no contact point.
  Mesh slab;
  slab.name = "slab";
  slab.albedo = {0.62f, 0.62f, 0.66f};
  // It turns about its vertical axis (counter-clockwise seen from above), so its penumbra sweeps
  // across the ground and the lattice.
  const float turns = std::fmod(t / kSlabTurnPeriod, 1.0f);
  addBox(slab, {1.1f, 2.05f, -1.2f}, {0.9f, 0.05f, 0.6f}, -0.25f + 2 * kPi * turns);
  s.meshes.push_back(std::move(slab));

  // Upright torus: light through its hole. Its ring faces roughly towards the framing camera
  // (azimuth 35 degrees), so the hole is visible.
  s.meshes.push_back(makeTorus({-2.0f, 0.73f, 0.2f}, 0.55f, 0.18f, 35.0f * kPi / 180, 48, 16,
                               {0.82f, 0.68f, 0.24f}));

  // Lattice of 4 cm bars with ~0.35 m square holes, 2 m x 2 m.
  s.meshes.push_back(
      makeLattice({-1.1f, 0, -2.1f}, 2.0f, 2.0f, 5, 0.04f, 0.15f, {0.32f, 0.62f, 0.34f}));
  return s;
}

// ---------------------------------------------------------------------------------------------
// Loading.
// ---------------------------------------------------------------------------------------------

namespace {

// The meshes as Assimp reads them (without the ground). Runs inside the contained child: Assimp
// is the code that may crash, loop or allocate without bound on a malformed file. Its logger is
// a process-wide singleton; the child is alone in its process, so no lock is needed.
std::vector<Mesh> importMeshes(const std::string& path) {
  const unsigned flags = aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                         aiProcess_GenSmoothNormals | aiProcess_PreTransformVertices |
                         aiProcess_SortByPType | aiProcess_ValidateDataStructure;
  Assimp::Importer importer;
  // Meshes without normals get smoothed only across edges flatter than 80 degrees, so hard edges
  // (a box's) stay hard instead of being rounded off.
  importer.SetPropertyFloat(AI_CONFIG_PP_GSN_MAX_SMOOTHING_ANGLE, 80.0f);

  ScopedWarningCapture warnings;
  const aiScene* ai = importer.ReadFile(path, flags);
  if (!ai) {
    const std::string why = oneLine(importer.GetErrorString());
    // Assimp catches an allocation failure (the child's memory limit) and reports it as text;
    // rethrown, it is reported as the limit it is (runContained).
    if (why.find("bad_alloc") != std::string::npos) throw std::bad_alloc();
    // Assimp's validation reports e.g. a point cloud only as "Mesh contains no faces". Re-read
    // without validation or post-processing to name the actual problem where we can.
    Assimp::Importer raw;
    if (const aiScene* rs = raw.ReadFile(path, 0)) checkAiScene(path, rs);
    const std::string l = lower(why);
    if (l.find("out of range") != std::string::npos && l.find("ind") != std::string::npos)
      badInput(path + ": indices out of range (Assimp: " + why + ")");
    badInput(path + ": cannot load the mesh (Assimp: " + why + ")");
  }
  for (const std::string& w : warnings.messages()) {
    const std::string l = lower(w);
    if ((l.find("out-of-range") != std::string::npos ||
         l.find("out of range") != std::string::npos) &&
        l.find("ind") != std::string::npos)
      badInput(path + ": indices out of range (Assimp: " + logText(w) + ")");
  }
  if (ai->mFlags & AI_SCENE_FLAGS_INCOMPLETE)
    badInput(path + ": the file holds no complete scene (Assimp marked it incomplete)");
  checkAiScene(path, ai);

  std::vector<Mesh> meshes;
  for (unsigned mi = 0; mi < ai->mNumMeshes; ++mi) {
    const aiMesh* mesh = ai->mMeshes[mi];
    // SortByPType split mixed meshes; what has no triangles here is points or lines: dropped.
    if (!mesh || !(mesh->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    Mesh m = convertMesh(ai, mesh, mi);
    if (!m.triangles.empty()) meshes.push_back(std::move(m));
  }
  return meshes;
}

// The child's meshes travel to the parent as a flat byte string: per mesh its name, albedo,
// positions, normals and triangles, each array preceded by its length.
template <class T>
void put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

template <class T>
void putArray(std::string& out, const std::vector<T>& v) {
  put(out, static_cast<std::uint64_t>(v.size()));
  out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

std::string packMeshes(const std::vector<Mesh>& meshes) {
  std::string out;
  put(out, static_cast<std::uint64_t>(meshes.size()));
  for (const Mesh& m : meshes) {
    put(out, static_cast<std::uint64_t>(m.name.size()));
    out += m.name;
    put(out, m.albedo);
    putArray(out, m.positions);
    putArray(out, m.normals);
    putArray(out, m.triangles);
  }
  return out;
}

// Reads packMeshes' output; the sizes are checked even though our own child wrote them.
class Unpacker {
 public:
  Unpacker(const std::string& data, const std::string& path) : data_(data), path_(path) {}
  template <class T>
  T get() {
    T v;
    take(&v, sizeof v);
    return v;
  }
  template <class T>
  std::vector<T> getArray() {
    const auto n = get<std::uint64_t>();
    if (n > (data_.size() - at_) / sizeof(T)) broken();
    std::vector<T> v(static_cast<std::size_t>(n));
    take(v.data(), v.size() * sizeof(T));
    return v;
  }
  std::string getString() {
    const std::vector<char> c = getArray<char>();
    return std::string(c.begin(), c.end());
  }
  bool done() const { return at_ == data_.size(); }
  [[noreturn]] void broken() const {
    throw Error(ErrorKind::Internal, path_ + ": the mesh reader process sent malformed meshes");
  }

 private:
  void take(void* dst, std::size_t n) {
    if (n > data_.size() - at_) broken();
    if (n) std::memcpy(dst, data_.data() + at_, n);
    at_ += n;
  }
  const std::string& data_;
  const std::string& path_;
  std::size_t at_ = 0;
};

std::vector<Mesh> unpackMeshes(const std::string& data, const std::string& path) {
  Unpacker in(data, path);
  const auto n = in.get<std::uint64_t>();
  std::vector<Mesh> meshes;
  for (std::uint64_t i = 0; i < n; ++i) {
    Mesh m;
    m.name = in.getString();
    m.albedo = in.get<Vec3>();
    m.positions = in.getArray<Vec3>();
    m.normals = in.getArray<Vec3>();
    m.triangles = in.getArray<std::array<int, 3>>();
    for (const auto& t : m.triangles)
      for (int v : t)
        if (v < 0 || static_cast<std::size_t>(v) >= m.positions.size()) in.broken();
    meshes.push_back(std::move(m));
  }
  if (!in.done()) in.broken();
  return meshes;
}

std::size_t physicalMemory() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  return pages > 0 && page > 0 ? static_cast<std::size_t>(pages) * static_cast<std::size_t>(page)
                               : std::size_t{4} << 30;
}

detail::ContainLimits meshLoadLimits(const LoadOptions& opt, std::uintmax_t fileBytes) {
  detail::ContainLimits limits;
  const double mb = static_cast<double>(fileBytes) / (1 << 20);
  limits.seconds = opt.timeoutSeconds > 0 ? opt.timeoutSeconds : 20.0 + mb;
  if (opt.memoryLimitBytes > 0) {
    limits.memoryBytes = opt.memoryLimitBytes;
  } else {
    const std::size_t wanted = (std::size_t{1} << 30) + 64 * static_cast<std::size_t>(fileBytes);
    limits.memoryBytes = std::min(wanted, physicalMemory() / 4 * 3);
  }
  return limits;
}

void checkLoadOptions(const LoadOptions& opt) {
  if (!(opt.timeoutSeconds >= 0) || !std::isfinite(opt.timeoutSeconds))
    badInput("LoadOptions::timeoutSeconds must be a finite number of seconds >= 0 (0: automatic), "
             "got " + detail::numberText(opt.timeoutSeconds));
}

}  // namespace

Scene loadScene(const std::string& path, const LoadOptions& opt) {
  checkLoadOptions(opt);
  const std::uintmax_t fileBytes = detail::checkMeshDeclarations(path);
  const std::string packed = detail::runContained(path, meshLoadLimits(opt, fileBytes),
                                                  [&] { return packMeshes(importMeshes(path)); });
  Scene scene;
  scene.meshes = unpackMeshes(packed, path);
  if (scene.meshes.empty())
    badInput(path + ": no triangles (every triangle in the file is degenerate)");

  const Bounds b = scene.bounds();
  const Vec3 ext = b.hi - b.lo;
  const float maxExt = std::max({ext[0], ext[1], ext[2]});
  if (!std::isfinite(maxExt)) badInput(path + ": the mesh bounds overflow single precision");
  if (maxExt <= 0)
    badInput(path + ": degenerate bounds (all vertices at one point " + vecText(b.lo) + ")");

  if (opt.addGround) {
    float horizontal = std::max(ext[0], ext[2]);
    if (horizontal <= 0) horizontal = ext[1];  // a mesh standing in a vertical line still gets one
    const Vec3 c = b.center();
    scene.meshes.push_back(
        makeGround("ground", c[0], b.lo[1], c[2], 4 * horizontal, 8, {0.7f, 0.7f, 0.7f}));
  }
  return scene;
}

void validateScene(const Scene& scene) {
  std::size_t triangles = 0;
  for (std::size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const Mesh& m = scene.meshes[mi];
    const std::string label = "Scene.meshes[" + std::to_string(mi) + "]" +
                              (m.name.empty() ? "" : " '" + oneLine(m.name) + "'") + ": ";
    for (std::size_t v = 0; v < m.positions.size(); ++v)
      if (!isFinite(m.positions[v]))
        badInput(label + "non-finite vertex position " + std::to_string(v) + " = " +
                 vecText(m.positions[v]));
    if (!m.normals.empty()) {
      if (m.normals.size() != m.positions.size())
        badInput(label + std::to_string(m.normals.size()) + " normals for " +
                 std::to_string(m.positions.size()) + " positions (give one per vertex or none)");
      for (std::size_t v = 0; v < m.normals.size(); ++v)
        if (!isFinite(m.normals[v]) || !(length(m.normals[v]) > kMinLength))
          badInput(label + "normal " + std::to_string(v) + " = " + vecText(m.normals[v]) +
                   " is not a finite non-zero vector");
    }
    const std::size_t nv = m.positions.size();
    for (std::size_t t = 0; t < m.triangles.size(); ++t)
      for (int k = 0; k < 3; ++k)
        if (m.triangles[t][k] < 0 || static_cast<std::size_t>(m.triangles[t][k]) >= nv)
          badInput(label + "triangle " + std::to_string(t) + " refers to vertex " +
                   std::to_string(m.triangles[t][k]) + " of " + std::to_string(nv));
    for (float a : m.albedo)
      if (!(a >= 0 && a <= 1))
        badInput(label + "albedo " + vecText(m.albedo) + " must lie in [0, 1]");
    triangles += m.triangles.size();
  }
  if (triangles == 0) badInput("scene has no triangles");
}

Scene sceneFrom(const std::string& pathOrBuiltin, const LoadOptions& opt) {
  if (pathOrBuiltin == "builtin") return builtinScene();
  return loadScene(pathOrBuiltin, opt);
}

// ---------------------------------------------------------------------------------------------
// Cameras.
// ---------------------------------------------------------------------------------------------

std::optional<GroundPlane> findGround(const Scene& scene) {
  for (const Mesh& m : scene.meshes) {
    if (m.name != "ground" || m.positions.empty()) continue;
    GroundPlane g;
    g.y = m.positions[0][1];
    g.x0 = g.x1 = m.positions[0][0];
    g.z0 = g.z1 = m.positions[0][2];
    bool flat = true;
    for (const Vec3& p : m.positions) {
      flat = flat && p[1] == g.y;
      g.x0 = std::min(g.x0, p[0]);
      g.x1 = std::max(g.x1, p[0]);
      g.z0 = std::min(g.z0, p[2]);
      g.z1 = std::max(g.z1, p[2]);
    }
    if (flat && g.x1 > g.x0 && g.z1 > g.z0) return g;
  }
  return std::nullopt;
}

Camera frameCamera(const Scene& scene, float aspect) {
  if (!std::isfinite(aspect) || aspect <= 0)
    badInput("frameCamera: the aspect ratio must be positive and finite, got " +
             detail::numberText(aspect));
  // The ground plane is several times larger than what stands on it; framing it would leave the
  // objects tiny. Frame everything else when there is anything else.
  std::vector<const Mesh*> objects, all;
  for (const Mesh& m : scene.meshes) {
    if (m.positions.empty()) continue;
    all.push_back(&m);
    if (m.name != "ground") objects.push_back(&m);
  }
  const Bounds b = boundsOf(objects.empty() ? all : objects);
  Camera cam;
  cam.fovyDeg = 40.0f;
  cam.up = {0, 1, 0};
  cam.target = b.center();
  float radius = b.radius();
  if (!(radius > 0) || !std::isfinite(radius)) radius = 1.0f;
  // The sphere of radius r seen from distance d subtends a half-angle asin(r/d); it fits when that
  // is below the smaller of the vertical and horizontal half fields of view. 5% margin.
  const float tanHalfY = std::tan(cam.fovyDeg * kPi / 360);
  const float halfAngle = std::min(std::atan(tanHalfY), std::atan(tanHalfY * aspect));
  const float distance = 1.05f * radius / std::sin(halfAngle);
  const float elevation = 30.0f * kPi / 180, azimuth = 35.0f * kPi / 180;
  const Vec3 dir{std::cos(elevation) * std::sin(azimuth), std::sin(elevation),
                 std::cos(elevation) * std::cos(azimuth)};
  cam.eye = cam.target + dir * distance;
  return cam;
}

CameraBasis cameraBasis(const Camera& c, int width, int height) {
  if (width <= 0 || height <= 0)
    badInput("camera: image size must be positive, got " + std::to_string(width) + "x" +
             std::to_string(height));
  if (!std::isfinite(c.fovyDeg) || c.fovyDeg <= 0 || c.fovyDeg >= 180)
    badInput("camera: vertical field of view must be in (0, 180) degrees, got " +
             detail::numberText(c.fovyDeg));
  if (!isFinite(c.eye) || !isFinite(c.target) || !isFinite(c.up))
    badInput("camera: eye, target and up must be finite");
  const Vec3 toTarget = c.target - c.eye;
  if (!(length(toTarget) > 0)) badInput("camera: eye and target coincide at " + vecText(c.eye));
  CameraBasis b;
  b.eye = c.eye;
  b.forward = detail::normalizeOr(toTarget, {0, 0, -1}, kMinLength);
  const Vec3 upDir = detail::normalizeOr(c.up, {0, 0, 0}, kMinLength);
  const Vec3 side = cross(b.forward, upDir);
  // Below ~0.06 degrees between up and forward the right vector is numerically meaningless.
  if (!(length(side) > 1e-3f))
    badInput("camera: up " + vecText(c.up) + " is zero or parallel to the view direction");
  b.right = detail::normalizeOr(side, {1, 0, 0}, kMinLength);
  b.up = cross(b.right, b.forward);
  b.tanHalfY = std::tan(c.fovyDeg * kPi / 360);
  b.tanHalfX = b.tanHalfY * static_cast<float>(width) / static_cast<float>(height);
  return b;
}

Vec3 cameraRayDirection(const CameraBasis& b, int width, int height, float px, float py) {
  const float sx = 2 * px / width - 1;
  const float sy = 1 - 2 * py / height;
  const Vec3 d = b.forward + (b.right * (sx * b.tanHalfX) + b.up * (sy * b.tanHalfY));
  return detail::normalizeOr(d, b.forward, kMinLength);
}

Camera parseCamera(const std::string& text) {
  std::vector<std::string> parts;
  std::string cur;
  for (char ch : text) {
    if (ch == ',') {
      parts.push_back(cur);
      cur.clear();
    } else {
      cur += ch;
    }
  }
  parts.push_back(cur);
  if (parts.size() != 6 && parts.size() != 7)
    badInput(cameraError(
        text, "expected 6 or 7 comma-separated numbers (ex,ey,ez,tx,ty,tz[,fovy]), got " +
                  std::to_string(parts.size())));
  float v[7] = {0, 0, 0, 0, 0, 0, 40.0f};
  for (std::size_t i = 0; i < parts.size(); ++i) {
    std::string p = parts[i];
    // Surrounding spaces are forgiven ("1, 2, 3" is a natural way to type it); nothing else is.
    const auto first = p.find_first_not_of(" \t");
    const auto last = p.find_last_not_of(" \t");
    p = first == std::string::npos ? "" : p.substr(first, last - first + 1);
    // Plain decimal notation only ("inf", "nan" and hex floats are refused), read by from_chars,
    // which ignores the locale (strtod under a German locale stops at the '.'). from_chars takes
    // no leading '+'; a leading '+' is skipped here.
    const bool plain = !p.empty() && p.find_first_not_of("0123456789+-.eE") == std::string::npos;
    const char* begin = p.c_str() + (p.size() > 1 && p[0] == '+' && p[1] != '-' ? 1 : 0);
    const char* const stop = p.c_str() + p.size();
    double x = 0.0;
    const auto [end, ec] =
        plain ? std::from_chars(begin, stop, x) : std::from_chars_result{begin, std::errc::invalid_argument};
    if (ec == std::errc::invalid_argument || end != stop)
      badInput(cameraError(text, "value " + std::to_string(i + 1) + " ('" + oneLine(parts[i]) +
                                     "') is not a number"));
    // out of range: beyond double's range (too small a value reads as 0, as strtod gives it)
    if (ec == std::errc::result_out_of_range) x = tooSmall(begin, stop) ? 0.0 : HUGE_VAL;
    if (!std::isfinite(x) || std::fabs(x) > std::numeric_limits<float>::max())
      badInput(
          cameraError(text, "value " + std::to_string(i + 1) + " ('" + p + "') is not finite"));
    v[i] = static_cast<float>(x);
  }
  Camera c;
  c.eye = {v[0], v[1], v[2]};
  c.target = {v[3], v[4], v[5]};
  c.up = {0, 1, 0};
  c.fovyDeg = v[6];
  if (!(c.fovyDeg > 0 && c.fovyDeg < 180))
    badInput(cameraError(text, "fovy " + parts[6] + " is not in (0, 180) degrees"));
  const Vec3 d = c.target - c.eye;
  if (!(length(d) > 0)) badInput(cameraError(text, "eye and target are the same point"));
  if (length(cross(detail::normalizeOr(d, {0, 0, 0}, kMinLength), c.up)) <= 1e-3f)
    badInput(cameraError(text, "the view direction is vertical, parallel to the up vector +y"));
  return c;
}

}  // namespace penumbra
