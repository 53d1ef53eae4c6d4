/// \file
/// Scenes: triangle meshes with a diffuse albedo, the built-in default scene, mesh loading through
/// Assimp (OBJ, PLY, glTF/GLB and anything else Assimp reads), and camera framing.
#pragma once
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace penumbra {

using Vec3 = std::array<float, 3>;

struct Mesh {
  std::string name;
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;               ///< per vertex, unit; empty means flat shading
  std::vector<std::array<int, 3>> triangles;
  Vec3 albedo{0.8f, 0.8f, 0.8f};           ///< diffuse reflectance in [0,1]
};

struct Bounds {
  Vec3 lo{0, 0, 0}, hi{0, 0, 0};
  Vec3 center() const;
  float radius() const;  // half the diagonal
};

struct Camera {
  Vec3 eye{0, 2, 5};
  Vec3 target{0, 0, 0};
  Vec3 up{0, 1, 0};
  float fovyDeg = 40.0f;  ///< vertical field of view
};

struct Scene {
  std::vector<Mesh> meshes;
  Bounds bounds() const;
  std::size_t triangleCount() const;
};

struct LoadOptions {
  bool addGround = true;   ///< add a ground plane under the mesh (its lowest point touches it)
  /// The importer runs in a child process under these limits, so a malformed file that crashes
  /// it, loops or allocates without bound is refused instead of taking the caller down.
  /// 0 means automatic: 20 s plus 1 s per MB of file; 1 GiB plus 64 bytes per byte of file, at
  /// most three quarters of the machine's physical memory.
  double timeoutSeconds = 0;
  std::size_t memoryLimitBytes = 0;
};

/// The default scene: a ground plane, a box and a sphere resting on it (contact shadows), a slab
/// floating high above it (wide penumbra), a torus and a lattice panel with square holes (holes and
/// thin parts). Units: metres, y up.
/// At time `timeSeconds` two objects have moved, so shadows move: the sphere bounces in place (a
/// hop of 0.8 m every 1.5 s, on the ground at whole multiples of 1.5 s) and the slab turns about
/// its vertical axis (one revolution every 10 s, counter-clockwise seen from above). Time 0 is the
/// static scene. Nothing leaves the view of frameCamera(builtinScene(0), aspect) at any time.
/// Throws Error(BadInput) for a non-finite time.
Scene builtinScene(float timeSeconds = 0.0f);

/// Loads a mesh file through Assimp. Throws Error(BadInput) naming the file and the problem:
/// unreadable or unsupported, no triangles (points or lines only), non-finite vertex coordinates,
/// indices out of range, PLY/glTF/GLB sizes declared beyond what the file holds (checked before
/// Assimp sees the file), or a file that crashes Assimp or passes the time or memory limit of
/// `opt` (Assimp runs in a forked child process; POSIX only). Safe to call from several threads;
/// their reader processes run one at a time.
Scene loadScene(const std::string& path, const LoadOptions& opt = {});

/// Checks a scene built in code as loadScene checks a file. Throws Error(BadInput) naming the mesh
/// and element ("Scene.meshes[1] 'box': triangle 4 refers to vertex 9 of 4"): a triangle index
/// outside the mesh's vertices, a non-finite position, normals whose count differs from the
/// positions' (when present) or that are non-finite or zero, an albedo outside [0, 1], no
/// triangles at all. Renderer::render calls it on every frame.
void validateScene(const Scene& scene);

/// "builtin" -> builtinScene(), else loadScene(path, opt).
Scene sceneFrom(const std::string& pathOrBuiltin, const LoadOptions& opt = {});

/// A camera looking at the scene's bounds (without the mesh named "ground", which would otherwise
/// set the framing) from above and to the side, far enough that the bounds' sphere fits the view
/// for the given aspect ratio (width/height).
Camera frameCamera(const Scene& scene, float aspect);

/// A horizontal rectangle at height y, x in [x0, x1] and z in [z0, z1] (y up): a scene's ground,
/// as the ground's occlusion of low lights (ShadowOptions::groundVisibility) sees it.
struct GroundPlane {
  float y = 0, x0 = 0, x1 = 0, z0 = 0, z1 = 0;
};

/// The scene's ground: the first mesh named "ground" (what loadScene and builtinScene add) whose
/// vertices all lie at one height and span a rectangle of non-zero area, as that rectangle (the
/// vertices' extent in x and z); nothing when there is none.
std::optional<GroundPlane> findGround(const Scene& scene);

/// The camera's orthonormal basis for a width x height image. Pixel (px, py) (continuous, row 0 at
/// the top, pixel centres at +0.5) looks along normalize(forward + sx*tanHalfX*right +
/// sy*tanHalfY*up) with sx = 2*px/width - 1 and sy = 1 - 2*py/height. The device rasterizer and the
/// Embree reference both use this, so they see the same pixels.
struct CameraBasis {
  Vec3 eye, forward, right, up;
  float tanHalfX = 0, tanHalfY = 0;
};
CameraBasis cameraBasis(const Camera& c, int width, int height);
Vec3 cameraRayDirection(const CameraBasis& b, int width, int height, float px, float py);

/// Parses "ex,ey,ez,tx,ty,tz[,fovy]". Throws Error(BadInput) naming --camera on malformed text.
Camera parseCamera(const std::string& text);

}  // namespace penumbra
