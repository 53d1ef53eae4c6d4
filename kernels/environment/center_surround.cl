// Center-surround light extraction (Arbree et al. 2005 §3) on the sphere: a bank of circular
// filters with a
// centre cap of weight +1 and a surround ring of weight surroundWeight (-10) per unit solid angle,
// evaluated at the brightest texels; the strongest normalized response becomes a light and its
// centre cap is removed from the map (kernels below, driven by
// src/environment/center_surround.cpp).
//
// Parameterization. The filters are circles on the sphere (geodesic caps), so we evaluate them on
// the sphere itself rather than on a flat image: the working grid is an equirect map of
// W x W/2 texels holding radiance x exact texel solid angle (energy), and a texel belongs to a
// filter region when the great-circle distance between its centre and the filter centre is below
// the region's radius. Arbree et al. 2005 instead rendered a local perspective view per texel; a
// flat view
// stretches the filter towards its edges (a 45 degree filter spans tan(22.5) vs 22.5 degrees) and
// needs resampling per candidate, whereas distances on the sphere are exact and need none. We keep
// the equirect grid (rather than a cube map) because it is invariant under rotations about the
// pole: the distance of a texel from a centre depends only on the two rows and the column
// offset, cos d = cos(t) cos(tc) + sin(t) sin(tc) cos(dphi) (spherical law of cosines), so one
// table of cos(dphi) serves every candidate, the seam phi = +-pi is a plain wrap of the column,
// and a rotation by whole columns gives bit-identical responses. For each candidate only rows
// within the largest outer radius are touched, and in each row only the longitude interval the
// law of cosines allows, |dphi| <= acos((cos R - cos t cos tc) / (sin t sin tc)): no texel
// outside the cap is read. Near a pole the interval covers the whole row, which is exactly what
// the cap contains there.
//
// Sums over caps. Within one row, the texels closer than R to a centre form one interval of
// columns centred on the centre's column (distance grows with |dphi|), so the energy within R is a
// sum over the cap's rows of interval sums, each the difference of two row prefix sums. The
// interval half-widths depend only on the centre's row, the row and R (the law of cosines above),
// so one table of them, per (centre row, row offset, radius), computed once per extraction,
// serves every candidate and every iteration. All 2*sizes radii (inner and outer radius of every
// size) share the pass: cumulative energies C(R_j) for the sorted radii, and every size's centre
// and ring integrals are C(r_inner) and C(r_outer) - C(r_inner). A candidate costs
// rows x 2*sizes prefix look-ups (about 67 x 40 at the defaults) instead of one visit per texel
// of its largest cap (4,000 to 20,000 texels on a 512-wide grid, most near the poles), with no
// transcendental function. The prefix sums hold fixed-point luminance energy in 64-bit integers
// (a power-of-two scale chosen by the host so the map's total fits), so interval sums are exact
// differences whatever the row's dynamic range, and the result does not depend on summation
// order: bit-identical on repeat and under rotations by whole columns. The half-widths are the
// largest |ds| that passes the float test cos d >= cos R with the same tables, so the centre
// region the response measures and the texels cs_take removes are the same set.
//
// Compile-time options (from the host): CS_BINS = 2 * sizes, CS_MAX_ROWS = the most rows a
// largest filter can span. Work-groups must be powers of two (cs_take's tree reduction).
#include "shared.h"

#ifndef CS_BINS
#error "CS_BINS (number of sorted radii) must be defined by the host"
#endif
#ifndef CS_MAX_ROWS
#error "CS_MAX_ROWS must be defined by the host"
#endif

#define CS_TWO_PI 6.28318530717958647692f

// Exact solid angle of working row t: (2 pi / W) (cos t0 - cos t1), written with sines so that
// rows next to the poles do not lose their digits to cancellation.
static float row_solid_angle(int t, int W, int H) {
  float t0 = (float)t * M_PI_F / (float)H, t1 = (float)(t + 1) * M_PI_F / (float)H;
  return CS_TWO_PI / (float)W * 2.0f * sin(0.5f * (t0 + t1)) * sin(0.5f * (t1 - t0));
}

