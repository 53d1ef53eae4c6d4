// The ambient residual's pre-integrated irradiance map (Arbree et al. 2005 abstract and end of §3:
// the
// ambient region "is rendered using pre-integrated irradiance mapping"; src/environment/
// ambient.cpp): for each normal n of the table (lights.hpp AmbientMap,
// shared.h pb_ambient_map_normal),
//   E_res(n) = E_map(n) - sum_i E_light_i(n),   E_map(n) = integral of L(w) max(0, n.w) dw,
// with E_light_i the light's exact unshadowed irradiance as shading computes it (shared.h:
// pb_cap_irradiance, pb_polygon_irradiance), so lights + ambient give E_map on every table normal.
//
// The map is what it is everywhere else in penumbra: constant radiance over each lat-long texel.
// Each texel's first moment m_t = integral of w dw over the texel is exact from the row and column
// integrals the host tabulates in double for kernels/environment/sh.cl (rows: int sin, int sin^2,
// int cos sin; columns: int 1, int sin, int cos, with the map's rotation in them), and the texel
// contributes L_t max(0, n.m_t): exact whenever the texel lies wholly on one side of n's horizon
// (the clamped cosine is then linear over it), a second-order error in the texel's size for the few
// texels the horizon cuts.
//
// Summed texel by texel that is W x H work per table normal. But along one map row the sign of
// n.m_t has a closed form: with theta_n, phi_n the normal's angles, rho = sin(theta_n), T1 = int
// sin^2 and T2 = int cos sin over the row's theta, and dphi = 2 pi / W,
//   n.m_t = rho T1 2 sin(dphi / 2) cos(phi_t - phi_n) + cos(theta_n) T2 dphi   (phi_t: its centre)
// (the column integrals of sin and cos combine into int cos(phi - phi_n) = 2 sin(dphi/2)
// cos(phi_t - phi_n)), so the texels with n.m_t > 0 are one run of columns centred on phi_n,
// of half-width acos(tau) with tau = -cos(theta_n) T2 dphi / (rho T1 2 sin(dphi / 2)), the same
// for every normal of a table row. The run's sum of L_t m_t is a difference of two prefix sums
// along the row, so a normal costs O(H), not O(W H), and the result is the same definition: every
// texel with n.m_t > 0 counted whole, the others not. Only a texel whose centre lies within float
// rounding of the run's computed ends (a few 1e-7 of a column's angle, or of tau near +-1) may
// fall on the other side, and its n.m_t is then within a few 1e-7 of 0 relative to |m_t|; the
// kernel-vs-texel-by-texel tests (tests/test_ambient.cpp AmbientMap.MatchesHostReference*) bound
// the whole difference at 2e-6 of the map's scale. A table of even width holds every normal's
// antipode, whose texels are the complement of the normal's (irradiance_bands): half the normals
// are summed.
//
// Kernels, in order: irradiance_prefix (per map row, the running sums of L_t m_t in world column
// order, compensated so that each stored prefix is the correctly rounded float of the exact one),
// irradiance_normals, irradiance_halfwidth (per table row and map row, the run's half-width in
// columns), irradiance_bands (per table normal and band of map rows, the band's sum),
// irradiance_table (per normal, or pair of antipodes, the bands in order minus the lights). Every
// sum runs in a fixed order: reproducible bit for bit, and a map turned by whole columns gives the
// same table as the map with its columns shifted (world column order: the same numbers summed in
// the same order). Work per extraction: W H (prefixes) + TW TH H / 2 (runs) + TW TH lights,
// against the TW TH W H of summing every texel for every normal.
#include "shared.h"
#include "lights.clh"

// Compensated sums rely on each addition being rounded on its own (back on after
// irradiance_prefix).
#pragma OPENCL FP_CONTRACT OFF

// Prefix entry: 3 float3 (9 floats, vload3/vstore3), the R, G and B sums of L_t m_t (xyz).
#define PREFIX_ENTRY 3

