/* Constants and small functions shared by the host (C++) and the kernels (OpenCL C 1.2).
 * Written in the common subset of both languages: the kernels get it spliced in at build time
 * (cmake/embed_kernels.cmake), the host includes it directly, so nothing is kept in sync by hand.
 * */
#ifndef PENUMBRA_SHARED_H
#define PENUMBRA_SHARED_H

#ifdef __OPENCL_VERSION__
#define PB_INLINE static inline
/* An explicit SIMD loop for CPU drivers: vectorized `width` lanes wide by the compiler (the
 * kernels' CPU forms, src/core/device_kind.hpp). -DPB_NO_SIMD_LOOPS leaves the loop scalar: the
 * oclgrind simulator mis-runs some vectorized loops (masked loads and reductions), and there
 * the loop's logic is what is checked. */
#define PB_PRAGMA(x) _Pragma(#x)
#ifdef PB_NO_SIMD_LOOPS
#define PB_SIMD_LOOP(width)
#else
#define PB_SIMD_LOOP(width) PB_PRAGMA(clang loop vectorize(assume_safety) vectorize_width(width))
#endif
/* The opposite, for a loop whose body reads whole vectors (a long4 per lattice value) that a
 * vectorized loop would turn into one gather per component. */
#define PB_SCALAR_LOOP PB_PRAGMA(clang loop vectorize(disable))
/* dot() and cross() of two float3 as PoCL's library computes them, on scalars: dot is
 * (p0 + p1) + p2 of rounded products, each component of cross a difference of two rounded
 * products (no fused multiply-add in either). The CPU forms call them in their SIMD loops, where
 * vector types would stop the vectorizer, and get the bits of their per-pixel forms' dot() and
 * cross(). */
static inline __attribute__((always_inline)) float dot3_s(float ax, float ay, float az, float bx,
                                                         float by, float bz) {
  float p0 = ax * bx;
  float p1 = ay * by;
  float p2 = az * bz;
  float s = p0 + p1;
  return p2 + s;
}
static inline __attribute__((always_inline)) void cross3_s(float ax, float ay, float az, float bx,
                                                          float by, float bz, float* cx,
                                                          float* cy, float* cz) {
  float x0 = ay * bz;
  float x1 = az * by;
  float y0 = az * bx;
  float y1 = ax * bz;
  float z0 = ax * by;
  float z1 = ay * bx;
  *cx = x0 - x1;
  *cy = y0 - y1;
  *cz = z0 - z1;
}
#else
#include <math.h>
#define PB_INLINE static inline
#endif

/* Rec. 709 / sRGB luminance weights (the Y row of the linear RGB -> XYZ matrix). */
#define PB_LUM_R 0.2126f
#define PB_LUM_G 0.7152f
#define PB_LUM_B 0.0722f
/* The same weights in 1/10000 units, for exact fixed-point luminance. */
#define PB_LUM_R_I 2126
#define PB_LUM_G_I 7152
#define PB_LUM_B_I 722
/* Fixed-point luminance of fixed-point RGB energies, exact (energies stay below 2^48, so the
 * products stay below 2^62); env_sat_inputs, the greedy fit and its host copy all use this. */
#define PB_LUM_FIXED(r, g, b) ((PB_LUM_R_I * (r) + PB_LUM_G_I * (g) + PB_LUM_B_I * (b)) / 10000)
/* The X and Z rows of the same matrix (IEC 61966-2-1:1999, the sRGB standard: Rec. 709 primaries,
 * D65 white), also in 1/10000 units: the median-cut SATs carry colour as CIE XYZ so that Y is
 * shared with the luminance SAT (Kneiphof 2017 §5); src/environment/median_cut.cpp inverts the
 * whole
 * matrix exactly. */
#define PB_X_R_I 4124
#define PB_X_G_I 3576
#define PB_X_B_I 1805
#define PB_Z_R_I 193
#define PB_Z_G_I 1192
#define PB_Z_B_I 9505

#define PB_CUBE_FACES 6
#define PB_MAX_LIGHTS 1024
/* Vertices of a polygon light (lights.hpp). 32 so that an ellipse light's polygon
 * (PB_ELLIPSE_VERTS) fits; shading loops run over a light's own vertex count only. */
