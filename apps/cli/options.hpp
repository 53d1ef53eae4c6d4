// Option sets that several commands share (scene, light extraction, shadows, sampling) and the
// library structs they translate into, plus each command's register/run pair. Defaults shown in
// help are read from the library's own default structs.
#pragma once

#include "common.hpp"

#ifdef PENUMBRA_HAS_GL
#include <penumbra/gl/interop.hpp>
#endif

#include <memory>
#include <string>

namespace penumbra::cli {

// --scene --env --size --camera --no-ground --load-timeout --load-memory --device, and
// --env-rotate when `rotatable`; the default size is (width, height). sizeFields: the library
// fields --size sets.
void addSceneOptions(CLI::App& app, Registry& reg, int width, int height,
                     std::vector<std::string> sizeFields, bool rotatable = false);
// --extract and its methods' options, --no-ambient, --ambient, --ambient-size, --light-shape,
// --light-texture.
void addExtractOptions(CLI::App& app, Registry& reg);
// --light-set FILE: lights a user defines instead of extracted ones.
void addLightSetOption(CLI::App& app, Registry& reg);
// --quiet: no progress lines.
void addQuietOption(CLI::App& app, Registry& reg);

struct SceneSetup {
  Scene scene;
  Environment env;
  Camera camera;
};
// Loads a map and says on stderr what sanitizing replaced.
Environment loadEnvironmentNoting(const std::string& pathOrBuiltin);
// The camera frames the scene for a width x height image. loadEnv = false leaves s.env empty.
SceneSetup loadSetup(const Args& a, int width, int height, bool loadEnv = true);
// --lights auto: the target error and the most lights when not given.
constexpr double kAutoTargetError = 0.03;
constexpr int kAutoMaxLights = 256;
// The long names of every extraction option (addExtractOptions): any of them asks `reference` for
// the light-set truth, and none may stand beside --light-set.
extern const char* const kExtractionOptionNames[16];
// The extraction options; an option that does not belong to the chosen method is refused.
ExtractOptions parseExtractOptions(const Args& a);
// extractLights; with --lights auto, says on stderr (unless --quiet) which count it chose, each
// count tried and its predicted error, and fixes that count in `eo` (an animation keeps the
// count of its first frame: a count that changed between frames would make shadows pop).
LightSet extractNoting(Context& ctx, const Environment& env, ExtractOptions& eo, const Args& a);
// Loads --light-set into `out` when given (refusing extraction options beside it).
bool userLightSet(const Args& a, LightSet& out);
// The input files a report names ("" for the built-in defaults and extracted lights).
ReportInfo reportInfo(const Args& a);

// The Shadows and Advanced groups of render and evaluate, every default read from RenderOptions.
void addRenderOptions(CLI::App& app, Registry& reg);
RenderOptions parseRenderOptions(const Args& a);
// --spp (minSpp..1048576), --seed, --threads of the Embree truths (reference, evaluate).
void addSamplingOptions(CLI::App& app, Registry& reg, const ReferenceOptions& defaults,
                        int minSpp);
void parseSampling(const Args& a, ReferenceOptions& ro);
// 0 means automatic exposure; an explicit value must be positive.
float parseExposure(const Args& a);

// Renders frames as `render` does: through the GL interop with --gl, and with --accumulate N the
// average of frames 0..N-1 of the bitmask's temporal jitter (rotated light samples).
class FrameRenderer {
 public:
  FrameRenderer(Context& ctx, const Args& a, const RenderOptions& ro);
  Frame render(const Scene& scene, const Camera& camera, const LightSet& lights,
               const Environment& env, const RenderOptions& ro);

 private:
  Renderer renderer_;
  int accumulate_ = 1;
#ifdef PENUMBRA_HAS_GL
  std::unique_ptr<gl::HeadlessContext> glContext_;
  std::unique_ptr<gl::GLRenderer> glRenderer_;
#endif
};

// The commands: each adds its subcommand to the root app, and runs once it is parsed.
CLI::App* addDevicesCommand(CLI::App& root, Registry& reg);
CLI::App* addRenderCommand(CLI::App& root, Registry& reg);
CLI::App* addReferenceCommand(CLI::App& root, Registry& reg);
CLI::App* addCompareCommand(CLI::App& root, Registry& reg);
CLI::App* addEvaluateCommand(CLI::App& root, Registry& reg);
CLI::App* addLightsCommand(CLI::App& root, Registry& reg);
int runDevices(const Args& a);
int runRender(const Args& a);
int runReference(const Args& a);
int runCompare(const Args& a);
int runEvaluate(const Args& a);
int runLights(const Args& a);

}  // namespace penumbra::cli