// Neumaier's compensated step: *s + *comp is the running sum to about half an ulp; returns it.
static float3 neumaier(float3* s, float3* comp, float3 x) {
  const float3 t = *s + x;
  *comp += select((x - t) + *s, (*s - t) + x, isgreaterequal(fabs(*s), fabs(x)));
  *s = t;
  return t + *comp;
}

// One work-item per map row r = r0 + k of a chunk of nrows rows: float3 (k (W + 1) + w) 3 + rgb
// of prefix = sum over world columns < w of L_t m_t. World column w is map column w + whole (modulo
// W; pb_env_world_column): cols[] already holds each map column's world integrals. The running sums
// are Neumaier's (compensated): each stored prefix then differs from the exact one by about half a
// float ulp, and a run's sum loses at most an ulp of the prefixes at its two ends.
kernel void irradiance_prefix(global const float* equirect, int W, int whole,
                              global const float8* rows, global const float8* cols, int r0,
                              int nrows, global float* prefix) {
  const int k = get_global_id(0);
  if (k >= nrows) return;
  const int r = r0 + k;
  const float8 T = rows[r];
  global float* out = prefix + (size_t)k * (W + 1) * PREFIX_ENTRY * 3;
  float3 sr = (float3)(0.0f), sg = sr, sb = sr, cr = sr, cg = sr, cb = sr;
  vstore3(sr, 0, out);
  vstore3(sr, 1, out);
  vstore3(sr, 2, out);
  int c = whole;
  for (int w = 0; w < W; ++w) {
    const float8 P = cols[c];
    // texel moment: x = int sin^2 * int sin, y = int cos sin * int 1, z = -int sin^2 * int cos
    // (pb_equirect_dir: x = sin(theta) sin(phi), y = cos(theta), z = -sin(theta) cos(phi))
    const float3 m = (float3)(T.s1 * P.s1, T.s2 * P.s0, -T.s1 * P.s2);
    const float3 L = vload3((size_t)r * W + c, equirect);
    const size_t e = (size_t)(w + 1) * PREFIX_ENTRY;
    vstore3(neumaier(&sr, &cr, L.x * m), e, out);
    vstore3(neumaier(&sg, &cg, L.y * m), e + 1, out);
    vstore3(neumaier(&sb, &cb, L.z * m), e + 2, out);
    if (++c == W) c = 0;
  }
}

#pragma OPENCL FP_CONTRACT ON

// One work-item per table normal: pb_ambient_map_normal once (w = 0), for the kernels below.
kernel void irradiance_normals(int TW, int TH, global float4* normals) {
  const int o = get_global_id(0);
  if (o >= TW * TH) return;
  float nx, ny, nz;
  pb_ambient_map_normal(o % TW, o / TW, TW, TH, &nx, &ny, &nz);
  normals[o] = (float4)(nx, ny, nz, 0.0f);
}

// One work-item per (table row j, map row r): the half-width, in columns, of the run of texels of
// row r with n.m_t > 0 for the normals of table row j (header), -1 for none, W for all. chord =
// 2 sin(pi / W), dphi = 2 pi / W (the host's doubles, so that W = 1 gives chord ~0, not a
// negative float sin(pi)).
kernel void irradiance_halfwidth(int W, int H, global const float8* rows, int TW, int TH,
                                 global const float4* normals, float chord, float dphi,
                                 global float* halfwidth) {
  const int id = get_global_id(0);
  if (id >= H * TH) return;
  const int j = id / H, r = id - j * H;
  const float4 nj = normals[(size_t)j * TW];
  const float ny = nj.y, rho = sqrt(nj.x * nj.x + nj.z * nj.z);
  const float8 T = rows[r];
  // n.m_t > 0  <=>  den cos(phi_t - phi_n) > num, den >= 0
  const float num = -ny * T.s2 * dphi, den = rho * T.s1 * chord;
  float hw;
  if (!(den > 0.0f)) {
    hw = num < 0.0f ? (float)W : -1.0f;
  } else {
    const float tau = num / den;
    hw = tau >= 1.0f ? -1.0f
                     : (tau < -1.0f ? (float)W : acos(tau) * (float)W / 6.28318530717958647692f);
  }
  halfwidth[id] = hw;
}

