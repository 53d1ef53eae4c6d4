/// \file
/// Summed-area tables (2D inclusive prefix sums) on the device, for batches of equally sized images.
///
/// Element types: float, float4 (general use) and int64 / int64x4 fixed point (precision-safe; see
/// kernels/common/scan.cl for why moments and environment energies use it).
#pragma once
#include "penumbra/context.hpp"
#include <string>

namespace penumbra {

class Context;

enum class ScanType { Float, Float4, Long, Long4 };
std::size_t scanElementBytes(ScanType t);

/// In-place 2D inclusive scan of `batch` images of width x height elements, stored one after the
/// other (image b starts at element b*width*height, rows contiguous). Stage names are prefixed
/// with `stage` ("sat" by default). Throws Error(BadInput) for zero or overflowing sizes.
void summedAreaTable(Context& ctx, cl::Buffer& data, ScanType type, int width, int height,
                     int batch = 1, const std::string& stage = "sat");

/// How summedAreaTable divides the work (the -D tuning knobs of kernels/common/scan.cl). 0 (-1 for
/// columnLockstep) means "choose for the device and image": the default overload always does that,
/// from a GPU or a CPU table in src/core/scan.cpp. The Long/Long4 results are bit-identical for
/// every choice; the Float/Float4 ones differ in rounding only.
struct ScanTuning {
  int workGroup = 0;        ///< row-pass work-items per row, a power of two (GPU: 32..256 by width;
                            ///< CPU: 8)
  int valuesPerItem = 0;    ///< elements each work-item scans serially per tile (GPU 4, CPU 64)
  int segmentRows = 0;      ///< rows per column segment in the column pass (default 64)
  int columnLockstep = -1;  ///< 1: column steps synchronize each row (CPU default), 0: not (GPU)
  /// The banded one-pass method instead of the row and column passes: each image's rows in this
  /// many bands, each swept top to bottom by one work-item (kernels/common/scan.cl). 0: the
  /// passes; -1: the device's choice (CPUs: banded, with enough bands to give every compute unit
  /// two sweeps, for Long/Long4 and, on devices with fp64, for Float/Float4, whose sums the sweep
  /// then carries in double and rounds once per value; GPUs, and float types without fp64: the
  /// passes; PENUMBRA_CPU_BATCHING=off or on forces the passes or the banded method on any
  /// device). Float tables banded without fp64 add in float along whole rows and bands. The other
  /// knobs apply to the passes only.
  int bands = -1;
};

/// As above with explicit tuning; throws Error(BadInput) for a work-group size the kernel or the
/// device's local memory cannot take, or values < 0. Width and height are limited to 2^30.
void summedAreaTable(Context& ctx, cl::Buffer& data, ScanType type, int width, int height,
                     int batch, const std::string& stage, const ScanTuning& tuning);

}  // namespace penumbra
