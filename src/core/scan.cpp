// Summed-area tables on the device: argument checks, the choice of kernels/common/scan.cl's tuning
// knobs for the device and image, and the four launches (row pass, then the three column steps).
#include "penumbra/scan.hpp"

#include <algorithm>
#include <climits>
#include <string>
#include <vector>

#include "penumbra/context.hpp"
#include "penumbra/error.hpp"
#include "core/device_kind.hpp"

namespace penumbra {

namespace {

const char* kFile = "scan.cl";
// Width and height are ints on the device, and the kernels form y0 + SEG and base + tile without
// widening; a bound far above any real image keeps those sums away from INT_MAX.
constexpr int kMaxSide = 1 << 30;
// Column-pass work-group size: enough adjacent columns for full coalesced transactions.
constexpr std::size_t kColumnWg = 128;

// Default knobs per device class (the CLBlast habit: a table, passed to the kernels as -D).
struct Knobs {
  int minWg, maxWg;  // row-pass work-group range; the choice within it follows the width
  int vpt, seg;
  bool lockstep;     // COL_LOCKSTEP
};
// GPUs: one warp/wavefront at least, 256 at most (beyond that the long4 tile's local memory,
// 42 KiB, crowds out occupancy); 4 values per item keep the padded local accesses conflict-free.
constexpr Knobs kGpuKnobs{32, 256, 4, 64, false};
// CPUs run a group's work-items one after another: few items with long serial runs (fewer tree
// steps and barriers per element) and row-synchronized column steps. Measured on PoCL, 2048^2
// float4: rows ~40 ms with 256 x 4, ~12 ms with 8 x 64; columns see kernels/common/scan.cl.
constexpr Knobs kCpuKnobs{8, 8, 64, 64, true};

// oclgrind, which calls itself a GPU too, gets the GPU table (core/device_kind.hpp).
const Knobs& defaultKnobs(Context& ctx) {
  return detail::isCpuDevice(ctx) ? kCpuKnobs : kGpuKnobs;
}

const char* typeName(ScanType t) {
  switch (t) {
    case ScanType::Float: return "float";
    case ScanType::Float4: return "float4";
    case ScanType::Long: return "long";
    case ScanType::Long4: return "long4";
  }
  badInput("summedAreaTable: unknown ScanType " + std::to_string(int(t)));
}

bool isPow2(long long v) { return v > 0 && (v & (v - 1)) == 0; }

std::size_t nextPow2(std::size_t v) {
  std::size_t p = 1;
  while (p < v) p *= 2;
  return p;
}

std::size_t roundUp(std::size_t v, std::size_t m) { return (v + m - 1) / m * m; }

// Local memory scan_rows declares for these knobs: the padded tile plus the padded per-item totals
// (PAD in scan.cl adds one element per 128 bytes).
std::size_t rowLocalBytes(std::size_t elemBytes, std::size_t wg, std::size_t vpt) {
  std::size_t bankRow = 128 / elemBytes;
  auto padded = [&](std::size_t n) { return (n - 1) + (n - 1) / bankRow + 1; };
  return (padded(wg * vpt) + padded(wg)) * elemBytes;
}

// a * b, or badInput naming `what` if it does not fit in size_t.
std::size_t checkedMul(std::size_t a, std::size_t b, const std::string& what) {
  if (a != 0 && b > SIZE_MAX / a) badInput("summedAreaTable: " + what + " overflows size_t");
  return a * b;
}

std::string options(ScanType type, int wg, int vpt, int seg, bool lockstep) {
  return std::string("-DSCAN_T=") + typeName(type) + " -DWG=" + std::to_string(wg) +
         " -DVPT=" + std::to_string(vpt) + " -DSEG=" + std::to_string(seg) +
         " -DCOL_LOCKSTEP=" + (lockstep ? "1" : "0");
}

// Bands per image for the banded method. More than one band reads the rows above the last band
// once more (step 1), and pays only where the bands' sweeps run side by side with memory bandwidth
// to spare. With two compute units they do not: one float4 image, medians of 100 tables each
// (2-core EPYC, PoCL 3.1), 1024^2 in one band 0.73-0.78 ms against 1.23-1.28 in four (the four
// sweeps alone 0.79-1.01: the second core adds little bandwidth), 2048^2 3.9-4.4 against 5.1-5.5,
// 256^2 39 us against 50 in two (its second work-group starts after the first has finished:
// the sweep is shorter than a worker thread's wake-up). So up to two units each image is one
// band. With more, one band per unit over the batch (a batch with that many images keeps one band
// each), but no more bands than the batch has MiB over 2 (the extra launch costs about what
// sweeping 2 MiB takes on PoCL).
int defaultBands(Context& ctx, int batch, std::size_t batchBytes) {
  const long long units = (long long)detail::computeUnits(ctx);
  if (units <= 2) return 1;
  const long long worth = std::max<long long>(1, (long long)(batchBytes >> 21));
  return int(std::max<long long>(1, std::min((units + batch - 1) / batch, worth)));
}

// The banded one-pass method (kernels/common/scan.cl, "Banded one-pass method"): `bands` bands
// per image (1 <= bands <= height). With doubleSums (float types on an fp64 device) the sums are
// carried in double (scan.cl, "accumulated in double"): the band sums are then also the sweep's
// carry rows, so they are allocated for every band and the sweep is scan_band_apply_acc. Stages:
// STAGE/bands/offsets with more than one band, then STAGE/bands.
void bandedTable(Context& ctx, cl::Buffer& data, ScanType type, int width, int height, int batch,
                 int bands, bool doubleSums, const std::string& stage) {
  std::string opts = options(type, 1, 1, 1, false);  // the pass knobs are unused here
  std::size_t accBytes = scanElementBytes(type);
  if (doubleSums) {
    const bool four = type == ScanType::Float4;
    opts += four ? " -DSCAN_ACC=double4 -DTO_ACC=convert_double4 -DFROM_ACC=convert_float4"
                 : " -DSCAN_ACC=double -DTO_ACC=convert_double -DFROM_ACC=convert_float";
    accBytes = (four ? 4 : 1) * sizeof(cl_double);
  }
  const int bandRows = (height + bands - 1) / bands;
  bands = (height + bandRows - 1) / bandRows;  // no empty band
  const std::size_t sumsElems =
      bands > 1 || doubleSums
          ? checkedMul(checkedMul(std::size_t(bands), std::size_t(batch), "band count"),
                       std::size_t(width), "band-sum count")
          : 1;  // one band: the sums are never read, the one element keeps the argument valid
  cl::Buffer sums = ctx.buffer(checkedMul(sumsElems, accBytes, "band-sum bytes"),
                               stage + " band sums");
  if (bands > 1) {
    // step 1's strips: two per compute unit over the batch, each at least one column
    const std::size_t strips = std::clamp<std::size_t>(
        (2 * detail::computeUnits(ctx) + batch - 1) / batch, 1, std::size_t(width));
    cl::Kernel offK = ctx.kernel(kFile, "scan_band_offsets", opts);
    ctx.launchWith(stage + "/bands/offsets", offK, cl::NDRange(strips, batch), cl::NDRange(1, 1),
                   data, sums, cl_int(width), cl_int(height), cl_int(bandRows));
  }
  if (doubleSums) {
    // the last argument is the 1.0 of scan.cl's ACC_ADD, given at run time so that it stays a
    // fused multiply-add
    cl::Kernel applyK = ctx.kernel(kFile, "scan_band_apply_acc", opts);
    ctx.launchWith(stage + "/bands", applyK, cl::NDRange(bands, batch), cl::NDRange(1, 1), data,
                   sums, cl_int(width), cl_int(height), cl_int(bandRows), cl_double(1.0));
  } else {
    cl::Kernel applyK = ctx.kernel(kFile, "scan_band_apply", opts);
    ctx.launchWith(stage + "/bands", applyK, cl::NDRange(bands, batch), cl::NDRange(1, 1), data,
                   sums, cl_int(width), cl_int(height), cl_int(bandRows));
  }
}

}  // namespace

std::size_t scanElementBytes(ScanType t) {
  switch (t) {
    case ScanType::Float: return sizeof(cl_float);
    case ScanType::Float4: return sizeof(cl_float4);
    case ScanType::Long: return sizeof(cl_long);
    case ScanType::Long4: return sizeof(cl_long4);
  }
  badInput("summedAreaTable: unknown ScanType " + std::to_string(int(t)));
}

void summedAreaTable(Context& ctx, cl::Buffer& data, ScanType type, int width, int height,
                     int batch, const std::string& stage) {
  summedAreaTable(ctx, data, type, width, height, batch, stage, ScanTuning{});
}

void summedAreaTable(Context& ctx, cl::Buffer& data, ScanType type, int width, int height,
                     int batch, const std::string& stage, const ScanTuning& tuning) {
  // --- arguments -------------------------------------------------------------------------------
  const std::size_t elemBytes = scanElementBytes(type);
  if (width < 1) badInput("summedAreaTable: width must be >= 1, got " + std::to_string(width));
  if (height < 1) badInput("summedAreaTable: height must be >= 1, got " + std::to_string(height));
  if (batch < 1) badInput("summedAreaTable: batch must be >= 1, got " + std::to_string(batch));
  if (width > kMaxSide)
    badInput("summedAreaTable: width " + std::to_string(width) + " exceeds the limit 2^30");
  if (height > kMaxSide)
    badInput("summedAreaTable: height " + std::to_string(height) + " exceeds the limit 2^30");
  const std::string dims = std::to_string(width) + "x" + std::to_string(height) + "x" +
                           std::to_string(batch) + " " + typeName(type);
  const std::size_t rows = checkedMul(std::size_t(height), std::size_t(batch),
                                      "height*batch (" + dims + ")");
  const std::size_t elements = checkedMul(rows, std::size_t(width), "element count (" + dims + ")");
  const std::size_t bytes = checkedMul(elements, elemBytes, "byte size (" + dims + ")");
  if (!data()) badInput("summedAreaTable: data buffer is null");
  std::size_t have = 0;
  try {
    have = data.getInfo<CL_MEM_SIZE>();
  } catch (const cl::Error& e) {
    rethrowCl(e, "summedAreaTable: querying the data buffer's size");
  }
  if (have < bytes)
    badInput("summedAreaTable: data buffer holds " + std::to_string(have) + " bytes but " + dims +
             " needs " + std::to_string(bytes) + " (" + std::to_string(elemBytes) +
             " bytes per element: wrong ScanType or size?)");
  if (tuning.workGroup < 0 || tuning.valuesPerItem < 0 || tuning.segmentRows < 0 ||
      tuning.columnLockstep < -1 || tuning.columnLockstep > 1 || tuning.bands < -1)
    badInput("summedAreaTable: tuning values out of range (workGroup " +
             std::to_string(tuning.workGroup) + ", valuesPerItem " +
             std::to_string(tuning.valuesPerItem) + ", segmentRows " +
             std::to_string(tuning.segmentRows) + ", columnLockstep " +
             std::to_string(tuning.columnLockstep) + ", bands " + std::to_string(tuning.bands) +
             ")");
  if (tuning.workGroup > 0 && !isPow2(tuning.workGroup))
    badInput("summedAreaTable: tuning.workGroup must be a power of two, got " +
             std::to_string(tuning.workGroup));
  if (tuning.workGroup > 0 && std::size_t(tuning.workGroup) > ctx.info().maxWorkGroupSize)
    badInput("summedAreaTable: tuning.workGroup " + std::to_string(tuning.workGroup) +
             " exceeds the work-group limit " + std::to_string(ctx.info().maxWorkGroupSize) +
             " of " + ctx.info().name);
  if (tuning.valuesPerItem > 64 || tuning.segmentRows > kMaxSide)
    badInput("summedAreaTable: tuning.valuesPerItem " + std::to_string(tuning.valuesPerItem) +
             " (max 64) or segmentRows " + std::to_string(tuning.segmentRows) + " too large");

  // --- knobs -----------------------------------------------------------------------------------
  const Knobs& knobs = defaultKnobs(ctx);
  const bool integer = type == ScanType::Long || type == ScanType::Long4;
  // float tables sweep in bands only where the device can carry their sums in double
  const bool doubleSums = !integer && ctx.info().fp64;
  int bands = tuning.bands;
  if (bands < 0)
    bands = detail::useCpuBatching(ctx) && (integer || doubleSums) ? defaultBands(ctx, batch, bytes)
                                                                    : 0;
  if (bands > 0) {
    bandedTable(ctx, data, type, width, height, batch, std::min(bands, height), doubleSums, stage);
    return;
  }
  const int vpt = tuning.valuesPerItem ? tuning.valuesPerItem : knobs.vpt;
  const int seg = tuning.segmentRows ? tuning.segmentRows : knobs.seg;
  const bool lockstep = tuning.columnLockstep < 0 ? knobs.lockstep : tuning.columnLockstep != 0;
  std::size_t localMem = 0;
  try {
    localMem = ctx.device().getInfo<CL_DEVICE_LOCAL_MEM_SIZE>();
  } catch (const cl::Error& e) {
    rethrowCl(e, "summedAreaTable: querying local memory size");
  }
  // Automatic row-pass work-group: just enough work-items to cover a row in one tile (narrow
  // images waste no lanes), within the device's work-group and local-memory limits.
  std::size_t wg = tuning.workGroup;
  if (!wg) {
    wg = nextPow2((std::size_t(width) + vpt - 1) / vpt);
    wg = std::clamp<std::size_t>(wg, knobs.minWg, knobs.maxWg);
    wg = std::min(wg, nextPow2(ctx.info().maxWorkGroupSize + 1) / 2);
    while (wg > 1 && rowLocalBytes(elemBytes, wg, vpt) > localMem) wg /= 2;
  }
  if (rowLocalBytes(elemBytes, wg, vpt) > localMem)
    badInput("summedAreaTable: row pass with work-group " + std::to_string(wg) + " x " +
             std::to_string(vpt) + " values of " + typeName(type) + " needs " +
             std::to_string(rowLocalBytes(elemBytes, wg, vpt)) + " bytes of local memory; " +
             ctx.info().name + " has " + std::to_string(localMem));
  // The kernel may still accept fewer work-items than the device maximum (registers); the
  // automatic choice steps down, an explicit one is the caller's error.
  cl::Kernel rowsK;
  for (;;) {
    rowsK = ctx.kernel(kFile, "scan_rows", options(type, int(wg), vpt, seg, lockstep));
    std::size_t limit = 0;
    try {
      limit = rowsK.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(ctx.device());
    } catch (const cl::Error& e) {
      rethrowCl(e, "summedAreaTable: querying scan_rows' work-group limit");
    }
    if (wg <= limit) break;
    if (tuning.workGroup || wg == 1)
      badInput("summedAreaTable: tuning.workGroup " + std::to_string(wg) + " exceeds the limit " +
               std::to_string(limit) + " of scan_rows on " + ctx.info().name);
    wg /= 2;
  }
  const std::string opts = options(type, int(wg), vpt, seg, lockstep);
  const std::size_t nseg = (std::size_t(height) + seg - 1) / seg;
  const std::size_t segRows = checkedMul(nseg, std::size_t(batch), "segment count");
  const std::size_t rowGlobal = checkedMul(rows, wg, "row-pass global size");

  // --- row pass --------------------------------------------------------------------------------
  // Arguments in kernels/common/scan.cl's order; launchWith checks their count against the
  // kernel's.
  ctx.launchWith(stage + "/rows", rowsK, cl::NDRange(rowGlobal), cl::NDRange(wg), data,
                 cl_int(width));

  // --- column pass -----------------------------------------------------------------------------
  cl::Kernel applyK = ctx.kernel(kFile, "scan_col_apply", opts);
  // Narrow images take a narrower group so that padding columns stay few.
  const std::size_t cwg = std::min(ctx.workGroupSize(applyK, kColumnWg), nextPow2(width));
  const std::size_t colGlobal = roundUp(std::size_t(width), cwg);
  // seg_sums is only read with more than one segment; one element keeps the argument valid.
  const std::size_t sumsElems =
      nseg > 1 ? checkedMul(segRows, std::size_t(width), "segment-sum count") : 1;
  const std::size_t sumsBytes = checkedMul(sumsElems, elemBytes, "segment-sum bytes");
  cl::Buffer segSums = ctx.buffer(sumsBytes, stage + " segment sums");
  // Step 1 writes every segment sum before steps 2 and 3 read it, so real devices need no
  // initialization. The oclgrind 21.10 simulator does: its --uninitialized plugin keeps the shadow
  // state of released buffers, and a new buffer that reuses a slot inherits the old, possibly
  // smaller shadow, so kernel writes past the old size go unrecorded and later reads are reported
  // as uninitialized. Only a full-size host write replaces that shadow (a fill does not).
  if (ctx.info().platform.find("Oclgrind") != std::string::npos) {
    std::vector<unsigned char> zeros(sumsBytes);
    ctx.write(segSums, zeros.data(), sumsBytes, stage + " segment sums");
  }
  if (nseg > 1) {
    cl::Kernel segK = ctx.kernel(kFile, "scan_col_segments", opts);
    cl::Kernel offK = ctx.kernel(kFile, "scan_col_offsets", opts);
    const std::size_t swg = std::min(cwg, ctx.workGroupSize(segK, kColumnWg));
    const std::size_t owg = std::min(cwg, ctx.workGroupSize(offK, kColumnWg));
    ctx.launchWith(stage + "/cols/segments", segK, cl::NDRange(roundUp(width, swg), nseg, batch),
                   cl::NDRange(swg, 1, 1), data, segSums, cl_int(width), cl_int(height));
    ctx.launchWith(stage + "/cols/offsets", offK, cl::NDRange(roundUp(width, owg), batch),
                   cl::NDRange(owg, 1), segSums, cl_int(width), cl_int(nseg));
  }
  ctx.launchWith(stage + "/cols", applyK, cl::NDRange(colGlobal, nseg, batch),
                 cl::NDRange(cwg, 1, 1), data, segSums, cl_int(width), cl_int(height));
}

}  // namespace penumbra
