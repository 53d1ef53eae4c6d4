// Internal: the shadow options (include/penumbra/options.hpp) as the techniques use them: their
// checks, the one form of their errors, and the shared settings' copy into a parameter block. Each technique checks its own struct beside its definition (the .cpp named
// below), when it runs; the settings they share are checked once per frame (Renderer::render).
// A message names the field as a path from RenderOptions ("RenderOptions.cssm.order must be in
// [1, 32], got 40"): the CLI and the Python module rewrite such paths into their flag or keyword.
#pragma once
#include <string>

#include "penumbra/options.hpp"

namespace penumbra::detail {

// Throws Error(BadInput): "<field> must <rule>, got <value>".
[[noreturn]] void badOption(const std::string& field, const std::string& rule, double value);
// An integer field in [lo, hi]: "<field> must be in [lo, hi], got <value>".
void checkRange(const std::string& field, long long value, long long lo, long long hi);

void validate(const ShadowOptions& o);                // src/shadows/shadow_options.cpp
void validate(const MSSMOptions& o);                  // src/shadows/mssm.cpp (MSSM4, MSSM6)
void validate(const CSSMOptions& o);                  // src/shadows/cssm.cpp
void validate(const PCSSOptions& o);                  // src/shadows/pcss.cpp
void validate(const BruteOptions& o);                 // src/shadows/brute.cpp
void validate(const BitmaskOptions& o, bool hard);    // src/shadows/bitmask.cpp
void validate(const AreaApproxOptions& o);            // src/shadows/area.cpp
void validate(const AutoOptions& o);                  // src/shadows/auto.cpp

// The light-size scale and filter limits every filtered technique reads, into its kernel
// parameter block (shadows/shadow_params.h: mssm_params, cssm_params, pcss_params).
template <class Params>
void setFilterLimits(Params& p, const ShadowOptions& o) {
  p.light_size_scale = o.lightSizeScale;
  p.max_filter = o.maxFilterTexels;
  p.min_filter = o.minFilterTexels;
}

}  // namespace penumbra::detail