#define PB_MAX_POLY_VERTS 32
/* Vertices of the polygon standing for an ellipse light in shading (lights.hpp makeEllipseLight):
 * the affine-regular 32-gon of the ellipse's area, within 0.33% of its radius (measured errors in
 * tests/test_textured_lights.cpp). */
#define PB_ELLIPSE_VERTS 32

/* Moments are stored in fixed point: round(z^k * 2^32) in 64-bit integers. A 4096^2 SAT of values
 * <= 2^32 stays below 2^56, far from overflow, and sums are exact (see kernels/common/scan.cl). */
#define PB_MOMENT_SCALE 4294967296.0

/* Depth written for texels/pixels that no triangle covers: bit pattern of +infinity. */
#define PB_DEPTH_EMPTY 0x7f800000u
#define PB_ID_EMPTY 0xffffffffu

/* Cube-map face orientation (the OpenGL convention): face f, face coordinates u,v in [-1,1]
 * (u grows with the texel column, v with the texel row) -> unnormalized direction. */
PB_INLINE void pb_cube_dir(int face, float u, float v, float* x, float* y, float* z) {
  switch (face) {
    case 0: *x = 1.0f;  *y = -v;    *z = -u;    break; /* +X */
    case 1: *x = -1.0f; *y = -v;    *z = u;     break; /* -X */
    case 2: *x = u;     *y = 1.0f;  *z = v;     break; /* +Y */
    case 3: *x = u;     *y = -1.0f; *z = -v;    break; /* -Y */
    case 4: *x = u;     *y = -v;    *z = 1.0f;  break; /* +Z */
    default: *x = -u;   *y = -v;    *z = -1.0f; break; /* -Z */
  }
}

/* Inverse of pb_cube_dir: direction (any length, not zero) -> face and u,v in [-1,1]. */
PB_INLINE int pb_cube_face(float x, float y, float z, float* u, float* v) {
  float ax = fabs(x), ay = fabs(y), az = fabs(z);
  if (ax >= ay && ax >= az) {
    if (x > 0.0f) { *u = -z / ax; *v = -y / ax; return 0; }
    *u = z / ax; *v = -y / ax; return 1;
  }
  if (ay >= az) {
    if (y > 0.0f) { *u = x / ay; *v = z / ay; return 2; }
    *u = x / ay; *v = -z / ay; return 3;
  }
  if (z > 0.0f) { *u = x / az; *v = -y / az; return 4; }
  *u = -x / az; *v = -y / az; return 5;
}

/* Equirectangular convention (y up): theta = acos(y) from +Y, phi = atan2(x, -z) in (-pi, pi];
 * image column s = (phi/(2 pi) + 0.5) * width, row t = theta/pi * height. The map's centre column
 * looks along -Z. */
PB_INLINE void pb_equirect_dir(float s, float t, float width, float height,
                               float* x, float* y, float* z) {
  float phi = (s / width - 0.5f) * 6.28318530717958647692f;
  float theta = t / height * 3.14159265358979323846f;
  float st = sin(theta);
  *x = st * sin(phi);
  *y = cos(theta);
  *z = -st * cos(phi);
}

PB_INLINE void pb_dir_equirect(float x, float y, float z, float width, float height,
                               float* s, float* t) {
  float len = sqrt(x * x + y * y + z * z);
  float cy = y / len;
  cy = cy > 1.0f ? 1.0f : (cy < -1.0f ? -1.0f : cy);
  *s = (atan2(x, -z) / 6.28318530717958647692f + 0.5f) * width;
  *t = acos(cy) / 3.14159265358979323846f * height;
}

/* Environment rotation about +y (Environment::rotationYDeg, angle a, counter-clockwise seen from
 * above) as a shift of equirect columns. The turned map L'(w) = L(R(-a) w); R(-a) adds a to phi,
 * so world column s reads map column s + shift with shift = a / 360 * width, normalized by the host
 * to [0, width). The shift is applied as its whole and fractional parts separately so that a
 * whole-column shift (90 degrees on a width divisible by 4) reads exactly the texels of the map
 * with its columns shifted, bit for bit. */
