#!/usr/bin/env python3
"""Mutation check: does the test suite notice a deliberate fault?

Copies the working tree (tracked and untracked, not ignored files) to a scratch directory beside
the checkout (penumbra-mutants/; with ccache and CCACHE_BASEDIR set above both, an earlier build of
the checkout is reused), builds it once, and checks that the tests each fault names PASS on the unmodified copy. Then, for each
fault in FAULTS, it replaces one exact piece of source text with a wrong one (a technique swapped,
a flag wired to the wrong field, a metric scaled, an ambient dropped, a light direction flipped,
an index off by one in a kernel...), rebuilds, runs the tests the fault names, and restores the
file. A fault is KILLED when those tests fail (or time out), SURVIVED when they pass: a surviving
fault is a regression the suite would let through.

Each fault names the tests a developer would run after touching that code (a GoogleTest filter
and/or pytest node ids), not the whole suite, so that a run stays near half an hour on 2 cores.
Every fault's original text must occur exactly once in its file: when the code moves, the check
says so instead of silently mutating nothing.

Run on demand, not in CI (README, "Testing the tests"):

    /usr/bin/python3 tools/mutation_check.py                # every fault
    /usr/bin/python3 tools/mutation_check.py --list         # what the faults are
    /usr/bin/python3 tools/mutation_check.py --only cli-depth-bias-field,shade-ambient-dropped

Exit status: 0 when every fault is killed, 1 when one survives, 2 on a usage or setup error.
Only the Python standard library is used; ccache is used when it is on PATH.
"""

import argparse
import os
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Optional


@dataclass
class Fault:
    id: str
    what: str  # the fault, in words
    path: str  # file, relative to the repository root
    old: str  # exact text, must occur once
    new: str  # its replacement
    gtest: Optional[str] = None  # --gtest_filter for penumbra_tests
    pytest: List[str] = field(default_factory=list)  # pytest node ids under bindings/python/tests


