// Embree shadow rays for explicit origins and directions (src/bitmask.hpp's SampleTracer): the
// bitmask technique's light samples are checked ray by ray against them, in the references' own
// Embree scene (src/embree_scene.hpp: every mesh's triangles, two-sided, inputs checked).
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
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r;
  r.org_x = o[0];
  r.org_y = o[1];
  r.org_z = o[2];
  r.dir_x = d[0];
  r.dir_y = d[1];
  r.dir_z = d[2];
  r.tnear = tnear;
  r.tfar = std::numeric_limits<float>::infinity();
  r.time = 0.0f;
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
  rtcOccluded1(impl_->embree.get(), &ctx, &r);
  return r.tfar < 0.0f;  // Embree sets tfar to -inf on a hit
}

}  // namespace penumbra::detail
