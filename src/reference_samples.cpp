// Embree shadow rays for explicit origins and directions (src/bitmask.hpp's SampleTracer): the
// bitmask technique's light samples are checked ray by ray against them. The scene is flattened
// as src/reference.cpp flattens it (every mesh's triangles, two-sided).
#include <embree3/rtcore.h>

#include <limits>
#include <string>

#include "bitmask.hpp"
#include "penumbra/error.hpp"

namespace penumbra::detail {

struct SampleTracer::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

SampleTracer::SampleTracer(const Scene& s) : impl_(std::make_unique<Impl>()) {
  std::size_t nv = 0, nt = 0;
  for (const Mesh& m : s.meshes) {
    nv += m.positions.size();
    nt += m.triangles.size();
  }
  if (nt == 0) badInput("scene has no triangles");
  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device) throw Error(ErrorKind::Internal, "Embree: rtcNewDevice failed");
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry g = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0,
                                                        RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
  auto* ix = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), nt));
  if (!v || !ix) {
    rtcReleaseGeometry(g);
    throw Error(ErrorKind::Internal, "Embree: geometry buffer allocation failed");
  }
  unsigned base = 0;
  for (const Mesh& m : s.meshes) {
    for (const Vec3& p : m.positions) {
      *v++ = p[0];
      *v++ = p[1];
      *v++ = p[2];
    }
    for (const auto& t : m.triangles) {
      *ix++ = base + unsigned(t[0]);
      *ix++ = base + unsigned(t[1]);
      *ix++ = base + unsigned(t[2]);
    }
    base += unsigned(m.positions.size());
  }
  rtcCommitGeometry(g);
  rtcAttachGeometry(impl_->scene, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(impl_->device) != RTC_ERROR_NONE)
    throw Error(ErrorKind::Internal, "Embree: scene build failed");
}

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
  rtcOccluded1(impl_->scene, &ctx, &r);
  return r.tfar < 0.0f;  // Embree sets tfar to -inf on a hit
}

}  // namespace penumbra::detail