// Solid angle of the band theta in [a, b] (radians) per radian of longitude: cos a - cos b.
static float band(float a, float b) { return 2.0f * sin(0.5f * (a + b)) * sin(0.5f * (b - a)); }

// Energy-conserving box resampling of the source equirect map (RGB radiance, srcW x srcH) to the
// working grid: each working texel gets the exact integral of the source radiance over its
// rectangle in (phi, theta), i.e. the sum of source radiance x overlap solid angle. For a source
// whose size is a multiple of the grid's this is the solid-angle weighted box filter. Writes the
// RGB energy (w: luminance energy), the luminance energy in fixed point (what the filters read), and the
// texel's luminance radiance as an order-preserving key for the candidate selection. shift: the
// map's rotation about +y in source columns (Environment::rotationColumns, in [0, srcW)): world
// column x shows source column x + shift, so the overlap is taken with the shifted interval,
// exactly (whole-column shifts read the same texels as the shifted map, bit for bit).
kernel void cs_resample(global const float* src, int srcW, int srcH, float shift, int W, int H,
                        float scale, global float4* energy, global long* q, global uint* key) {
  int s = get_global_id(0), t = get_global_id(1);
  if (s >= W || t >= H) return;
  float th0 = (float)t * M_PI_F / (float)H, th1 = (float)(t + 1) * M_PI_F / (float)H;
  // Source rows/columns overlapping this texel: [j0, j1), [i0, i1) in source texels.
  float sy0 = (float)t * (float)srcH / (float)H, sy1 = (float)(t + 1) * (float)srcH / (float)H;
  float sx0 = (float)s * (float)srcW / (float)W + shift;
  float sx1 = (float)(s + 1) * (float)srcW / (float)W + shift;
  int j0 = (int)floor(sy0), j1 = min(srcH, (int)ceil(sy1));
  int i0 = (int)floor(sx0), i1 = (int)ceil(sx1);  // may pass srcW: wrapped below
  float dphiSrc = CS_TWO_PI / (float)srcW;
  float3 e = (float3)(0.0f);
  for (int j = j0; j < j1; ++j) {
    float a = fmax(th0, (float)j * M_PI_F / (float)srcH);
    float b = fmin(th1, (float)(j + 1) * M_PI_F / (float)srcH);
    if (b <= a) continue;
    float w_t = band(a, b);
    float3 rowSum = (float3)(0.0f);
    for (int i = i0; i < i1; ++i) {
      float fx = fmin(sx1, (float)(i + 1)) - fmax(sx0, (float)i);  // overlap in source columns
      if (fx <= 0.0f) continue;
      int iw = i >= srcW ? i - srcW : i;
      global const float* p = src + ((size_t)j * srcW + iw) * 3;
      rowSum += fx * (float3)(p[0], p[1], p[2]);
    }
    e += rowSum * (w_t * dphiSrc);
  }
  float l = PB_LUM_R * e.x + PB_LUM_G * e.y + PB_LUM_B * e.z;
  size_t idx = (size_t)t * W + s;
  energy[idx] = (float4)(e, l);
  // Fixed point: scale is a power of two, so l * scale is exact; truncation only drops the
  // fraction of texels below 2^23 units (relative 2^-39 of the map's total, see the host).
  q[idx] = (long)(l * scale);
  // Non-negative floats order like their bit patterns: the key sorts texels by radiance.
  key[idx] = as_uint(fmax(0.0f, l / row_solid_angle(t, W, H)));
}