FAULTS = [
    # ---- kernels ---------------------------------------------------------------------------------
    Fault("scan-carry", "SAT row scan forgets the running total of earlier tiles (rows longer than a work-group)",
          "kernels/common/scan.cl", "    carry += total;", "    carry = total;",
          gtest="Scan.*AwkwardSizes:Scan.BatchImagesDoNotLeak"),
    Fault("contained-handlers-kept", "the contained child keeps the parent's crash handlers (libLLVM's returns from a raised SIGSEGV)",
          "src/core/contained.cpp",
          "  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) ::signal(sig, SIG_DFL);",
          "",
          gtest="Contained.*"),
    Fault("bitmask-deferred-stats-stale", "the bitmask's statistics keep the last frame's figures once its read-back is queued",
          "src/shadows/bitmask.cpp",
          "    st.meanList = st.occupiedTexels ? double(st.viewSamples) / double(st.occupiedTexels) : 0.0;\n    stats_ = st;",
          "    st.meanList = st.occupiedTexels ? double(st.viewSamples) / double(st.occupiedTexels) : 0.0;\n    if (stats_.texels == 0) stats_ = st;",
          gtest="BitmaskReport.*"),
    Fault("horizon-mean-all-miscounted", "the horizon step's mean over more than 32 sources divides by one too many",
          "kernels/render/horizon.cl",
          "  return sum / (float)count;",
          "  return sum / (float)(count + 1);",
          gtest="Horizon.*"),
    Fault("scan-band-strip-short", "the bands' offsets leave each column strip's last column unsummed",
          "kernels/common/scan.cl",
          "const int x1 = (int)((long)width * (strip + 1) / nstrips);",
          "const int x1 = (int)((long)width * (strip + 1) / nstrips) - 1;",
          gtest="Scan.Banded*"),
    Fault("scan-band-offsets-row-dropped", "the bands' offsets skip one row of each four-row step",
          "kernels/common/scan.cl",
          "next[x] = next[x] + TO_ACC(row[x]) + TO_ACC(r1[x]) + TO_ACC(r2[x]) + TO_ACC(r3[x]);",
          "next[x] = next[x] + TO_ACC(row[x]) + TO_ACC(r1[x]) + TO_ACC(r2[x]);",
          gtest="Scan.Banded*"),
    Fault("scan-acc-one-not-one", "the float tables' sweep is given 2 where its fused additions need 1.0 (read where the kernel compiler defines __FMA__, as PoCL on x86 does)",
          "src/core/scan.cpp",
          "cl_int(bandRows), cl_double(1.0));",
          "cl_int(bandRows), cl_double(2.0));",
          gtest="Scan.*"),
    Fault("bitmask-bit-off-by-one", "bitmask visibility sets the bit of the neighbouring light sample",
          "kernels/shadows/bitmask.cl",
          "if (nz + uv.x * nx + uv.y * ny < 0.0f) bits |= 1u << (uint)i;",
          "if (nz + uv.x * nx + uv.y * ny < 0.0f) bits |= 1u << (uint)((i + 1) & 31);",
          gtest="Bitmask*.*:BitmaskAgainst*.*"),
    Fault("hard-texel-transposed", "hard shadow test reads texel (v, u) instead of (u, v)",
          "kernels/shadows/pcss.cl",
          "int i = min((int)m->u, size - 1), j = min((int)m->v, size - 1);",
          "int i = min((int)m->v, size - 1), j = min((int)m->u, size - 1);",
          gtest="HardShadows.*:ShadowAccuracy.*:PlanarOblique.*"),
    Fault("pcss-penumbra-halved", "PCSS penumbra width (Fernando 2005) halved",
          "kernels/shadows/pcss.cl",
          "float pen = BOX_FROM_DISC * fmax(m.d - z_avg, 0.0f) * m.range * tan_a;",
          "float pen = 0.5f * BOX_FROM_DISC * fmax(m.d - z_avg, 0.0f) * m.range * tan_a;",
          gtest="PCSS.*:PlanarOblique.*"),
    Fault("pcss-receiver-plane-clamped", "PCSS's receiver plane clamped at tan 84 degrees again (lit ground shadows itself under grazing light)",
          "kernels/shadows/pcss.cl",
          "map_point m = map_point_of(&L, p4.xyz, g, size, PB_UNCLAMPED_SLOPE);",
          "map_point m = map_point_of(&L, p4.xyz, g, size, PB_MAX_RECEIVER_SLOPE);",
          gtest="PCSS.TiltedPlane*"),
    Fault("mssm-hamburger-sign", "MSSM four-moment bound: receiver offset z_f - b1 written z_f + b1",
          "kernels/shadows/moments.cl", "  float y2 = zf - b1;", "  float y2 = zf + b1;",
          gtest="MSSM4.*:ShadowAccuracy.*"),
    Fault("mssm-bias-direction", "MSSM receiver depth bias applied away from the light",
          "kernels/shadows/moments.cl",
          "  return q->d - (P->depth_bias + P->slope_bias * h * q->texel * q->slope / q->range);",
          "  return q->d + (P->depth_bias + P->slope_bias * h * q->texel * q->slope / q->range);",
          gtest="MSSM4.*:ShadowAccuracy.*:Frame.*"),
    Fault("cssm-sine-sign", "CSSM Fourier reconstruction: sign of the sine term flipped",
          "kernels/shadows/csm.cl",
          "float cc = w * s[k], cs = -w * c[k];", "float cc = w * s[k], cs = w * c[k];",
          gtest="CSSM.*"),
    Fault("shade-ambient-dropped", "shading drops the ambient irradiance map",
          "kernels/render/shade.cl",
          "    for (int k = 0; k < 4; ++k) acc += wt[k] * vload3(idx[k], amap);",
          "    for (int k = 0; k < 4; ++k) acc += 0.0f * wt[k] * vload3(idx[k], amap);",
          gtest="Frame.*:Ambient.FrameAddsTheAmbientUnshadowed"),
    Fault("greedy-argmin", "greedy extraction seeds each light at the darkest texel instead of the brightest",
          "kernels/environment/greedy.cl",
          "if (!covered[i] && (best.y < 0 || lum[i] > best.x)) best = (long2)(lum[i], (long)i);",
          "if (!covered[i] && (best.y < 0 || lum[i] < best.x)) best = (long2)(lum[i], (long)i);",
          gtest="Greedy*.*"),
    Fault("envmap-row-solid-angle", "cube-map resampling weights rows by cos instead of sin of the polar angle",
          "kernels/environment/envmap.cl",
          "  return 2.0f * M_PI_F / W * 2.0f * sin(0.5f * (th0 + th1)) * sin(0.5f * (th1 - th0));",
          "  return 2.0f * M_PI_F / W * 2.0f * cos(0.5f * (th0 + th1)) * sin(0.5f * (th1 - th0));",
          gtest="Environment.*:CubeMap*.*:Cubemap*.*:MedianCut*.*"),
    # ---- host library ----------------------------------------------------------------------------
    Fault("bitmask-jitter-ignored", "jittered bitmask frames reuse the unrotated light samples",
          "src/shadows/bitmask.cpp",
          "    const double rot = hard_ ? 0.0 : bitmaskJitterAngle(bo.jitter);",
          "    const double rot = 0.0;",
          gtest="BitmaskJitter.*:CliRenderOptions.BitmaskSamplesAndAccumulate"),
    Fault("center-surround-power-halved", "center-surround lights carry half their power (the ambient takes the rest)",
          "src/environment/center_surround.cpp",
          "    l.setPower({f[0], f[1], f[2]});",
          "    l.setPower({0.5f * f[0], 0.5f * f[1], 0.5f * f[2]});",
          gtest="CenterSurround.*"),
    Fault("registry-mssm4-is-hard", "asking for MSSM4 gives hard shadows (technique swapped)",
          "src/shadows/registry.cpp",
          "    case ShadowTechnique::MSSM4: return makeMSSM4Pass();",
          "    case ShadowTechnique::MSSM4: return makeHardPass();",
          gtest="Frame.*:MSSM4.*"),
    Fault("median-cut-direction-flipped", "median-cut lights point away from the bright regions",
          "src/environment/median_cut.cpp",
          "    l.direction = {d[i].s[0], d[i].s[1], d[i].s[2]};",
          "    l.direction = {-d[i].s[0], -d[i].s[1], -d[i].s[2]};",
          gtest="MedianCut.*"),
    Fault("light-power-halved", "a light's radiance is half its power over its solid angle",
          "src/lights/lights.cpp",
          "  for (int c = 0; c < 3; ++c) radiance[c] = omega > 0 ? power[c] / omega : 0.0f;",
          "  for (int c = 0; c < 3; ++c) radiance[c] = omega > 0 ? 0.5f * power[c] / omega : 0.0f;",
          gtest="Lights.*:MedianCut.*:Frame.*"),
    Fault("compare-rmse-scaled", "image comparison reports half the relative RMSE",
          "src/reference/reference.cpp",
          "  m.relativeRmse = meanB > 0 ? m.rmse / meanB : (m.rmse == 0 ? 0.0 : inf);",
          "  m.relativeRmse = meanB > 0 ? 0.5 * m.rmse / meanB : (m.rmse == 0 ? 0.0 : inf);",
          gtest="CompareImages.*:CliCompare.*"),
    Fault("flip-qc-exponent", "FLIP colour-difference exponent q_c 0.7 written 0.5",
          "src/metrics/flip.cpp", "constexpr float kQc = 0.7f;", "constexpr float kQc = 0.5f;",
          gtest="Flip.*"),
    Fault("srgb-gamma", "PNG encoding uses exponent 1/2.2 instead of the sRGB curve's 1/2.4",
          "src/core/image.cpp",
          "  return t <= 0.0031308f ? 12.92f * t : 1.055f * std::pow(t, 1.0f / 2.4f) - 0.055f;",
          "  return t <= 0.0031308f ? 12.92f * t : 1.055f * std::pow(t, 1.0f / 2.2f) - 0.055f;",
          gtest="CliCompare.Png*:CliCompare.RenderPng*",
          pytest=["bindings/python/tests/test_images.py"]),
    Fault("auto-grazing-cut-ignored", "auto gives PCSS to lights grazing their receivers (the elevation cut dropped)",
          "src/shadows/auto.cpp",
          "        lights[i].receiverSin >= sinPcss)",
          "        lights[i].receiverSin >= -1.0)",
          gtest="AutoRule.*:CliRenderOptions.AutoChoices"),
    Fault("auto-budget-by-power", "auto ranks its budgets by power alone, not by irradiance on screen",
          "src/shadows/auto.cpp",
          "double autoScreenIrradiance(const AutoLight& l) { return l.power * l.screenCos; }",
          "double autoScreenIrradiance(const AutoLight& l) { return l.power; }",
          gtest="AutoRule.*:AutoInputs.*:AutoFrame.FilteredBudget*"),
    Fault("auto-screen-cos-unread", "auto's share on screen is never measured (always 1)",
          "src/shadows/auto.cpp",
          "  if (!samples.empty()) st.screenCos = cosSum / double(samples.size());",
          "  if (!samples.empty()) st.screenCos = 1.0;",
          gtest="AutoRule.*:AutoInputs.*"),
    Fault("auto-screen-cos-not-passed", "the pass leaves each light's share on screen at 1",
          "src/shadows/auto.cpp",
          "      info[l].screenCos = stats[l].screenCos;",
          "      info[l].screenCos = 1.0;",
          gtest="AutoFrame.FilteredBudget*"),
    Fault("area-under-horizon-tested", "the area approximation depth-tests its samples under the receiver's horizon",
          "kernels/shadows/area.cl",
          "    if (!(dot(nl, dir_of(ql[k])) > 0.0f)) {",
          "    if (false) {",
          gtest="AreaApprox.*"),
    Fault("area-receiver-plane-clamped", "the area approximation clamps its receiver plane at tan 84 degrees",
          "kernels/shadows/area.cl",
          "  float2 slope = receiver_slope(g, ex, ey, w, m.tx, m.ty, m.range, PB_UNCLAMPED_SLOPE);",
          "  float2 slope = receiver_slope(g, ex, ey, w, m.tx, m.ty, m.range, PB_MAX_RECEIVER_SLOPE);",
          gtest="AreaApprox.*"),
    Fault("mssm4-rows-ignored", "the batched MSSM4 visibility writes light l's row, not rows[l]",
          "kernels/shadows/moments.cl",
          "  global float* out = vis + (size_t)rows[l] * npixels;",
          "  global float* out = vis + (size_t)l * npixels;",
          gtest="MSSM4.Batched*"),
    Fault("horizon-skip-margin", "MSSM4 skips pairs just above the horizon too, which the horizon step keeps",
          "kernels/shadows/filter.clh",
          "  return pb_on_horizon(c, sin_a, 1e-5f)",
          "  return pb_on_horizon(c, sin_a, -0.2f)",
          gtest="MSSM4.PairsTheHorizon*:Horizon.Skipped*"),
    Fault("contact-map-gather-mask", "contact_map reads the map texel where the light is below the facet instead of above",
          "kernels/render/contact.cl",
          "      const float tm = c > 0.0f ? as_float(md[cy * map_size + cx]) : 0.0f;",
          "      const float tm = c < 0.0f ? as_float(md[cy * map_size + cx]) : 0.0f;",
          gtest="ContactShadows.*"),
    Fault("bitmask-resolve-batch-lit", "the bitmask's batched resolve counts the blocked samples as lit",
          "kernels/shadows/bitmask.cl",
          "        lit[k] = ((mw[w][k] >> b) & 1u) == 0u ? lit[k] + wgt : lit[k];",
          "        lit[k] = ((mw[w][k] >> b) & 1u) != 0u ? lit[k] + wgt : lit[k];",
          gtest="RenderStages.CpuBatched*"),
    Fault("ground-batch-counts-all", "the ground step's CPU form counts the directions below the pixel's plane",
          "kernels/render/ground.cl",
          "        total[j] = counts ? t : total[j];",
          "        total[j] = t;",
          gtest="Ground.*"),
    Fault("contact-batch-window-narrow", "the camera side's CPU form scans one column less of each window row",
          "kernels/render/contact.cl",
          "    for (int di = 0; di <= 2 * CONTACT_RADIUS; ++di) {",
          "    for (int di = 0; di < 2 * CONTACT_RADIUS; ++di) {",
          gtest="ContactShadows.*"),
    Fault("contact-batch-lanes-unmasked", "the camera side's CPU form casts the rays of lights the mask leaves alone",
          "kernels/render/contact.cl",
          "        go[i] = l0 + i < nl && mask[l] != 0 && vis[(size_t)l * pixels + p] != 0.0f &&",
          "        go[i] = l0 + i < nl && vis[(size_t)l * pixels + p] != 0.0f &&",
          gtest="ContactShadows.*"),
    Fault("horizon-run-unmasked", "the horizon step's CPU form writes a run's mean to every pixel of its span",
          "kernels/render/horizon.cl",
          "          if (pair[k]) out[k] = sum[k] / (float)ns;",
          "          out[k] = sum[k] / (float)ns;",
          gtest="Horizon.*"),
    Fault("gbuffer-batch-no-flip", "the G-buffer's CPU form keeps the geometric normal facing away from the camera",
          "kernels/render/raster.cl",
          "    const bool flip = dot3_s(gx, gy, gz, dx, dy, dz) > 0.0f;",
          "    const bool flip = false;",
          gtest="Raster.*"),
    Fault("vs-count-batch-runs-merge-texels", "the list count's CPU form lets a run of samples cross texels",
          "kernels/shadows/viewsamples.cl",
          "    while (e < cnt && texel[e] == t) far = max(far, oz[e++]);",
          "    while (e < cnt && texel[e] >= 0) far = max(far, oz[e++]);",
          gtest="Bitmask*"),
    Fault("vs-bounds-batch-counts-all", "the list bounds' CPU form counts pixels that are no view sample",
          "kernels/shadows/viewsamples.cl",
          "    v5 += in[k];",
          "    v5 += 1;",
          gtest="Bitmask*"),
    Fault("moment-table-rows-ignored", "the moments-and-table sweep reads map l, not rows[l]",
          "kernels/shadows/moments.cl",
          "    moments_row(depth + ((size_t)rows[l] * size + y) * size, out, size, lights[l].origin[3]);",
          "    moments_row(depth + ((size_t)l * size + y) * size, out, size, lights[l].origin[3]);",
          gtest="MSSM4.MomentTable*"),
    Fault("raster-views-no-clear", "raster_views does not empty the maps it is asked to",
          "kernels/render/raster.cl",
          "  if (clear) {",
          "  if (clear && 0) {",
          gtest="Raster.*"),
    Fault("bitmask-self-keeps-zero-words", "bitmask_self leaves a soft mask word it found empty unwritten",
          "kernels/shadows/bitmask.cl",
          "    mask[k] = bits;",
          "    if (bits) mask[k] = bits;",
          gtest="Bitmask*:Exact*"),
    # ---- command line ----------------------------------------------------------------------------
    Fault("cli-depth-bias-field", "--depth-bias sets the MSSM slope bias",
          "apps/cli/render_options.cpp",
          'if (a.has("depth-bias")) ro.shadow.depthBias = float(a.real("depth-bias"));',
          'if (a.has("depth-bias")) ro.mssm.slopeBias = float(a.real("depth-bias"));',
          gtest="CliRenderOptions.DepthBias*:CliRenderOptions.SlopeBias*"),
    Fault("cli-light-size-field", "--light-size-scale sets the largest filter width",
          "apps/cli/render_options.cpp",
          'ro.shadow.lightSizeScale = float(a.real("light-size-scale"));',
          'ro.shadow.maxFilterTexels = float(a.real("light-size-scale"));',
          gtest="CliRenderOptions.LightSizeScale*"),
    Fault("cli-seed-ignored", "--seed is parsed and ignored",
          "apps/cli/render_options.cpp",
          'if (a.has("seed")) ro.seed = std::uint64_t(a.integer("seed"));',
          'if (a.has("seed")) (void)std::uint64_t(a.integer("seed"));',
          gtest="CliReferenceOptions.*"),
    Fault("cli-no-ground-ignored", "--no-ground still adds the ground plane",
          "apps/cli/scene_options.cpp",
          '  lo.addGround = !a.has("no-ground");', '  lo.addGround = true;',
          gtest="CliOptions.NoGround*"),
    Fault("cli-sharpen-b-field", "--sharpen-b sets the sharpening strength A",
          "apps/cli/render_options.cpp",
          'if (a.has("sharpen-b")) ro.cssm.sharpenB = float(a.real("sharpen-b"));',
          'if (a.has("sharpen-b")) ro.cssm.sharpenA = float(a.real("sharpen-b"));',
          gtest="CliRenderOptions.CssmOrderAndSharpening"),
    Fault("cli-compare-reference-swapped", "`compare A B` takes A as the reference",
          "apps/cli/cmd_compare.cpp",
          "  const ImageMetrics m = compareImages(A, B);", "  const ImageMetrics m = compareImages(B, A);",
          gtest="CliCompare.*"),
    # ---- Python bindings -------------------------------------------------------------------------
    Fault("py-depth-bias-field", "Python ShadowOptions.depth_bias is bound to max_filter_texels",
          "bindings/python/penumbra_module.cpp",
          '  so.def_readwrite("depth_bias", &ShadowOptions::depthBias,',
          '  so.def_readwrite("depth_bias", &ShadowOptions::maxFilterTexels,',
          pytest=["bindings/python/tests"]),
    Fault("py-write-image-exposure", "Python write_image ignores its exposure",
          "bindings/python/penumbra_module.cpp",
          "        writeImage(path.string(), img, exposure, numbers, text);",
          "        writeImage(path.string(), img, 1.0f, numbers, text);",
          pytest=["bindings/python/tests"]),
]


