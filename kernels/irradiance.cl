// The ambient residual's pre-integrated irradiance map (seed 004 abstract and end of §3: the
// ambient region "is rendered using pre-integrated irradiance mapping"; src/ambient.cpp): for each
// normal n of the table (lights.hpp AmbientMap, shared.h pb_ambient_map_normal),
//   E_res(n) = E_map(n) - sum_i E_light_i(n),   E_map(n) = integral of L(w) max(0, n.w) dw,
// with E_light_i the light's exact unshadowed irradiance as shading computes it (shared.h:
// pb_cap_irradiance, pb_polygon_irradiance), so lights + ambient give E_map on every table normal.
//
// The map is what it is everywhere else in penumbra: constant radiance over each lat-long texel.
// Each texel's first moment m_t = integral of w dw over the texel is exact from the row and column
// integrals the host tabulates in double for kernels/sh.cl (rows: int sin, int sin^2, int cos sin;
// columns: int 1, int sin, int cos, with the map's rotation in them), and the texel contributes
// L_t max(0, n.m_t): exact whenever the texel lies wholly on one side of n's horizon (the clamped
// cosine is then linear over it), a second-order error in the texel's size for the few texels the
// horizon cuts. Summed over every texel per normal that is W x H work per table texel; instead
// irradiance_cells reduces the map once into cells of CW x CH texels, each with its RGB first
// moment M1 = sum L_t m_t and a cap that bounds it. For n and a cell wholly above n's horizon the
// cell's sum is exactly n.M1 (every term is positive), wholly below it is 0, and only the cells
// the horizon crosses (a great circle's worth) are summed texel by texel.
#include "shared.h"

// Cell record: 4 float4 per cell: the first moment of R, G, B (xyz each), then the bounding cap:
// axis xyz, w = sin of its radius (2 when the radius is >= 90 degrees: the cell always straddles).
#define CELL_RECORD 4

// Texel (r, c)'s first moment from the row and column integrals (kernels/sh.cl's tables):
// x = sin(theta) sin(phi), y = cos(theta), z = -sin(theta) cos(phi) (pb_equirect_dir), and
// dw = sin(theta) dtheta dphi, so int x dw = int sin^2 * int sin, and so on.
static float3 texel_moment(float8 T, float8 P) {
  return (float3)(T.s1 * P.s1, T.s2 * P.s0, -T.s1 * P.s2);
}

// One work-item per cell of the map's CW x CH texels (cells at the right and bottom edges hold
// what is left). `shift`: the map's rotation in columns (Environment::rotationColumns): map column
// c starts at world column pb_env_world_column(c), and a cell's columns are contiguous in world
// longitude (modulo the width, which directions do not see).
kernel void irradiance_cells(global const float* equirect, int W, int H, int CW, int CH,
                             int cellsX, int cellsY, global const float8* rows,
                             global const float8* cols, float shift, global float4* cells) {
  const int id = get_global_id(0);
  if (id >= cellsX * cellsY) return;
  const int cy = id / cellsX, cx = id - cy * cellsX;
  const int r0 = cy * CH, r1 = min(r0 + CH, H), c0 = cx * CW, c1 = min(c0 + CW, W);
  float3 mr = (float3)(0.0f), mg = (float3)(0.0f), mb = (float3)(0.0f);
  for (int r = r0; r < r1; ++r) {
    const float8 T = rows[r];
    for (int c = c0; c < c1; ++c) {
      const float3 m = texel_moment(T, cols[c]);
      const float3 L = vload3((size_t)r * W + c, equirect);
      mr += L.x * m;
      mg += L.y * m;
      mb += L.z * m;
    }
  }
  // Bounding cap about the direction at the cell's centre. The cell is the lat-long rectangle
  // [theta0, theta1] x [phi0, phi1]; while it spans at most 90 degrees of longitude its farthest
  // point from that centre is one of its corners (along a parallel the distance grows with the
  // longitude difference; along a meridian the distance has no interior maximum inside [0, pi]).
  // Wider cells (maps narrower than 4 cells) are always summed texel by texel.
  const float ws = pb_env_world_column(c0, shift, W), nc = (float)(c1 - c0);
  float ax, ay, az;
  pb_equirect_dir(ws + 0.5f * nc, 0.5f * (float)(r0 + r1), (float)W, (float)H, &ax, &ay, &az);
  float sinr = 2.0f;
  if (4.0f * nc <= (float)W) {
    float cmin = 1.0f;
    for (int k = 0; k < 4; ++k) {
      float x, y, z;
      pb_equirect_dir(ws + ((k & 1) ? nc : 0.0f), (float)((k & 2) ? r1 : r0), (float)W, (float)H,
                      &x, &y, &z);
      cmin = fmin(cmin, ax * x + ay * y + az * z);
    }
    // 1e-4: float rounding of the directions; a cell taken whole a hair too early adds only its
    // terms with n.w ~ -1e-4, a cell summed per texel costs time, not accuracy.
    if (cmin > 0.0f) sinr = fmin(1.0f, sqrt(fmax(0.0f, 1.0f - cmin * cmin)) + 1e-4f);
  }
  global float4* out = cells + (size_t)id * CELL_RECORD;
  out[0] = (float4)(mr, 0.0f);
  out[1] = (float4)(mg, 0.0f);
  out[2] = (float4)(mb, 0.0f);
  out[3] = (float4)(ax, ay, az, sinr);
}