PB_INLINE int pb_env_column(float s, float shift, int width) {
  float whole = floor(shift), frac = shift - whole;
  int c = (int)floor(s + frac);
  /* s == width (phi == pi) stays in the last column as the unrotated lookup does; a fractional
   * shift past the seam wraps to the first. */
  if (c >= width) c = frac > 0.0f ? c - width : width - 1;
  if (c < 0) c = 0;
  c += (int)whole;
  return c >= width ? c - width : c;
}

/* Inverse of pb_env_column: the world column where map column c starts; c covers
 * [start, start + 1). Sub-texel positions are start + (i + 0.5) / n. */
PB_INLINE float pb_env_world_column(int c, float shift, int width) {
  float whole = floor(shift), frac = shift - whole;
  int w = c - (int)whole;
  if (w < 0) w += width;
  return (float)w - frac;
}

/* Cube-map texel solid angle (DESIGN.md; Kneiphof 2017 eq. 8 with the exponent's sign restored):
 * d_omega = 4/m^2 * (1 + u^2 + v^2)^(-3/2) at the texel centre (u,v). */
PB_INLINE float pb_cube_texel_solid_angle(float u, float v, int m) {
  float q = 1.0f + u * u + v * v;
  return 4.0f / ((float)m * (float)m) / (q * sqrt(q));
}

/* Irradiance at a surface from a uniform spherical cap of unit radiance, half-angle alpha
 * (0 < alpha < pi/2), whose axis makes angle beta with the normal. Fully above the horizon this is
 * Kneiphof 2017 eq. 15, pi sin^2(alpha) cos(beta). Partly below the horizon, the cap clipped by the
 * tangent plane has the closed form of Snyder (1996), "Area light sources for real-time graphics";
 * checked against numerical integration in tests/test_lights.cpp. */
PB_INLINE float pb_cap_irradiance(float cos_alpha, float cos_beta) {
  float sin2a = 1.0f - cos_alpha * cos_alpha;
  float sin_a = sqrt(sin2a > 0.0f ? sin2a : 0.0f);
  /* beta <= pi/2 - alpha  <=>  cos(beta) >= sin(alpha) */
  if (cos_beta >= sin_a) return 3.14159265358979323846f * sin2a * cos_beta;
  /* beta >= pi/2 + alpha  <=>  cos(beta) <= -sin(alpha) */
  if (cos_beta <= -sin_a) return 0.0f;
  float sin_b = sqrt(fmax(0.0f, 1.0f - cos_beta * cos_beta));
  float x = cos_alpha / sin_a;                /* cot(alpha) */
  float y = -x * cos_beta / sin_b;            /* -cot(alpha) cot(beta), in [-1, 1] here */
  y = y > 1.0f ? 1.0f : (y < -1.0f ? -1.0f : y);
  float sy = sqrt(1.0f - y * y);
  float e = (cos_beta * acos(y) - x * sin_b * sy) * sin2a + atan(sin_b * sy / x);
  return e > 0.0f ? e : 0.0f;
}

/* Whether a cap of half-angle a (sin_a = sin(a)) whose axis has cosine c with a surface's normal
 * is on its horizon: the axis below (c <= 0), part of the cap above (c > -sin a). The horizon step
 * (kernels/render/horizon.cl) rewrites such pairs with margin 0; margin > 0 narrows the band on
 * both sides (kernels/shadows/filter.clh, horizon_rewrites: the pairs it surely rewrites). */
PB_INLINE int pb_on_horizon(float c, float sin_a, float margin) {
  return c <= -margin && c > -sin_a + margin;
}

/* Irradiance at a surface with unit normal n from a convex spherical polygon of unit radiance
 * (lights.hpp: 3..PB_MAX_POLY_VERTS unit vertices v, packed xyz, ordered so that
 * (v_i x v_i+1) . d > 0 about the polygon's inside d). Lambert's formula (Lambert 1760, as Arvo
 * 1995, "Applications of irradiance tensors to the simulation of non-Lambertian phenomena", eq. 8
 * states it): E = 1/2 sum_i Theta_i n . g_i, with Theta_i the angle of edge i and g_i the unit
 * normal of its great-circle plane, g_i = (v_i x v_i+1) / |v_i x v_i+1|. The formula needs the
 * whole polygon above the horizon, so the polygon is first clipped by the plane n . w = 0
 * (Sutherland-Hodgman: a convex polygon cut by a plane stays convex and gains at most one vertex);
 * the new vertices need not be unit length since Theta_i = atan2(|a x b|, a . b) and g_i do not
 * depend on the edge vectors' lengths. atan2 instead of acos keeps short edges accurate in float.
 * Checked against numerical integration in tests/test_polygon_lights.cpp. */