// One pass of a most-significant-digit radix select: counts the keys whose bits above `shift + 8`
// equal `prefix` (under `mask`), by their 8-bit digit at `shift`. Local histograms, then one
// global atomic per bin and group (counts: the result does not depend on the order).
kernel void cs_key_histogram(global const uint* key, int n, int shift, uint mask, uint prefix,
                             global uint* hist, local uint* lh) {
  int lid = get_local_id(0), wg = get_local_size(0);
  for (int b = lid; b < 256; b += wg) lh[b] = 0;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int i = get_global_id(0); i < n; i += get_global_size(0)) {
    uint k = key[i];
    if ((k & mask) == prefix) atomic_inc(&lh[(k >> shift) & 255u]);
  }
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int b = lid; b < 256; b += wg)
    if (lh[b]) atomic_add(&hist[b], lh[b]);
}

// Per row: how many keys are above the threshold key and how many equal it.
kernel void cs_row_counts(global const uint* key, int W, int H, uint thresh,
                          global int2* counts) {
  int t = get_global_id(0);
  if (t >= H) return;
  int gt = 0, eq = 0;
  for (int s = 0; s < W; ++s) {
    uint k = key[(size_t)t * W + s];
    gt += k > thresh;
    eq += k == thresh;
  }
  counts[t] = (int2)(gt, eq);
}

// Writes the candidate texels of row t in index order from rowStart[t]: keys above the threshold,
// and the first takeEq[t] keys equal to it (ties go to the lowest texel index, chosen on the host).
// The list is sorted by texel index, so candidates of a band of rows are one contiguous range.
kernel void cs_row_write(global const uint* key, int W, int H, uint thresh,
                         global const int* rowStart, global const int* takeEq,
                         global int* cand) {
  int t = get_global_id(0);
  if (t >= H) return;
  int o = rowStart[t], eqLeft = takeEq[t];
  for (int s = 0; s < W; ++s) {
    uint k = key[(size_t)t * W + s];
    bool take = k > thresh;
    if (!take && k == thresh && eqLeft > 0) {
      take = true;
      --eqLeft;
    }
    if (take) cand[o++] = t * W + s;
  }
}

// Inclusive prefix sums of the fixed-point luminance energy along rows [row0, row0 + nrows).
// Run once, then again on the rows a removed cap touched.
kernel void cs_row_prefix(global const long* q, int W, int row0, int nrows, global long* P) {
  int r = get_global_id(0);
  if (r >= nrows) return;
  size_t base = (size_t)(row0 + r) * W;
  long acc = 0;
  for (int s = 0; s < W; ++s) {
    acc += q[base + s];
    P[base + s] = acc;
  }
}

// Half-width table: E[(tc * CS_MAX_ROWS + dt) * CS_BINS + j] = the largest column offset e such
// that the texels at offsets -e..e of row t = tc - rrows + dt lie within sorted radius j of a
// centre in row tc (cos d >= thr[j], d by the law of cosines), -1 if none, W/2 if the whole row.
// acos gives the estimate; stepping with the very test the take uses makes it exact.
kernel void cs_extents(global const float4* rowTrig, global const float* colCos,
                       constant float* thr, int W, int H, int rrows, global short* E) {
  int dt = get_global_id(0), tc = get_global_id(1);
  if (dt >= CS_MAX_ROWS || tc >= H) return;
  int t = tc - rrows + dt;
  global short* out = E + ((size_t)tc * CS_MAX_ROWS + dt) * CS_BINS;
  if (t < 0 || t >= H) {
    for (int j = 0; j < CS_BINS; ++j) out[j] = -1;
    return;
  }
  float4 rt = rowTrig[t], rc = rowTrig[tc];
  float A = rt.x * rc.x, B = rt.y * rc.y;
  int hw = W / 2;
  for (int j = 0; j < CS_BINS; ++j) {
    float cosR = thr[j];
    float c = (cosR - A) / B;
    int e = c >= 1.0f ? -1 : (c <= -1.0f ? hw : (int)(acos(c) * (float)W / CS_TWO_PI));
    e = clamp(e, -1, hw);
    while (e < hw && A + B * colCos[e + 1] >= cosR) ++e;
    while (e >= 0 && A + B * colCos[e] < cosR) --e;
    out[j] = (short)e;
  }
}

