// Internal: whether a context's device is a CPU, for the kernels that run differently there
// (a CPU driver such as PoCL runs a work-group's work-items one after another on one core and
// vectorizes only what it can prove: serial sweeps and explicit SIMD loops beat work-item
// parallelism there). A device that also calls itself a GPU (oclgrind reports every type) counts
// as a GPU, so that the simulator checks what GPUs run.
#pragma once
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <string>

#include "penumbra/context.hpp"
#include "penumbra/error.hpp"

namespace penumbra::detail {

inline bool isCpuDevice(Context& ctx) {
  cl_device_type type = 0;
  try {
    type = ctx.device().getInfo<CL_DEVICE_TYPE>();
  } catch (const cl::Error& e) {
    rethrowCl(e, "querying the device type");
  }
  return (type & CL_DEVICE_TYPE_CPU) && !(type & CL_DEVICE_TYPE_GPU);
}

// The device's compute units (at least 1): its cores on a CPU driver, the tuning hint the CPU
// forms size their work by (the rasterizer's views, the summed-area tables' bands).
inline std::size_t computeUnits(Context& ctx) {
  cl_uint units = 1;
  try {
    units = ctx.device().getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>();
  } catch (const cl::Error& e) {
    rethrowCl(e, "querying the compute units");
  }
  return units > 0 ? units : 1;
}

// Whether to run the CPU forms of the kernels that have one (the banded summed-area tables, MSSM4's
// batched visibility, batched shading, the bitmask's lists and resolve, the ground and horizon
// steps, contact shadows, the G-buffer's resolve, ...): on CPU devices. PENUMBRA_CPU_BATCHING=off
// (exactly) asks for the one-work-item-per-pixel kernels GPUs run on any device (the same images:
// a check, and a way around a driver that mis-vectorizes), =on for the CPU forms on any device
// (the tests run them under oclgrind, which calls itself a GPU).
inline bool useCpuBatching(Context& ctx) {
  const char* v = std::getenv("PENUMBRA_CPU_BATCHING");
  if (v && std::strcmp(v, "off") == 0) return false;
  if (v && std::strcmp(v, "on") == 0) return true;
  return isCpuDevice(ctx);
}

// Build option of the CPU forms' kernels: their SIMD loops stay scalar on oclgrind
// (kernels/common/shared.h, PB_SIMD_LOOP).
inline std::string simdLoopOption(Context& ctx) {
  return ctx.info().platform.find("Oclgrind") != std::string::npos ? " -DPB_NO_SIMD_LOOPS" : "";
}

// A CPU form whose work-item takes `group` consecutive pixels (or texels, rows' runs, ...): its
// build options (the group size as -D<macro>, which overrides the kernel's #ifndef default, and
// simdLoopOption) and its work-item count over n of them.
inline std::string cpuFormOptions(Context& ctx, const char* macro, int group) {
  return std::string(" -D") + macro + "=" + std::to_string(group) + simdLoopOption(ctx);
}
inline std::size_t cpuFormItems(std::size_t n, int group) {
  return (n + std::size_t(group) - 1) / std::size_t(group);
}

// Kernel `name` of `file` over n pixels (or rows' pixels), or on CPU devices its CPU form
// `name`_batch, built with cpuFormOptions(macro, group) after `options`: the kernel to launch and
// its work-item count along the pixels (n, or cpuFormItems(n, group)).
struct KernelForm {
  cl::Kernel kernel;
  std::size_t items;
};
inline KernelForm kernelForm(Context& ctx, const std::string& file, const std::string& name,
                             const char* macro, int group, std::size_t n,
                             const std::string& options = "") {
  if (useCpuBatching(ctx))
    return {ctx.kernel(file, name + "_batch", options + cpuFormOptions(ctx, macro, group)),
            cpuFormItems(n, group)};
  return {ctx.kernel(file, name, options), n};
}

}  // namespace penumbra::detail