PB_INLINE float pb_polygon_irradiance(const float* v, int nv, float nx, float ny, float nz) {
  float c[3 * (PB_MAX_POLY_VERTS + 1)];
  int nc = 0;
  for (int i = 0; i < nv; ++i) {
    int j = i + 1 == nv ? 0 : i + 1;
    float ax = v[3 * i], ay = v[3 * i + 1], az = v[3 * i + 2];
    float bx = v[3 * j], by = v[3 * j + 1], bz = v[3 * j + 2];
    float da = nx * ax + ny * ay + nz * az, db = nx * bx + ny * by + nz * bz;
    if (da >= 0.0f && nc < PB_MAX_POLY_VERTS + 1) {
      c[3 * nc] = ax; c[3 * nc + 1] = ay; c[3 * nc + 2] = az; ++nc;
    }
    if ((da >= 0.0f) != (db >= 0.0f) && nc < PB_MAX_POLY_VERTS + 1) {
      /* the edge's point on the horizon: a + t (b - a) with t = da / (da - db), which is
       * (b da - a db) / (da - db): keep the numerator, its sign fixed by da - db's */
      float s = da > db ? 1.0f : -1.0f;
      c[3 * nc] = s * (bx * da - ax * db);
      c[3 * nc + 1] = s * (by * da - ay * db);
      c[3 * nc + 2] = s * (bz * da - az * db);
      ++nc;
    }
  }
  if (nc < 3) return 0.0f;
  float e = 0.0f;
  for (int i = 0; i < nc; ++i) {
    int j = i + 1 == nc ? 0 : i + 1;
    float ax = c[3 * i], ay = c[3 * i + 1], az = c[3 * i + 2];
    float bx = c[3 * j], by = c[3 * j + 1], bz = c[3 * j + 2];
    float gx = ay * bz - az * by, gy = az * bx - ax * bz, gz = ax * by - ay * bx;
    float len = sqrt(gx * gx + gy * gy + gz * gz);
    if (len <= 0.0f) continue; /* coincident vertices: a zero-length edge adds nothing */
    float theta = atan2(len, ax * bx + ay * by + az * bz);
    e += theta * (nx * gx + ny * gy + nz * gz) / len;
  }
  e *= 0.5f;
  return e > 0.0f ? e : 0.0f;
}

/* The 9 real spherical harmonics of order <= 2 (Ramamoorthi & Hanrahan 2001, "An efficient
 * representation for irradiance environment maps", eq. 3), written in world x, y, z of a unit
 * direction (any orthonormal basis works if projection and evaluation agree; this is the one both
 * kernels/environment/sh.cl and the host use). Order: (l,m) = (0,0) (1,-1) (1,0) (1,1) (2,-2)
 * (2,-1) (2,0) (2,1) (2,2), as LightSet::ambientSH. */
#define PB_SH_K00 0.282094791773878f  /* 1 / (2 sqrt(pi)) */
#define PB_SH_K1 0.488602511902920f   /* sqrt(3 / (4 pi)) */
#define PB_SH_K2 1.092548430592079f   /* sqrt(15 / (4 pi)), l = 2, m = -2, -1, 1 */
#define PB_SH_K20 0.315391565252520f  /* sqrt(5 / (16 pi)) */
#define PB_SH_K22 0.546274215296040f  /* sqrt(15 / (16 pi)) */
/* Clamped-cosine convolution: irradiance E(n) = sum_lm Ahat_l L_lm Y_lm(n) (R&H 2001 eqs. 7-9,
 * Ahat_0 = pi, Ahat_1 = 2 pi / 3, Ahat_2 = pi / 4; Ahat_l for l = 3 is 0, for l >= 4 small). */
