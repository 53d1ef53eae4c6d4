// Embree shadow rays for explicit origins and directions (src/shadows/bitmask.hpp's SampleTracer):
// the bitmask technique's light samples are checked ray by ray against them, in the references' own
// Embree scene (src/reference/embree_scene.hpp: every mesh's triangles, two-sided, inputs checked).
#include <embree3/rtcore.h>

#include <limits>
#include <string>

#include "shadows/bitmask.hpp"
#include "reference/embree_scene.hpp"
#include "penumbra/error.hpp"

namespace penumbra::detail {

struct SampleTracer::Impl {
  FlatScene flat;
  EmbreeScene embree;
  explicit Impl(const Scene& s) : flat(flatten(s)), embree(flat, 0) {}
};

SampleTracer::SampleTracer(const Scene& s) : impl_(std::make_unique<Impl>(s)) {}

SampleTracer::~SampleTracer() = default;

bool SampleTracer::occluded(const std::array<float, 3>& o, const std::array<float, 3>& d,
                            float tnear) const {
  return rayOccluded(impl_->embree.get(), o, d, tnear);
}

}  // namespace penumbra::detail
