// Area approximation for polygonal lights (Ying et al. 2002, Ying, Tang, Dong: "Soft Shadow Maps
// for Area Light by Area Approximation", §2). The light's boundary is sampled at its vertices and
// along its edges; each sample direction has its own orthographic depth map (src/shadows/area.cpp).
// Per receiver:
//   1. point visibility V_p(P_k) of every boundary sample: one depth test in its map (§2); a
//      sample under the receiver's horizon counts as lit, its light clipped away in step 3;
//   2. on every boundary segment whose two ends disagree, the linear-light visibility V_s (the
//      lit share of the segment, after Heidrich et al. 2000, the paper's ref. [1]), which places
//      the shadow boundary's crossing point on that segment;
//   3. the visible area S_e: the lit boundary runs, each closed by the straight chord between its
//      two crossing points, summed (§2, Figure 1 and its equation); visibility = S_e / S_a.
//
// Where the areas live: every light is at infinity, so a "sample point" is a direction. In the
// light's gnomonic plane (the plane at unit distance along the light's centre direction c, a
// direction d maps to d / (d.c)), great circles are straight lines: the polygon's great-arc edges
// are straight segments, the shadow boundary a straight occluder edge casts on the light (the
// directions grazing that edge lie in the plane through the receiver and the edge, a great
// circle) is a straight line, and the paper's planar polygon and triangle decomposition apply
// exactly there. The host gives each sample's gnomonic coordinates (q_k) in boundary order.
//
// S_e is measured by the irradiance the lit part sends the receiver (Lambert's formula, a sum over
// edges like the shoelace formula, see area_ratio): the paper's planar area weighs every part of
// the light alike, which the gnomonic plane distorts by up to (1 + tan^2 alpha)^(-3/2) (0.46 at a
// 40-degree half-width: median cut's lights are that wide) and which ignores the cosine the
// shading applies. The paper's own expansion (S(P1P2P4)(1 - a) + b (S(P1P4P5) + ...)) is the
// shoelace sum with precomputed triangle areas; here each edge costs an atan2 instead. Cost: one
// depth test per sample and, per segment crossing the shadow boundary, `taps` texel reads;
// nothing grows with the pixel's penumbra width.
#include "shared.h"
#include "filter.clh"
#include "shadow_params.h"

// Most boundary samples per light: the point visibilities of one receiver fit one ulong.
#define AREA_MAX_SAMPLES 64

// A receiver as one sample's depth map sees it (the orthographic view of raster.cl).
typedef struct {
  float u, v;    // continuous texel coordinates (row 0 at +ey), inside [0, size]
  float d;       // normalized depth (0 at the near plane, 1 at the far plane)
  float du, dv;  // receiver plane: normalized depth per texel along u and v
  float tx, ty;  // world size of a texel along x and y
  float range;   // world depth range of the map
} area_point;

static area_point area_point_of(const pb_light* L, float3 p, float3 g, int size) {
  float3 w = (float3)(L->dir[0], L->dir[1], L->dir[2]);
  float3 ex = (float3)(L->ex[0], L->ex[1], L->ex[2]), ey = (float3)(L->ey[0], L->ey[1], L->ey[2]);
  float3 r = p - (float3)(L->origin[0], L->origin[1], L->origin[2]);
  area_point m;
  m.range = L->origin[3];
  m.u = clamp((dot(r, ex) / L->ex[3] + 1.0f) * 0.5f * size, 0.0f, (float)size);
  m.v = clamp((1.0f - dot(r, ey) / L->ey[3]) * 0.5f * size, 0.0f, (float)size);
  m.d = dot(r, -w) / m.range;
  m.tx = 2.0f * L->ex[3] / size;
  m.ty = 2.0f * L->ey[3] / size;
  float2 slope = receiver_slope(g, ex, ey, w, m.tx, m.ty, m.range, PB_UNCLAMPED_SLOPE);
  m.du = slope.x;
  m.dv = slope.y;
  return m;
}

// The receiver's (plane) depth at the centre of texel (i, j), less the bias.
static float area_receiver(const area_point* m, int i, int j, float bias) {
  return m->d - bias + m->du * (i + 0.5f - m->u) + m->dv * (j + 0.5f - m->v);
}