#define PB_SH_AHAT(k) ((k) == 0 ? 3.14159265358979f : ((k) < 4 ? 2.09439510239320f : 0.785398163397448f))

PB_INLINE void pb_sh9(float x, float y, float z, float* b) {
  b[0] = PB_SH_K00;
  b[1] = PB_SH_K1 * y;
  b[2] = PB_SH_K1 * z;
  b[3] = PB_SH_K1 * x;
  b[4] = PB_SH_K2 * x * y;
  b[5] = PB_SH_K2 * y * z;
  b[6] = PB_SH_K20 * (3.0f * z * z - 1.0f);
  b[7] = PB_SH_K2 * x * z;
  b[8] = PB_SH_K22 * (x * x - y * y);
}

/* Bilinear taps of the ambient irradiance map (lights.hpp AmbientMap, kernels/environment/irradiance.cl) of
 * w x h texels at unit normal (x, y, z): four texel indices (row-major) and their weights, read
 * the same way by LightSet::ambientIrradiance, kernels/render/shade.cl and
 * src/gl/shaders/shade.frag (whose GL_LINEAR texture, GL_REPEAT in s and clamped in t, takes these
 * taps). Parameterization: columns are the equirect's (texel centres at phi = ((i + 0.5) / w - 0.5)
 * 2 pi, wrapping), rows are nodes theta_j = j pi / (h - 1), so row 0 is the +y pole itself and row
 * h - 1 the -y pole. With texel-centred rows instead the pole would lie half a row inside the first
 * row, where a bilinear lookup returns one ring texel's value, not the pole's: an error of the
 * irradiance's gradient times pi / (2h), first order, ~2.5% of E on an up-facing floor with a
 * 32-row table where the ambient is half the light (center-surround). Node rows are exact at the
 * poles and interpolate between a pole and the next ring near them. Latitude is clamped (never
 * needed inside [0, pi]); a 1-row table holds the equator's ring (theta = pi / 2) for every normal.
 * */
PB_INLINE void pb_ambient_map_taps(float x, float y, float z, int w, int h, int* idx, float* wt) {
  float s, t;
  pb_dir_equirect(x, y, z, (float)w, 1.0f, &s, &t); /* s in [0, w], t = theta / pi in [0, 1] */
  float u = s - 0.5f, v = h > 1 ? t * (float)(h - 1) : 0.0f;
  float fu = floor(u), fv = floor(v);
  float a = u - fu, b = v - fv;
  int i0 = (int)fu % w;
  if (i0 < 0) i0 += w; /* also catches a non-finite normal's undefined conversion */
  int i1 = i0 + 1 == w ? 0 : i0 + 1;
  int j0 = (int)fv, j1 = j0 + 1;
  j0 = j0 < 0 ? 0 : (j0 > h - 1 ? h - 1 : j0);
  j1 = j1 < 0 ? 0 : (j1 > h - 1 ? h - 1 : j1);
  idx[0] = j0 * w + i0;
  idx[1] = j0 * w + i1;
  idx[2] = j1 * w + i0;
  idx[3] = j1 * w + i1;
  wt[0] = (1.0f - a) * (1.0f - b);
  wt[1] = a * (1.0f - b);
  wt[2] = (1.0f - a) * b;
  wt[3] = a * b;
}

/* The normal of ambient-map texel (i, j) (the parameterization above). */
PB_INLINE void pb_ambient_map_normal(int i, int j, int w, int h, float* x, float* y, float* z) {
  pb_equirect_dir((float)i + 0.5f, h > 1 ? (float)j : 0.5f, (float)w, h > 1 ? (float)(h - 1) : 1.0f,
                  x, y, z);
}

/* One light as the kernels see it (16-byte aligned floats only, identical layout on both sides). */
typedef struct {
  float dir[4];      /* unit direction towards the light (world), w: cos(alpha) */
  float radiance[4]; /* uniform RGB radiance of the cap, w: half-angle alpha in radians */
  float ex[4];       /* shadow-map frame: x axis (world), w: half-extent of the map along x */
  float ey[4];       /* y axis, w: half-extent along y */
  float origin[4];   /* centre of the map's near plane (world), w: depth range (world units) */
} pb_light;