// One work-item per (band b of `band` map rows, table normal o), for the nb bands from b0 whose
// rows' prefixes are in `prefix` (the host's chunk): global id (b - b0) R + o, R = the normals
// computed (below), so that neighbouring work-items read the same rows. partial[(b TW TH +
// o) 3 + rgb] = n . (sum over the band's rows of the run's sum of L_t m_t). frac: the fractional
// part of the map's rotation in columns (world column w covers longitude [w - frac, w - frac + 1)
// in columns).
//
// When TW is even every table normal's antipode is one too: (i + TW/2 mod TW, TH - 1 - j) (nodes
// symmetric in latitude, centres in longitude). The texels with (-n).m_t > 0 are those with
// n.m_t < 0, the complement of n's run in each row, so with the row's total M_r the antipode's sum
// is n'.(M_r - run) (n' its own float normal; a texel with n.m_t = 0 adds 0 either way). Then only
// the first half of the table, o < TW TH / 2 (R = TW TH / 2), is computed, each work-item writing
// its normal's and its antipode's band sums; otherwise R = TW TH.
kernel void irradiance_bands(global const float* prefix, int W, int H, float frac,
                             global const float* halfwidth, global const float4* normals, int TW,
                             int TH, int band, int b0, int nb, global float* partial) {
  const int N = TW * TH;
  const int pairs = (TW & 1) == 0, R = pairs ? N / 2 : N;
  const int id = get_global_id(0);
  const int bl = id / R, o = id - bl * R;
  if (bl >= nb) return;
  const int b = b0 + bl;  // prefix holds the chunk of rows from b0 band
  const int j = o / TW, i = o - j * TW;
  // the normal's longitude in world columns (pb_equirect_dir at column i + 0.5 of TW), less the
  // centre of world column 0 (at 0.5 - frac): texel w is in the run when |w - x| < half-width
  const float x = ((float)i + 0.5f) / (float)TW * (float)W - 0.5f + frac;
  // runs' sums (s) and rows' totals (m), R, G, B
  float3 sr = (float3)(0.0f), sg = sr, sb = sr, mr = sr, mg = sr, mb = sr;
  const int r1 = min(H, (b + 1) * band);
  for (int r = b * band; r < r1; ++r) {
    const float hw = halfwidth[(size_t)j * H + r];
    // entries (3 float3 each) of this row
    const size_t row = (size_t)(r - b0 * band) * (W + 1) * PREFIX_ENTRY;
    const size_t pend = row + (size_t)W * PREFIX_ENTRY;
    const float3 er = vload3(pend, prefix), eg = vload3(pend + 1, prefix),
                 eb = vload3(pend + 2, prefix);
    mr += er;
    mg += eg;
    mb += eb;
    int lo = (int)floor(x - hw) + 1;
    const int count = (int)ceil(x + hw) - lo;  // world columns lo .. lo + count - 1
    if (count <= 0) continue;
    if (count >= W) {
      sr += er;
      sg += eg;
      sb += eb;
      continue;
    }
    // x is in [-0.5, W + 0.5), hw in [0, W / 2]: lo is in [-W / 2, 3 W / 2)
    if (lo < 0) lo += W;
    else if (lo >= W) lo -= W;
    const int hi = lo + count;
    const size_t plo = row + (size_t)lo * PREFIX_ENTRY;
    if (hi <= W) {
      const size_t phi = row + (size_t)hi * PREFIX_ENTRY;
      sr += vload3(phi, prefix) - vload3(plo, prefix);
      sg += vload3(phi + 1, prefix) - vload3(plo + 1, prefix);
      sb += vload3(phi + 2, prefix) - vload3(plo + 2, prefix);
    } else {  // the run wraps past world column W - 1
      const size_t phi = row + (size_t)(hi - W) * PREFIX_ENTRY;
      sr += (er - vload3(plo, prefix)) + vload3(phi, prefix);
      sg += (eg - vload3(plo + 1, prefix)) + vload3(phi + 1, prefix);
      sb += (eb - vload3(plo + 2, prefix)) + vload3(phi + 2, prefix);
    }
  }
  const float3 n = normals[o].xyz;
  vstore3((float3)(dot(n, sr), dot(n, sg), dot(n, sb)), (size_t)b * N + o, partial);
  if (pairs) {
    const int oa = (TH - 1 - j) * TW + (i < TW / 2 ? i + TW / 2 : i - TW / 2);
    const float3 na = normals[oa].xyz;
    vstore3((float3)(dot(na, mr - sr), dot(na, mg - sg), dot(na, mb - sb)), (size_t)b * N + oa,
            partial);
  }
}