// Sum of the fixed-point energy of row P (prefix sums) over column offsets -e..e around column
// sc, wrapping across the seam; the whole row when the interval covers it.
static long row_interval_sum(global const long* P, int W, int sc, int e) {
  if (e < 0) return 0;
  if (2 * e + 1 >= W) return P[W - 1];
  int lo = sc - e, hi = sc + e;
  long below = lo > 0 ? P[lo - 1] : 0;
  if (lo < 0) return P[hi] + (P[W - 1] - P[lo + W - 1]);      // wraps at phi = -pi
  if (hi >= W) return (P[W - 1] - below) + P[hi - W];         // wraps at phi = +pi
  return P[hi] - below;
}

// Filter responses of candidates cand[candBegin + group], one work-group per candidate, one
// work-item per sorted radius j: C_j = sum over the cap's rows of the interval sums, exact in
// fixed point. Then, per size (Arbree et al. 2005 §3: weights +1 and surround per unit solid angle,
// divided
// by the filter's angular extent),
//   response_k = (C(r_inner_k) + surround * (C(r_outer_k) - C(r_inner_k))) / extent_k.
// resp gets every size, best/bestSize the largest (ties: the smaller size). cull.w > -2: skip
// candidates farther than acos(cull.w) from the unit direction cull.xyz (their caps saw no
// change); the test is the same for the whole group, so skipping never splits a barrier.
kernel void cs_response(global const long* P, int W, int H, global const float4* rowTrig,
                        global const float2* colDir, global const short* E,
                        global const int2* sizeBins, global const float* invExtent, int nSizes,
                        float surround, float invScale, int rrows, global const int* cand,
                        int candBegin, float4 cull, global float* resp, global float* best,
                        global int* bestSize, local long* C, local float* v) {
  int lid = get_local_id(0), wg = get_local_size(0);
  int ci = candBegin + get_group_id(0);
  int c = cand[ci];
  int tc = c / W, sc = c - tc * W;
  if (cull.w > -2.0f) {
    float4 rc = rowTrig[tc];
    float2 sp = colDir[sc];
    float3 d = (float3)(rc.y * sp.x, rc.x, -rc.y * sp.y);
    if (dot(d, cull.xyz) < cull.w) return;
  }
  global const short* Ec = E + (size_t)tc * CS_MAX_ROWS * CS_BINS;
  int dt0 = max(0, rrows - tc), dt1 = min(CS_MAX_ROWS - 1, rrows + (H - 1 - tc));
  for (int j = lid; j < CS_BINS; j += wg) {
    long acc = 0;
    for (int dt = dt0; dt <= dt1; ++dt) {
      int e = Ec[dt * CS_BINS + j];
      if (e >= 0) acc += row_interval_sum(P + (size_t)(tc - rrows + dt) * W, W, sc, e);
    }
    C[j] = acc;
  }
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int k = lid; k < nSizes; k += wg) {
    int2 sb = sizeBins[k];
    float inner = (float)C[sb.x] * invScale, ring = (float)(C[sb.y] - C[sb.x]) * invScale;
    float r = (inner + surround * ring) * invExtent[k];
    resp[(size_t)ci * nSizes + k] = r;
    v[k] = r;
  }
  barrier(CLK_LOCAL_MEM_FENCE);
  if (lid == 0) {
    float bv = v[0];
    int bk = 0;
    for (int k = 1; k < nSizes; ++k)
      if (v[k] > bv) {
        bv = v[k];
        bk = k;
      }
    best[ci] = bv;
    bestSize[ci] = bk;
  }
}