/* Light-space list grid of the bitmask technique (Sintorn et al. 2008 §3.1), one per light, fitted to the 2D
 * bounds of that light's view samples and with its far plane at the farthest of them (§4.3).
 * Coordinates are the light frame's: x = (p - origin).ex, y = (p - origin).ey, depth
 * z = (p - origin).(-dir). Texel (i, j) holds x in [x0 + i/sx, x0 + (i+1)/sx). */
typedef struct {
  float x0, y0;     /* light-frame position of the grid's corner */
  float sx, sy;     /* texels per world unit along ex and ey */
  float zmax;       /* depth of the farthest view sample (the far plane) */
  float tan_alpha;  /* radius of the light's disk at unit depth: tan of the cap's half-angle */
  int size;         /* S: the grid has S x S texels */
  int samples;      /* view samples in the lists (0: the light shadows nothing) */
} pb_list_grid;

/* The list texel of light-frame point (x, y), clamped into the grid. */
PB_INLINE int pb_grid_texel(const pb_list_grid* g, float x, float y) {
  int i = (int)floor((x - g->x0) * g->sx), j = (int)floor((y - g->y0) * g->sy);
  i = i < 0 ? 0 : (i >= g->size ? g->size - 1 : i);
  j = j < 0 ? 0 : (j >= g->size ? g->size - 1 : j);
  return j * g->size + i;
}

#ifdef __OPENCL_VERSION__
/* The light frame's coordinates of world point p (lateral x, y and depth z from the near plane),
 * on scalars (dot3_s: the library's dot() rounding), for every kernel that bins or tests view
 * samples (kernels/shadows/viewsamples.cl, bitmask.cl), in their SIMD loops too: a sample's list
 * texel must come out the same wherever it is computed. */
static inline __attribute__((always_inline)) void pb_light_coords_s(const pb_light* L, float px,
                                                                    float py, float pz, float* x,
                                                                    float* y, float* z) {
  const float rx = px - L->origin[0], ry = py - L->origin[1], rz = pz - L->origin[2];
  *x = dot3_s(rx, ry, rz, L->ex[0], L->ex[1], L->ex[2]);
  *y = dot3_s(rx, ry, rz, L->ey[0], L->ey[1], L->ey[2]);
  *z = -dot3_s(rx, ry, rz, L->dir[0], L->dir[1], L->dir[2]);
}
static inline float3 pb_light_coords(const pb_light* L, float3 p) {
  float x, y, z;
  pb_light_coords_s(L, p.x, p.y, p.z, &x, &y, &z);
  return (float3)(x, y, z);
}
#endif

/* A median-cut region: texels [x0,x1) x [y0,y1) of one cube face; regions with the same group
 * form one light (only when fewer than six lights are asked for, whole faces are grouped). */
typedef struct {
  int face, x0, y0, x1, y1, group, pad0, pad1;
} pb_region;

/* Camera or light projection for the ray-casting rasterizer. */
typedef struct {
  float origin[4];  /* eye (perspective) or near-plane centre (orthographic) */
  float forward[4]; /* unit view direction */
  float right[4];   /* unit; w: tan(fovx/2) (perspective) or half-width (orthographic) */
  float up[4];      /* unit; w: tan(fovy/2) or half-height */
  int width, height, ortho, pad;
} pb_view;

/* Floats as ints that order like the floats (negative ones with their magnitude bits flipped),
 * so kernels/render/bent.cl takes per-vertex minima and maxima of floats with integer atomics. */
#ifdef __OPENCL_VERSION__
PB_INLINE int pb_float_to_ordered(float f) { int i = as_int(f); return i < 0 ? i ^ 0x7fffffff : i; }
PB_INLINE float pb_ordered_to_float(int i) { return as_float(i < 0 ? i ^ 0x7fffffff : i); }
#else
#include <string.h>
PB_INLINE int pb_float_to_ordered(float f) {
  int i;
  memcpy(&i, &f, sizeof i);
  return i < 0 ? i ^ 0x7fffffff : i;
}
PB_INLINE float pb_ordered_to_float(int i) {
  float f;
  i = i < 0 ? i ^ 0x7fffffff : i;
  memcpy(&f, &i, sizeof f);
  return f;
}
#endif

#endif