static float area_texel(global const uint* map, int size, int i, int j, float range) {
  return as_float(map[(size_t)j * size + i]) / range;  // +inf where the map is empty
}

// Step 2: lit share of the boundary segment from blocked sample j to lit sample i (its linear-
// light visibility V_s). Heidrich's idea with one map: the blocker seen in j's map at the receiver
// lies delta (world) in front of it; a ray leaving the receiver towards a direction a fraction t of
// the way from d_j to d_i reaches that blocker's depth at the lateral offset delta t g_ji in j's
// map, g_ji = (d_i.ex_j, d_i.ey_j) / (d_i.d_j) (the gnomonic coordinates of d_i about d_j; linear
// in t to first order in the segment's angle). `taps` texels along that line, at t = (k + 1/2) /
// taps, tell which rays pass the blocker: a tap holding a surface no deeper than halfway from the
// blocker to the receiver (and in front of the receiver's plane) blocks its ray. taps = 0: the
// boundary is put at the segment's midpoint.
static float segment_lit(const pb_light* Sj, const pb_light* Si, global const uint* map, int size,
                         float3 p, float3 g, float bias, int taps) {
  if (taps <= 0) return 0.5f;
  area_point m = area_point_of(Sj, p, g, size);
  int i0 = min((int)m.u, size - 1), j0 = min((int)m.v, size - 1);
  float zb = area_texel(map, size, i0, j0, m.range);
  float delta = area_receiver(&m, i0, j0, bias) - zb;  // normalized depth, > 0: j is blocked
  if (!(delta > 0.0f)) return 0.5f;
  float3 di = (float3)(Si->dir[0], Si->dir[1], Si->dir[2]);
  float3 dj = (float3)(Sj->dir[0], Sj->dir[1], Sj->dir[2]);
  float3 ex = (float3)(Sj->ex[0], Sj->ex[1], Sj->ex[2]), ey = (float3)(Sj->ey[0], Sj->ey[1], Sj->ey[2]);
  float c = fmax(dot(di, dj), 1e-6f);
  float world = delta * m.range;
  float gu = world * dot(di, ex) / c / m.tx, gv = -world * dot(di, ey) / c / m.ty;  // texels
  int lit = 0;
  for (int k = 0; k < taps; ++k) {
    float t = (k + 0.5f) / taps;
    float u = m.u + t * gu, v = m.v + t * gv;
    if (!(u >= 0.0f && u < (float)size && v >= 0.0f && v < (float)size)) {
      ++lit;  // outside the map: outside the scene, nothing blocks
      continue;
    }
    // a blocker near the ray: no deeper than halfway to the receiver, and in front of the
    // receiver's own plane there (a tilted receiver is not its own blocker)
    int ti = (int)u, tj = (int)v;
    float z = area_texel(map, size, ti, tj, m.range);
    if (!(z < zb + 0.5f * delta && z < area_receiver(&m, ti, tj, bias))) ++lit;
  }
  return (float)lit / taps;
}

// Step 3 measures the lit part of the light by its irradiance on the receiver, not by its plane
// area: Lambert's formula E = 1/2 sum_i Theta_i n.g_i over the edges of a polygon of directions
// (Theta_i the edge's angle, g_i the unit normal of its great-circle plane; as shared.h's
// pb_polygon_irradiance), clipped by the receiver's horizon n.w >= 0. Like the shoelace formula it
// is a sum over edges, so each lit run (a polygon of great arcs: samples, crossings and the chord)
// is accumulated edge by edge in the same walk. S_e / S_a weighted this way is the visibility the
// shading needs (the irradiance-weighted share of the light; brute force weighs its samples the
// same way), exactly so for a straight occluder edge, with no gnomonic distortion however wide the
// light, and a light straddling the horizon is judged on its part above it.
// Directions are in the light's frame (ex, ey, c): a gnomonic point q is the direction (q, 1).
typedef struct {
  float e;          // accumulated irradiance (twice, see lambert_edge)
  float3 out, in;   // where the polygon left and re-entered the upper hemisphere
  int flags;        // 1: left, 2: re-entered
} lambert_acc;

// 2 x Lambert's term of edge a -> b (lengths of a and b do not matter).
static float lambert_edge(float3 a, float3 b, float3 n) {
  float3 g = cross(a, b);
  float len = length(g);
  if (!(len > 0.0f)) return 0.0f;  // a zero-length edge adds nothing
  return atan2(len, dot(a, b)) * dot(n, g) / len;
}