// Light l's irradiance at unit normal n: shading's own (kernels/lights/lights.clh). *moment: for a
// cap, pi sin^2(alpha) (its unclamped first moment's length, below), -1 for a polygon.
static float light_irradiance(global const float4* lights, global const float4* polys, int l,
                              float3 n, float* moment) {
  global const float4* pv = polys + (size_t)l * PB_MAX_POLY_VERTS;
  const float4 dir = lights[2 * l];
  *moment = pv[0].w >= 3.0f ? -1.0f : 3.14159265358979323846f * fmax(0.0f, 1.0f - dir.w * dir.w);
  return pb_light_irradiance(dir, pv, n);
}

// One work-item per table normal (per pair of antipodes when TW is even, as irradiance_bands): the
// bands' partial sums in order, minus each light's irradiance. For a cap the antipode's needs no
// second evaluation: max(0, x) - max(0, -x) = x, so E(n) - E(-n) = integral over the cap of n.w =
// pi sin^2(alpha) (n.d) exactly (n' = -n up to float rounding of the two normals, a few 1e-7 of
// the cap's irradiance). lights: 2 float4 per light, (direction, cos alpha) and (radiance, 0);
// polys: PB_MAX_POLY_VERTS float4 per light (src/lights/light_buffers.hpp, shade.cl's layout).
// table: TW x TH x RGB.
kernel void irradiance_table(global const float* partial, int bands, global const float4* normals,
                             global const float4* lights, int nlights, global const float4* polys,
                             int TW, int TH, global float* table) {
  const int N = TW * TH;
  const int pairs = (TW & 1) == 0, R = pairs ? N / 2 : N;
  const int o = get_global_id(0);
  if (o >= R) return;
  const int j = o / TW, i = o - j * TW;
  const int oa = pairs ? (TH - 1 - j) * TW + (i < TW / 2 ? i + TW / 2 : i - TW / 2) : o;
  const float3 n = normals[o].xyz, na = normals[oa].xyz;
  float3 acc = (float3)(0.0f), acca = acc;
  for (int b = 0; b < bands; ++b) {
    acc += vload3((size_t)b * N + o, partial);
    acca += vload3((size_t)b * N + oa, partial);
  }
  for (int l = 0; l < nlights; ++l) {
    const float3 rad = lights[2 * l + 1].xyz;
    float moment;
    const float e = light_irradiance(lights, polys, l, n, &moment);
    acc -= e * rad;
    if (!pairs) continue;
    float ea;
    if (moment >= 0.0f) {
      const float4 dir = lights[2 * l];
      ea = fmax(0.0f, e + moment * (na.x * dir.x + na.y * dir.y + na.z * dir.z));
    } else {
      ea = light_irradiance(lights, polys, l, na, &moment);
    }
    acca -= ea * rad;
  }
  vstore3(acc, o, table);
  if (pairs) vstore3(acca, oa, table);
}
