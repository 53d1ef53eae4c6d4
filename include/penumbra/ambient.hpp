/// \file
/// The ambient residual of a light set (Arbree et al. 2005 §3; Ramamoorthi & Hanrahan 2001): what
/// the lights
/// do not carry, the map minus the lights, applied unshadowed. Its representation
/// (LightSet::ambientSH, LightSet::ambientMap) is part of the light set (lights.hpp); this header
/// computes it.
#pragma once
#include <string>

#include "penumbra/lights.hpp"

namespace penumbra {

class Context;
struct Environment;

/// How the ambient residual is represented for shading.
///   IrradianceMap: the residual's irradiance tabulated over normals (LightSet::ambientMap, seed
///                  004's pre-integrated irradiance map): exact at the table's normals, bilinear
///                  between them; lights + ambient reproduce the map's irradiance on every normal
///                  to the table's interpolation error (tests/test_ambient.cpp measures it).
///   SH9:           the residual's radiance as 9 SH coefficients only (R&H 2001): smooth, but
///                  it drops the residual's bands l >= 3, up to several % of the irradiance.
enum class AmbientModel { IrradianceMap, SH9 };
AmbientModel parseAmbientModel(const std::string& name);  // "map" | "sh9"
const char* toString(AmbientModel m);
struct AmbientOptions {
  AmbientModel model = AmbientModel::IrradianceMap;
  /// Table size (IrradianceMap), texels; each in 1..1024. Default 128 x 64, chosen by measurement
  /// (lights + ambient against the map's irradiance on 26 + 200 random normals, every method and
  /// test map, two random sets): the worst error is 2.9% at 64 x 32, 1.8% at 80 x 40 and
  /// 96 x 48, 1.4% at 128 x 64 (interior.exr, center-surround), 1.3% at 160 x 80; it falls
  /// slower than the square of the spacing because compact bright sources left
  /// in the residual, and lights whose shape differs from their region, make the irradiance kink
  /// where their horizon passes, which bilinear interpolation resolves only to first order.
  int mapWidth = 128, mapHeight = 64;
};

/// Sets set.ambientSH to SH9(map) - sum of SH9(each light), computed on the device, and
/// set.hasAmbient = true; with AmbientModel::IrradianceMap also set.ambientMap (on the device,
/// kernels/environment/irradiance.cl), else clears it. Honours env.rotationYDeg. Throws
/// Error(BadInput) for a table size outside 1..1024.
void addAmbientResidual(Context& ctx, const Environment& env, LightSet& set,
                        const AmbientOptions& opt = {});

}  // namespace penumbra