// One work-group per table texel: its work-items stride over the cells (and the texels of the
// cells n's horizon crosses), then over the lights, and reduce in local memory (3 floats per
// work-item; local size a power of two). lights: 2 float4 per light, (direction, cos alpha) and
// (radiance, vertex count: 0 for a cap); polys: PB_MAX_POLY_VERTS float4 per light (shade.cl's
// layout). table: TW x TH x RGB. The cells are visited in world order: world cell column x is map
// cell column x + cell_shift (the rotation in whole cells, 0 unless it is one), so a map turned by
// whole cells sums exactly the same numbers in the same order as the map with its columns shifted,
// and gives the same table bit for bit (tests/test_animation.cpp renders both).
kernel void irradiance_table(global const float4* cells, int cellsX, int cellsY, int cell_shift,
                             global const float* equirect, int W, int H, int CW, int CH,
                             global const float8* rows, global const float8* cols,
                             global const float4* lights, int nlights, global const float4* polys,
                             int TW, int TH, local float* scratch, global float* table) {
  const int j = get_group_id(0), lid = get_local_id(0), wg = get_local_size(0);
  if (j >= TW * TH) return;  // uniform per work-group
  float nx, ny, nz;
  pb_ambient_map_normal(j % TW, j / TW, TW, TH, &nx, &ny, &nz);
  const float3 n = (float3)(nx, ny, nz);
  float3 acc = (float3)(0.0f);
  const int ncells = cellsX * cellsY;
  for (int kw = lid; kw < ncells; kw += wg) {
    const int cy = kw / cellsX, wx = kw - cy * cellsX;
    const int cx = wx + cell_shift >= cellsX ? wx + cell_shift - cellsX : wx + cell_shift;
    global const float4* cell = cells + ((size_t)cy * cellsX + cx) * CELL_RECORD;
    const float4 cap = cell[3];
    const float d = dot(n, cap.xyz);
    if (d >= cap.w) {
      acc += (float3)(dot(n, cell[0].xyz), dot(n, cell[1].xyz), dot(n, cell[2].xyz));
    } else if (d > -cap.w) {
      const int r0 = cy * CH, r1 = min(r0 + CH, H), c0 = cx * CW, c1 = min(c0 + CW, W);
      for (int r = r0; r < r1; ++r) {
        const float8 T = rows[r];
        for (int c = c0; c < c1; ++c) {
          const float e = dot(n, texel_moment(T, cols[c]));
          if (e > 0.0f) acc += e * vload3((size_t)r * W + c, equirect);
        }
      }
    }
  }
  for (int l = lid; l < nlights; l += wg) {
    const float4 dir = lights[2 * l], rad = lights[2 * l + 1];
    const int nv = (int)rad.w;
    float e;
    if (nv >= 3) {
      global const float4* pv = polys + (size_t)l * PB_MAX_POLY_VERTS;
      float v[3 * PB_MAX_POLY_VERTS];
      const int m = min(nv, PB_MAX_POLY_VERTS);
      for (int i = 0; i < m; ++i) {
        v[3 * i] = pv[i].x;
        v[3 * i + 1] = pv[i].y;
        v[3 * i + 2] = pv[i].z;
      }
      e = pb_polygon_irradiance(v, m, nx, ny, nz);
    } else {
      e = pb_cap_irradiance(dir.w, dot(n, dir.xyz));
    }
    acc -= e * rad.xyz;
  }
  scratch[3 * lid] = acc.x;
  scratch[3 * lid + 1] = acc.y;
  scratch[3 * lid + 2] = acc.z;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int s = wg / 2; s > 0; s >>= 1) {
    if (lid < s)
      for (int c = 0; c < 3; ++c) scratch[3 * lid + c] += scratch[3 * (lid + s) + c];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (lid == 0)
    for (int c = 0; c < 3; ++c) table[3 * (size_t)j + c] = scratch[c];
}