def log(msg: str) -> None:
    print(msg, flush=True)


def run(cmd: List[str], cwd: Path, timeout: float, env=None) -> subprocess.CompletedProcess:
    try:
        return subprocess.run(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True, timeout=timeout)
    except subprocess.TimeoutExpired as e:
        out = e.stdout.decode(errors="replace") if isinstance(e.stdout, bytes) else (e.stdout or "")
        return subprocess.CompletedProcess(cmd, 124, out + f"\n[timed out after {timeout:.0f} s]")


class Scratch:
    def __init__(self, repo: Path, root: Path, jobs: int):
        self.repo, self.root, self.jobs = repo, root, jobs
        # The copy's layout is the checkout's (sources at the root, build/ inside), so ccache with
        # CCACHE_BASEDIR above both finds the objects of an earlier build of the checkout.
        self.src, self.build = root, root / "build"
        self.marker = root / "build" / "mutation_in_progress"

    def make(self) -> None:
        files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=self.repo,
                               stdout=subprocess.PIPE, check=True).stdout.decode().split("\0")
        wanted = {f for f in files if f and (self.repo / f).is_file()}
        # A previous run's copy keeps its build/; a source whose bytes differ from the checkout's
        # (a mutant left by an interrupted run, or a changed file) is rewritten with a new mtime,
        # so that the build cannot keep objects made from other text. Unchanged files keep theirs.
        if self.src.exists():
            for p in sorted(self.src.rglob("*"), reverse=True):
                rel = p.relative_to(self.src).as_posix()
                if rel == "build" or rel.startswith("build/"):
                    continue
                if p.is_file() and rel not in wanted:
                    p.unlink()
                elif p.is_dir() and not any(p.iterdir()):
                    p.rmdir()
        # A run killed outright (SIGKILL) leaves the name of the file it had mutated in the marker:
        # that file's objects were built from the mutant, so it is rewritten even if restored.
        stale = self.marker.read_text().strip() if self.marker.exists() else None
        for f in sorted(wanted):
            s, d = self.repo / f, self.src / f
            if f != stale and d.is_file() and d.read_bytes() == s.read_bytes():
                continue
            d.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(s, d)
            shutil.copymode(s, d)
        if stale:
            self.marker.unlink()
        cmd = ["cmake", "-S", str(self.src), "-B", str(self.build), "-DCMAKE_BUILD_TYPE=Release"]
        if shutil.which("ccache"):
            cmd.append("-DCMAKE_CXX_COMPILER_LAUNCHER=ccache")
        r = run(cmd, self.root, 600)
        if r.returncode != 0:
            sys.exit(f"mutation_check: cmake configure failed:\n{r.stdout[-3000:]}")

    def compile(self, targets: List[str]) -> subprocess.CompletedProcess:
        return run(["cmake", "--build", str(self.build), "-j", str(self.jobs), "--target", *targets],
                   self.root, 3600)

    def python_dir(self) -> Path:
        # the directory that holds the built package penumbra/ (its extension _penumbra*.so)
        p = self.build / "bindings" / "python"
        if any((p / "penumbra").glob("_penumbra*.so")):
            return p
        sys.exit("mutation_check: the Python module was not built (is pybind11 installed?)")

    def tests(self, fault: Fault, timeout: float) -> subprocess.CompletedProcess:
        """Runs the fault's tests; returns the first failing run, or the last passing one."""
        last = None
        if fault.gtest:
            last = run([str(self.build / "tests" / "penumbra_tests"), f"--gtest_filter={fault.gtest}",
                        "--gtest_brief=1"], self.src, timeout)
            if last.returncode != 0:
                return last
            if "[  PASSED  ] 0 tests" in last.stdout:
                sys.exit(f"mutation_check: {fault.id}: the filter '{fault.gtest}' selects no test")
        if fault.pytest:
            env = dict(os.environ, PYTHONPATH=str(self.python_dir()), PYTHONDONTWRITEBYTECODE="1",
                       PENUMBRA_TEST_DATA=str(self.src / "tests" / "data"), MPLBACKEND="Agg")
            last = run([sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider",
                        *fault.pytest], self.src, timeout, env)
        return last