// Adds edge a -> b clipped by the horizon. A convex polygon leaves the upper hemisphere at most
// once; the horizon arc from the exit to the re-entry closes it (lambert_close).
static void lambert_add(lambert_acc* A, float3 a, float3 b, float3 n) {
  float da = dot(n, a), db = dot(n, b);
  if (da >= 0.0f && db >= 0.0f) {
    A->e += lambert_edge(a, b, n);
  } else if (da >= 0.0f || db >= 0.0f) {
    float3 x = a + (da / (da - db)) * (b - a);  // the edge's point on the horizon
    if (da >= 0.0f) {
      A->e += lambert_edge(a, x, n);
      A->out = x;
      A->flags |= 1;
    } else {
      A->e += lambert_edge(x, b, n);
      A->in = x;
      A->flags |= 2;
    }
  }
}

static void lambert_close(lambert_acc* A, float3 n) {
  if (A->flags == 3) A->e += lambert_edge(A->out, A->in, n);
  A->flags = 0;
}

static float3 dir_of(float2 q) { return (float3)(q.x, q.y, 1.0f); }

// Step 3: S_e / S_a from the boundary samples' gnomonic positions q[0..n) (counter-clockwise,
// convex), their point visibilities (bit k of `lit`), for each segment k -> k+1 whose ends
// disagree seg[k] = its lit share, and the receiver's normal n in the light's frame. A lit run
// entered across segment (a, b) starts at the crossing q_a + (1 - s)(q_b - q_a) (the lit share s
// lies next to the lit end b), runs through its lit samples, and leaves at the crossing of its
// exit segment; the chord between the two crossings closes it (the paper's Figure 1: its S_h is
// this run's area). Runs are summed: for a straight boundary crossing the light (one run) this is
// the paper's S_e; for a bar across the light (two runs) it keeps both lit sides. Two blockers
// clipping two corners also give two runs, whose chords then cut off the middle too: boundary
// samples cannot tell the two cases apart (Ying et al. 2002 samples only the boundary), and the bar
// is
// the one that occurs under thin casters.
static float area_ratio(global const float2* q, int n, ulong lit, const float* seg, float3 nrm) {
  ulong all = n >= 64 ? ~(ulong)0 : (((ulong)1 << n) - 1);
  if ((lit & all) == all) return 1.0f;
  if ((lit & all) == 0) return 0.0f;
  lambert_acc T = {0.0f, (float3)(0.0f), (float3)(0.0f), 0};
  for (int k = 0; k < n; ++k) lambert_add(&T, dir_of(q[k]), dir_of(q[(k + 1) % n]), nrm);
  lambert_close(&T, nrm);
  if (!(fabs(T.e) > 0.0f)) return 1.0f;  // no light above the horizon: nothing to shadow
  int b = 0;
  while ((lit >> b) & 1) ++b;  // a blocked sample: no run wraps past the walk's start
  lambert_acc A = {0.0f, (float3)(0.0f), (float3)(0.0f), 0};
  float3 first = (float3)(0.0f), last = (float3)(0.0f);
  for (int s = 1; s <= n; ++s) {
    int k = (b + s) % n, prev = (b + s - 1) % n;
    bool vk = (lit >> k) & 1, vp = (lit >> prev) & 1;
    float2 qa = q[prev], qb = q[k];
    if (vk && !vp) {  // enter a run across (prev, k): prev blocked, lit share next to k
      first = last = dir_of(qa + (1.0f - seg[prev]) * (qb - qa));
    } else if (!vk && vp) {  // leave across (prev, k): prev lit, lit share next to prev
      float3 x = dir_of(qa + seg[prev] * (qb - qa));
      lambert_add(&A, last, x, nrm);
      lambert_add(&A, x, first, nrm);  // the chord
      lambert_close(&A, nrm);
      continue;
    }
    if (vk) {
      lambert_add(&A, last, dir_of(qb), nrm);
      last = dir_of(qb);
    }
  }
  return clamp(A.e / T.e, 0.0f, 1.0f);
}

