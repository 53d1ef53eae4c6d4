/// \file
/// HDR environment maps: loading (EXR, Radiance HDR, PFM through OpenImageIO), sanitizing, the
/// built-in sky, and the resampling to a cube map on the device.
///
/// Direction convention: y up; see pb_equirect_dir / pb_dir_equirect in shared.h.
#pragma once
#include <cstdint>
#include <string>

#include "penumbra/image.hpp"

namespace penumbra {

class Context;

struct Environment {
  std::string source;        ///< file path or "builtin"
  Image equirect;            ///< RGB, linear radiance, width = 2*height is typical but not required
  std::int64_t sanitizedPixels = 0;  ///< pixels whose NaN/Inf/negative values were replaced
  std::int64_t nonFiniteValues = 0;  ///< channel values that were NaN or Inf (set to 0)
  std::int64_t negativeValues = 0;   ///< channel values below 0 (clamped to 0)
  /// The map turned by this angle (degrees) about +y: positive is counter-clockwise seen from
  /// above (the right-handed sense, +x towards -z), so what the file shows at azimuth phi appears
  /// at phi - rotationYDeg. Default 0 (the file as it is). Honoured by lookup, irradiance, the
  /// device cube map (and so every light extraction), the rendered background and the Embree
  /// reference; power() does not change. Any finite value; whole turns are exactly the identity.
  float rotationYDeg = 0.0f;

  /// Radiance along a world direction (nearest texel of the rotated map), used by the reference
  /// and for backgrounds.
  void lookup(float x, float y, float z, float rgb[3]) const;
  /// Solid angle of equirect texel row t (exact: (2 pi / W) (cos theta0 - cos theta1)).
  double texelSolidAngle(int row) const;
  /// Integral of radiance over the sphere, per channel (sum of L * texel solid angle).
  void power(double rgb[3]) const;
  /// Irradiance on a surface with unit normal n: sum of L max(0, n.w) dw over the texels.
  void irradiance(const float n[3], double rgb[3]) const;
  /// The rotation as a shift of equirect columns in [0, width): world column s shows map column
  /// s + shift (pb_env_column in shared.h). Throws Error(BadInput) for a non-finite rotation.
  float rotationColumns() const;
  /// A copy whose pixels are the rotated map (nearest texel per world column, exact for whole-column
  /// shifts) and whose rotationYDeg is 0: for host code that reads `equirect` directly.
  Environment withRotationApplied() const;
};

/// Loads and sanitizes a map. Throws Error(BadInput) naming the file for unreadable, truncated,
/// non-image, or zero-sized input. One-pixel maps are legal (a constant environment). Float maps
/// (EXR, HDR, PFM) are linear radiance; an LDR image (PNG, JPEG) is accepted by design and decoded
/// from sRGB to linear (readImage's `linearize`), though its range ends at 1.
Environment loadEnvironment(const std::string& path);

/// A procedural sky that needs no file: a sun of about 0.5 degrees, a blue sky gradient, a bright
/// area near the horizon and a darker ground. Deterministic; `width` x width/2 texels.
Environment builtinEnvironment(int width = 512);

/// The map resampled to a cube map on the device (kernels/environment/envmap.cl), as radiant energy
/// per texel (radiance x solid angle): RGB, the six faces stacked vertically (width m, height 6m;
/// face f in rows f*m .. f*m+m-1), oriented as pb_cube_dir in shared.h. Radiance is energy /
/// pb_cube_texel_solid_angle. `supersample` caps the sub-samples per side. The sum over all texels
/// is the map's power (to float rounding) when the map is at least 4 faces wide (each map texel is
/// splatted with its exact solid angle); a narrower map is gathered by sub-samples, which is
/// approximate (a 64x32 sky at face 64 loses 1.4% of its power: bindings/python/tests/
/// test_lights.py). Throws Error(BadInput) for faceSize outside [1, 4096].
Image cubeMapEnergy(Context& ctx, const Environment& env, int faceSize, int supersample = 4);

/// "builtin" -> builtinEnvironment(), anything else -> loadEnvironment(path).
Environment environmentFrom(const std::string& pathOrBuiltin);

}  // namespace penumbra