def targets_for(f: Fault) -> List[str]:
    t = []
    if f.gtest:
        t += ["penumbra_tests", "penumbra_cli"]
    if f.pytest:
        t += ["penumbra_python"]
    return t


def first_failure(out: str) -> str:
    for line in out.splitlines():
        if line.startswith("[  FAILED  ]") and "listed below" not in line and " tests," not in line:
            return line[len("[  FAILED  ]"):].strip().split(" (")[0]
        if line.startswith("FAILED ") or line.startswith("ERROR "):
            return line.split(" - ")[0]
    if "timed out" in out:
        return "timed out"
    return out.strip().splitlines()[-1][:120] if out.strip() else "non-zero exit"


def interrupted(signum, frame):
    """SIGTERM unwinds like Ctrl-C, so the mutated file is restored by its `finally`."""
    raise KeyboardInterrupt


def main() -> int:
    signal.signal(signal.SIGTERM, interrupted)
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--list", action="store_true", help="list the faults and exit")
    ap.add_argument("--only", default="", help="comma-separated fault ids")
    ap.add_argument("--scratch", default=None,
                    help="scratch directory (default: penumbra-mutants beside the checkout)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=900, help="seconds per fault's test run")
    ap.add_argument("--skip-baseline", action="store_true",
                    help="do not check that the selected tests pass unmutated (faster, less sure)")
    a = ap.parse_args()

    faults = FAULTS
    if a.only:
        want = [s for s in a.only.split(",") if s]
        unknown = [w for w in want if w not in {f.id for f in FAULTS}]
        if unknown:
            log(f"mutation_check: unknown fault id(s): {', '.join(unknown)}")
            return 2
        faults = [f for f in FAULTS if f.id in want]
    if a.list:
        for f in faults:
            log(f"{f.id:32} {f.path:38} {f.what}")
        log(f"{len(faults)} faults")
        return 0

    repo = Path(__file__).resolve().parent.parent
    for f in faults:  # every fault must still apply to today's code
        n = (repo / f.path).read_text().count(f.old)
        if n != 1:
            log(f"mutation_check: {f.id}: its text occurs {n} times in {f.path} (must be once); "
                "update the fault to the code")
            return 2

    t_start = time.time()
    scratch = Path(a.scratch) if a.scratch else repo.parent / "penumbra-mutants"
    if scratch.resolve() == repo or repo in scratch.resolve().parents:
        log("mutation_check: --scratch must be outside the checkout")
        return 2
    s = Scratch(repo, scratch, a.jobs)
    log(f"scratch copy in {s.root}; building it once")
    s.make()
    targets = sorted({t for f in faults for t in targets_for(f)})
    r = s.compile(targets)
    if r.returncode != 0:
        log(r.stdout[-3000:])
        log("mutation_check: the unmodified copy does not build")
        return 2
    if not a.skip_baseline:
        seen = set()
        for f in faults:
            key = (f.gtest, tuple(f.pytest))
            if key in seen:
                continue
            seen.add(key)
            r = s.tests(f, a.timeout)
            if r.returncode != 0:
                log(r.stdout[-3000:])
                log(f"mutation_check: {f.id}'s tests fail WITHOUT the fault ({first_failure(r.stdout)});"
                    " a kill would mean nothing")
                return 2
        log(f"baseline: every selected test passes unmodified ({time.time() - t_start:.0f} s so far)")

    rows = []
    for f in faults:
        p = s.src / f.path
        original = p.read_text()
        s.marker.write_text(f.path)
        p.write_text(original.replace(f.old, f.new))
        t0 = time.time()
        try:
            b = s.compile(targets_for(f))
            if b.returncode != 0:
                verdict, why = "INVALID", "the mutant does not compile: " + first_failure(b.stdout)
            else:
                r = s.tests(f, a.timeout)
                verdict = "killed" if r.returncode != 0 else "SURVIVED"
                why = first_failure(r.stdout) if r.returncode != 0 else "all selected tests passed"
        finally:
            p.write_text(original)
            os.utime(p)  # newer than the mutant's objects: the next build recompiles it
            s.marker.unlink()
        dt = time.time() - t0
        rows.append((f, verdict, why, dt))
        log(f"{verdict:8} {dt:6.0f} s  {f.id}: {why}")

    killed = sum(1 for _, v, _, _ in rows if v == "killed")
    log("")
    log(f"{'fault':32} {'result':8} {'s':>5}  first failing test")
    for f, v, why, dt in rows:
        log(f"{f.id:32} {v:8} {dt:5.0f}  {why}")
    log(f"\n{killed} of {len(rows)} faults killed in {time.time() - t_start:.0f} s "
        f"(scratch {s.root}, {a.jobs} build jobs)")
    return 0 if killed == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