// One iteration of Arbree et al. 2005 §3's loop, in a single work-group: (1) the candidate with the
// largest
// response (ties: the lowest texel index), (2) the RGB energy, luminance energy, texel count and
// luminance-weighted direction sum of the texels inside that filter's centre cap (the same
// half-width table as the response, so the same texels), (3) those texels set to zero (removed
// from the map; the host then refreshes the touched rows' prefix sums). out: [0..2] RGB power,
// [3] luminance power, [4..6] direction sum, [7] response (float bits), [8] candidate texel,
// [9] size index, [10] texel count, [11] 1 if a positive response was found. The host decides
// whether the light is kept (2% rule); when it is not the loop ends, so the speculative removal
// costs nothing.
kernel void cs_take(global long* q, global float4* energy, int W, int H,
                    global const float4* rowTrig, global const float2* colDir,
                    global const short* E, global const int2* sizeBins, int rrows,
                    global const int* cand, int nCand, global const float* best,
                    global const int* bestSize, global int* out, local float* red,
                    local int* redi) {
  int lid = get_local_id(0), wg = get_local_size(0);
  float bv = 0.0f;
  int bi = -1;
  for (int i = lid; i < nCand; i += wg) {  // ascending i: strict > keeps the lowest index
    float v = best[i];
    if (bi < 0 || v > bv) {
      bv = v;
      bi = i;
    }
  }
  red[lid] = bv;
  redi[lid] = bi;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int off = wg / 2; off > 0; off >>= 1) {
    if (lid < off) {
      float ov = red[lid + off];
      int oi = redi[lid + off];
      bool better = oi >= 0 && (redi[lid] < 0 || ov > red[lid] || (ov == red[lid] && oi < redi[lid]));
      if (better) {
        red[lid] = ov;
        redi[lid] = oi;
      }
    }
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  bv = red[0];
  bi = redi[0];
  barrier(CLK_LOCAL_MEM_FENCE);
  if (bi < 0 || !(bv > 0.0f)) {  // no compact bright region left (or no candidates)
    if (lid == 0) {
      for (int i = 0; i < 11; ++i) out[i] = 0;
      out[7] = as_int(bv);
      out[11] = 0;
    }
    return;
  }
  int c = cand[bi], k = bestSize[bi];
  int tc = c / W, sc = c - tc * W;
  int jin = sizeBins[k].x;
  global const short* Ec = E + (size_t)tc * CS_MAX_ROWS * CS_BINS;
  int dt0 = max(0, rrows - tc), dt1 = min(CS_MAX_ROWS - 1, rrows + (H - 1 - tc));
  float acc[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  for (int dt = dt0; dt <= dt1; ++dt) {
    int e = Ec[dt * CS_BINS + jin];
    if (e < 0) continue;
    int t = tc - rrows + dt;
    float4 rt = rowTrig[t];
    int n = 2 * e + 1 >= W ? W : 2 * e + 1, start = 2 * e + 1 >= W ? 0 : sc - e;
    for (int j = lid; j < n; j += wg) {
      int col = start + j;
      col += col < 0 ? W : (col >= W ? -W : 0);
      size_t idx = (size_t)t * W + col;
      float4 en = energy[idx];
      float2 sp = colDir[col];
      acc[0] += en.x;
      acc[1] += en.y;
      acc[2] += en.z;
      acc[3] += en.w;
      acc[4] += en.w * rt.y * sp.x;
      acc[5] += en.w * rt.x;
      acc[6] += en.w * -rt.y * sp.y;
      acc[7] += 1.0f;
      energy[idx] = (float4)(0.0f);
      q[idx] = 0;
    }
  }
  for (int m = 0; m < 8; ++m) red[m * wg + lid] = acc[m];
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int off = wg / 2; off > 0; off >>= 1) {
    if (lid < off)
      for (int m = 0; m < 8; ++m) red[m * wg + lid] += red[m * wg + lid + off];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (lid == 0) {
    for (int m = 0; m < 7; ++m) out[m] = as_int(red[m * wg]);
    out[7] = as_int(bv);
    out[8] = c;
    out[9] = k;
    out[10] = (int)red[7 * wg];
    out[11] = 1;
  }
}
