// Internal: a cap light's axis and extent from luminance moments, as median cut resolves a region
// on the device (kernels/environment/extract.cl resolve_lights), for the host extractors (greedy
// fitting, median cut's bright sources).
#pragma once
#include <algorithm>
#include <array>
#include <cmath>

namespace penumbra::detail {

// Y: the luminance summed over the light's texels (times their solid angles); m: the same sum of
// luminance times each texel's unit direction. The axis is the luminance-weighted mean direction
// m / |m| (Kneiphof 2017 eq. 9, on the sphere), and a uniform cap of half-angle a has mean
// resultant length R = (1 + cos a) / 2, so cos a = 2R - 1 with R = |m| / Y (eq. 10). Returns false,
// writing nothing, when Y or |m| is 0 (no luminance, or directions that cancel).
inline bool capFromMoments(double Y, double mx, double my, double mz, std::array<float, 3>& axis,
                           float& cosA) {
  const double len = std::sqrt(mx * mx + my * my + mz * mz);
  if (!(Y > 0 && len > 0)) return false;
  axis = {float(mx / len), float(my / len), float(mz / len)};
  cosA = float(2.0 * std::min(1.0, len / Y) - 1.0);
  return true;
}

}  // namespace penumbra::detail
