// Mip pyramids of filterable shadow maps (the cheaper of Annen et al.'s (2008) two prefilters, §4.1
// and
// Fig. 8): every level's texel is the exact 64-bit sum of its up to four children, so the
// pyramid, like the SAT, is bit-identical on every device and work-group size. The layout and the
// query (trilinear interpolation of texel means) are in filter.clh.
//
// Build options:
//   MIP_TILE  side of a work-group (a power of two): one launch builds up to log2(MIP_TILE) + 1
//             levels, the first from global memory, the rest in local memory.
#include "shared.h"
#include "filter.clh"

#ifndef MIP_TILE
#define MIP_TILE 16
#endif

// Builds levels src+1 .. src+depth of every image (image b at element b * stride) from level src.
// Work-items map to texels (x, y) of level src+1 and images (dimension 2); the global size is
// n_{src+1} rounded up to MIP_TILE in x and y. Each work-group then reduces its MIP_TILE^2 sums to
// (MIP_TILE/2)^2, ... in local memory, a 2x2 block of the previous step per texel, so a launch
// reads level src once and writes depth levels: the 8 (256^2) to 10 (1024^2) levels of a map take
// two launches instead of one per level (the top levels are too small to fill a device alone).
// Group-tile boundaries are multiples of MIP_TILE >> (d - 1) at level src+d, so every child of a
// texel lies in the same work-group. Texels past a level's edge are summed as zero and never
// stored: a ragged edge texel sums just the children that exist (filter.clh). depth is uniform
// across the group, so every work-item meets the same barriers.
kernel __attribute__((reqd_work_group_size(MIP_TILE, MIP_TILE, 1)))
void mip_build(global long4* maps, int size, ulong stride, int src, int depth) {
  local long4 tile[MIP_TILE * MIP_TILE];
  const int lx = get_local_id(0), ly = get_local_id(1);
  const int x = get_global_id(0), y = get_global_id(1);
  global long4* img = maps + get_global_id(2) * stride;

  const int n = mip_level_size(size, src);
  const size_t off = mip_level_offset(size, src);
  long4 s = (long4)(0);
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      int cx = 2 * x + dx, cy = 2 * y + dy;
      if (cx < n && cy < n) s += img[off + (size_t)cy * n + cx];
    }
  int n1 = mip_level_size(size, src + 1);
  size_t off1 = off + (size_t)n * n;
  if (x < n1 && y < n1) img[off1 + (size_t)y * n1 + x] = s;
  tile[ly * MIP_TILE + lx] = s;

  int side = MIP_TILE;  // texels of the current level this group holds, per axis
  for (int d = 2; d <= depth; ++d) {
    off1 += (size_t)n1 * n1;
    n1 = mip_level_size(size, src + d);
    side >>= 1;
    const bool live = lx < side && ly < side;
    long4 v = (long4)(0);
    barrier(CLK_LOCAL_MEM_FENCE);  // the previous level is complete in `tile`
    if (live) {
      int c = 2 * ly * MIP_TILE + 2 * lx;
      v = tile[c] + tile[c + 1] + tile[c + MIP_TILE] + tile[c + MIP_TILE + 1];
    }
    barrier(CLK_LOCAL_MEM_FENCE);  // every read is done before the level is overwritten
    if (live) {
      tile[ly * MIP_TILE + lx] = v;
      int X = get_group_id(0) * side + lx, Y = get_group_id(1) * side + ly;
      if (X < n1 && Y < n1) img[off1 + (size_t)Y * n1 + X] = v;
    }
  }
}

// Test probe (tests/test_prefilter.cpp): FILTER_BOX of box i (x0, y0, x1, y1) on image image[i],
// from a SAT or, built with -DPREFILTER_MIP, from a mip pyramid; the query as the techniques'
// kernels compile it.
kernel void filter_box_probe(global const long4* maps, int size, ulong stride,
                             global const float4* boxes, global const int* image, int n,
                             global float4* out) {
  int i = get_global_id(0);
  if (i >= n) return;
  float4 b = boxes[i];
  out[i] = FILTER_BOX(maps + image[i] * stride, size, b.x, b.y, b.z, b.w);
}