// Visibility of lights l0 .. l0 + get_global_size(1) - 1 at every pixel. samples: one frame per
// boundary sample (pb_light, dir = the sample direction), q its gnomonic position; maps holds the
// depth maps of samples base .. (this batch), S x S each.
kernel void area_visibility(global const float4* gpos, global const float4* gnrm,
                            global const float4* ggeo, global const pb_light* lights,
                            global const pb_light* samples, global const float2* q,
                            global const area_range* ranges, global const uint* maps, int size,
                            int base, int l0, int npixels, float depth_bias, int taps,
                            global float* vis) {
  int px = get_global_id(0), l = l0 + (int)get_global_id(1);
  if (px >= npixels) return;
  size_t out = (size_t)l * npixels + px;
  float4 p4 = gpos[px];
  pb_light L = lights[l];
  if (p4.w == 0.0f || light_below_horizon(gnrm[px].xyz, &L)) {
    vis[out] = 1.0f;
    return;
  }
  float3 g = ggeo[px].xyz;
  area_range r = ranges[l];
  float3 n = gnrm[px].xyz;  // the shading normal, whose irradiance the shading scales
  float3 nl = (float3)(dot(n, (float3)(L.ex[0], L.ex[1], L.ex[2])),
                       dot(n, (float3)(L.ey[0], L.ey[1], L.ey[2])),
                       dot(n, (float3)(L.dir[0], L.dir[1], L.dir[2])));
  global const float2* ql = q + r.first;
  // Samples under the receiver's horizon send it nothing (step 3 clips them away), but their
  // depth tests look along the receiver's own plane, or from behind it, and may read it as a
  // blocker: a lit run broken there is closed by a chord that cuts off light above the horizon
  // (a lone plane under a light 2 degrees above it read 0.96). They count as lit, and a segment
  // from one of them to a blocked sample crosses at the horizon (step 2), so that what lies
  // under it stays out of the estimate whatever its depth tests say.
  ulong lit = 0, under = 0;
  for (int k = 0; k < r.count; ++k) {  // step 1: V_p of every sample
    if (!(dot(nl, dir_of(ql[k])) > 0.0f)) {
      lit |= (ulong)1 << k;
      under |= (ulong)1 << k;
      continue;
    }
    pb_light S = samples[r.first + k];
    area_point m = area_point_of(&S, p4.xyz, g, size);
    int i = min((int)m.u, size - 1), j = min((int)m.v, size - 1);
    global const uint* map = maps + (size_t)(r.first + k - base) * size * size;
    if (!(area_texel(map, size, i, j, m.range) < area_receiver(&m, i, j, depth_bias)))
      lit |= (ulong)1 << k;
  }
  float seg[AREA_MAX_SAMPLES];
  for (int k = 0; k < r.count; ++k) {  // step 2: V_s where a segment's ends disagree
    int k1 = (k + 1) % r.count;
    bool a = (lit >> k) & 1, b = (lit >> k1) & 1;
    seg[k] = 0.5f;
    if (a == b) continue;
    int blocked = a ? k1 : k, open = a ? k : k1;
    if ((under >> open) & 1) {  // the share of the segment under the horizon, next to `open`
      float hb = dot(nl, dir_of(ql[blocked])), ho = dot(nl, dir_of(ql[open]));
      seg[k] = clamp(-ho / (hb - ho), 0.0f, 1.0f);
      continue;
    }
    pb_light Sj = samples[r.first + blocked], Si = samples[r.first + open];
    seg[k] = segment_lit(&Sj, &Si, maps + (size_t)(r.first + blocked - base) * size * size, size,
                         p4.xyz, g, depth_bias, taps);
  }
  vis[out] = area_ratio(ql, r.count, lit, seg, nl);  // step 3
}

// The area estimate alone, for tests: visibility of `n`-sample boundaries from given point
// visibilities, segment shares and normals in the light's frame (lit[c], seg[c * n + k], nrm[c])
// for `cases` cases sharing q.
kernel void area_ratio_cases(global const float2* q, int n, global const ulong* lit,
                             global const float* seg, global const float4* nrm, int cases,
                             global float* out) {
  int c = get_global_id(0);
  if (c >= cases || n > AREA_MAX_SAMPLES) return;
  float s[AREA_MAX_SAMPLES];
  for (int k = 0; k < n; ++k) s[k] = seg[(size_t)c * n + k];
  out[c] = area_ratio(q, n, lit[c], s, nrm[c].xyz);
}
