// Summed-area tables: in-place 2D inclusive scans of a batch of images stored back to back (image b
// starts at element b*width*height, rows contiguous). A row pass, then a three-step column pass.
//
// Precision strategy. A box filter over a SAT is a difference of four corner values, and the
// corners grow with the image: in a 1024^2 float SAT of values in [0,1] they reach ~5e5, where one
// float ulp is ~0.03, so a small box (whose true sum may be < 1) comes back with an error of the
// same order as its value, and the error depends on the summation order, i.e. on the work-group
// size and the device. penumbra therefore stores the SATs it filters (shadow-map moments,
// environment energies) as 64-bit fixed point, long/long4 holding round(v * 2^32)
// (PB_MOMENT_SCALE): integer addition is exact and associative, so a box query is the exact sum
// of the quantized values whatever the box size or position, and the tables are bit-identical
// for every work-group size and device. (Values <= 2^32 in a 4096^2 table stay within 2^56.) The
// float/float4 variants are for general use; the tests hold them to a double-precision reference
// with a tolerance derived from the sums' magnitude, and show the box-query gap on moment data.
//
// Build options (tuning knobs; the host picks them per device, see src/core/scan.cpp):
//   SCAN_T  element type: float, float4, long or long4
//   WG      row-pass work-group size (power of two)
//   VPT     elements each work-item scans serially per tile (a tile is WG*VPT elements)
//   SEG     rows per column segment
//   COL_LOCKSTEP  1: the column steps synchronize their work-groups after every row (CPUs)

#ifndef SCAN_T
#define SCAN_T float
#endif
#ifndef WG
#define WG 256
#endif
#ifndef VPT
#define VPT 4
#endif
#ifndef SEG
#define SEG 64
#endif
#ifndef COL_LOCKSTEP
#define COL_LOCKSTEP 0
#endif

typedef SCAN_T T;
#define ZERO ((T)(0))
#define TILE (WG * VPT)

// The banded method's accumulator (below, "Banded one-pass method"): the element type itself, or,
// for float tables on devices with cl_khr_fp64, SCAN_ACC (double or double4) with its conversions
// TO_ACC and FROM_ACC, all set by the host (src/core/scan.cpp).
#ifdef SCAN_ACC
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef SCAN_ACC A;
#else
typedef T A;
#define TO_ACC(x) (x)
#endif
#define AZERO ((A)(0))

// Local-memory bank-conflict avoidance (Harris, Sengupta & Owens, "Parallel Prefix Sum (Scan)
// with CUDA", GPU Gems 3 ch. 39.2.3): one element of padding per 128-byte row of 32 four-byte
// banks. With VPT = 4 this makes both the serial per-item reads (stride VPT) and the tree steps
// of the per-item totals scan conflict-free for all four element sizes (4, 8, 16, 32 bytes).
#define BANK_ROW (128 / (int)sizeof(T))
#define PAD(i) ((i) + (i) / BANK_ROW)

// Row pass: one work-group per (row, image), global size WG * height * batch. Images are stored
// back to back, so group g is global row g (image g / height); a 1D range of groups also avoids
// the small grid limits some GPUs put on the second and third dimensions. The group walks its
// row in tiles of WG*VPT elements, carrying the running total from tile to tile, so any width works
// with a fixed amount of local memory. Per tile (Blelloch, "Prefix sums and their applications",
// 1990; work-efficient: O(tile) additions, 2 log2(WG) barrier steps):
//   1. coalesced loads: element i*WG + lid for i < VPT (adjacent work-items, adjacent addresses);
//   2. each work-item scans its VPT consecutive elements serially (registers), keeping its total;
//   3. exclusive up-sweep/down-sweep scan of the WG per-item totals in local memory;
//   4. each work-item adds carry + its exclusive prefix to its elements; coalesced stores.
// Elements past the row's end load as zero and are never stored.
kernel __attribute__((reqd_work_group_size(WG, 1, 1)))
void scan_rows(global T* data, int width) {
  local T tile[PAD(TILE - 1) + 1];
  local T sums[PAD(WG - 1) + 1];
  const int lid = get_local_id(0);
  global T* row = data + get_group_id(0) * (size_t)width;

  T carry = ZERO;
  for (int base = 0; base < width; base += TILE) {  // uniform across the group: barriers are safe
    for (int i = 0; i < VPT; ++i) {
      int j = i * WG + lid;
      tile[PAD(j)] = base + j < width ? row[base + j] : ZERO;
    }
    barrier(CLK_LOCAL_MEM_FENCE);

    T v[VPT];
    T acc = ZERO;
    for (int k = 0; k < VPT; ++k) {
      acc += tile[PAD(lid * VPT + k)];
      v[k] = acc;
    }
    sums[PAD(lid)] = acc;

    // Up-sweep: after it, sums[WG-1] holds the tile total.
    int offset = 1;
    for (int n = WG >> 1; n > 0; n >>= 1) {
      barrier(CLK_LOCAL_MEM_FENCE);
      if (lid < n) {
        int a = offset * (2 * lid + 1) - 1, b = offset * (2 * lid + 2) - 1;
        sums[PAD(b)] += sums[PAD(a)];
      }
      offset <<= 1;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    const T total = sums[PAD(WG - 1)];
    barrier(CLK_LOCAL_MEM_FENCE);  // everyone has read the total before it is cleared
    if (lid == 0) sums[PAD(WG - 1)] = ZERO;
    // Down-sweep: turns the partial sums into the exclusive prefix of each work-item's total.
    for (int n = 1; n < WG; n <<= 1) {
      offset >>= 1;
      barrier(CLK_LOCAL_MEM_FENCE);
      if (lid < n) {
        int a = offset * (2 * lid + 1) - 1, b = offset * (2 * lid + 2) - 1;
        T t = sums[PAD(a)];
        sums[PAD(a)] = sums[PAD(b)];
        sums[PAD(b)] += t;
      }
    }
    barrier(CLK_LOCAL_MEM_FENCE);

    const T prefix = carry + sums[PAD(lid)];
    for (int k = 0; k < VPT; ++k) tile[PAD(lid * VPT + k)] = prefix + v[k];
    barrier(CLK_LOCAL_MEM_FENCE);
    for (int i = 0; i < VPT; ++i) {
      int j = i * WG + lid;
      if (base + j < width) row[base + j] = tile[PAD(j)];
    }
    carry += total;
    // The next tile's loads overwrite tile[] and its step 2 overwrites sums[]: wait until every
    // work-item has finished reading both.
    barrier(CLK_LOCAL_MEM_FENCE);
  }
}

// Column pass, after the row pass. Work-items map to (column, segment of SEG rows, image) with the
// column fastest, so each row step of a work-group reads/writes adjacent addresses (coalesced)
// and no local memory or barriers are needed. Global size (width rounded up to the work-group
// size, nseg, batch); seg_sums holds row (b*nseg + s) for segment s of image b. Work-items past
// the last column return at once. Segment and image come from separate dimensions rather than a
// division of one flat index: that is cheaper, oclgrind 21.10 cannot interpret the `freeze` LLVM
// emits for a div/rem pair, and nseg and batch stay far below the 65535 some GPUs allow there.

//
// COL_LOCKSTEP (a per-device knob, on for CPU devices): PoCL and other CPU runtimes run the
// work-items of a group one after another, so each work-item would walk its whole segment alone,
// a stride-width walk down one column that cannot be vectorized and, for power-of-two widths,
// maps every row to the same cache set. A barrier per row makes the compiler run the group row by
// row instead (the work-item loop moves inside the row loop): contiguous, vectorized row reads.
// Measured on PoCL (2 cores, 2048^2 float4): the rescan step went from ~100 ms to ~15 ms. GPU
// work-items already advance together, where the barrier would only cost, so it is off there.
// The segment length and width are uniform across the group, so every work-item meets the same
// barriers; work-items past the last column stay in the loop without touching memory.
#if COL_LOCKSTEP
#define ROW_STEP() barrier(CLK_LOCAL_MEM_FENCE)  // only the execution barrier matters
#else
#define ROW_STEP()
#endif

// Step 1: the sum of each (column, segment).
kernel void scan_col_segments(global const T* data, global T* seg_sums, int width, int height) {
  const int x = get_global_id(0), s = get_global_id(1);
#if COL_LOCKSTEP
  const bool live = x < width;  // no early return: every work-item must reach the barriers
#else
  if (x >= width) return;
  const bool live = true;
#endif
  const int nseg = get_global_size(1);
  const size_t b = get_global_id(2), sb = b * nseg + s;
  const int y0 = s * SEG, y1 = min(height, y0 + SEG);
  global const T* p = data + (b * height + y0) * (size_t)width + x;
  T acc = ZERO;
  for (int y = y0; y < y1; ++y, p += width) {
    if (live) acc += *p;
    ROW_STEP();
  }
  if (live) seg_sums[sb * width + x] = acc;
}

// Step 2: per (column, image), an exclusive scan over the segment sums, in place. Serial in the
// segment count (height/SEG, small); columns and images run in parallel. Global size (width
// rounded up, batch).
kernel void scan_col_offsets(global A* seg_sums, int width, int nseg) {
  const int x = get_global_id(0), b = get_global_id(1);
  if (x >= width) return;
  global A* p = seg_sums + (size_t)b * nseg * (size_t)width + x;
  A acc = AZERO;
  for (int s = 0; s < nseg; ++s, p += width) {
    A v = *p;
    *p = acc;
    acc += v;
  }
}

// Step 3: each (column, segment) rescans its rows starting from its segment's offset. With a single
// segment (height <= SEG) steps 1 and 2 are skipped and seg_sums is not read.
kernel void scan_col_apply(global T* data, global const T* seg_sums, int width, int height) {
  const int x = get_global_id(0), s = get_global_id(1);
#if COL_LOCKSTEP
  const bool live = x < width;
#else
  if (x >= width) return;
  const bool live = true;
#endif
  const int nseg = get_global_size(1);
  const size_t b = get_global_id(2), sb = b * nseg + s;
  const int y0 = s * SEG, y1 = min(height, y0 + SEG);
  global T* p = data + (b * height + y0) * (size_t)width + x;
  T acc = nseg > 1 && live ? seg_sums[sb * width + x] : ZERO;
  for (int y = y0; y < y1; ++y, p += width) {
    if (live) {
      acc += *p;
      *p = acc;
    }
    ROW_STEP();
  }
}

// ---- Banded one-pass method (CPU devices) ----
//
// The passes above read and write every element twice and read it a third time (rows, column
// segments, column rescan): five image transfers where a copy makes two. On a CPU, where a
// work-item is a thread that may run a long serial loop, the table can instead be built in one
// sweep down the image: row y of the table is the running sum along row y of the input plus row
// y - 1 of the table, which the sweep has just written and finds in cache:
//   S(x, y) = sum_{x' <= x} I(x', y) + S(x, y - 1).
// One work-item per (band of rows, image) sweeps its band. A band below the first needs row
// y0 - 1 of the table, the running sum along x of the column sums of every row above it: step 1
// (scan_band_offsets) sums the columns down the image, leaving each band the sums of the rows
// above it, and step 2 (scan_band_apply) starts its sweep from them. With one band per
// image only step 2 runs, and the image is read and written once: a copy's traffic. With B > 1
// bands the rows above the last band are read once more (src/core/scan.cpp picks B). Integer tables come out identical to the passes' (integer addition
// is associative); float ones round differently (a serial sum along each row, error growing with
// the width rather than with its logarithm), so for float tables the host takes the form below
// that carries the sums in double, and this one only when asked on a device without fp64
// (src/core/scan.cpp).

// Step 1: band_offsets[(image * nbands + band) * width + x] = the sum of column x over every row
// above the band (zero for the first band), in one launch. Global size (strips, batch), one
// work-item per group: work-item s takes the columns [s w / strips, (s + 1) w / strips) of its
// image down to the last band's first row, carrying each column's running sum from one band's row
// of offsets to the next (a row of the strip, which stays in cache). Splitting by columns keeps
// every core busy whatever the band count, and the sums leave as offsets: no scan over the bands.
// Four rows a step, added in row order (the same sums as one row at a time).
kernel void scan_band_offsets(global const T* data, global A* band_offsets, int width,
                              int height, int band_rows) {
  const int strip = get_global_id(0), nstrips = get_global_size(0);
  const size_t img = get_global_id(1);
  const int nbands = (height + band_rows - 1) / band_rows;
  const int x0 = (int)((long)width * strip / nstrips);
  const int x1 = (int)((long)width * (strip + 1) / nstrips);
  global A* run = band_offsets + img * nbands * (size_t)width;
  for (int x = x0; x < x1; ++x) run[x] = AZERO;
  for (int band = 1; band < nbands; ++band) {
    global A* next = run + width;
    for (int x = x0; x < x1; ++x) next[x] = run[x];
    const int y1 = band * band_rows;
    int y = y1 - band_rows;
    global const T* row = data + (img * height + y) * (size_t)width;
    for (; y + 4 <= y1; y += 4, row += 4 * (size_t)width) {
      global const T* r1 = row + width;
      global const T* r2 = r1 + width;
      global const T* r3 = r2 + width;
      for (int x = x0; x < x1; ++x)
        next[x] = next[x] + TO_ACC(row[x]) + TO_ACC(r1[x]) + TO_ACC(r2[x]) + TO_ACC(r3[x]);
    }
    for (; y < y1; ++y, row += width)
      for (int x = x0; x < x1; ++x) next[x] += TO_ACC(row[x]);
    run = next;
  }
}

// Step 2: the sweep over one band, in place. band_offsets as step 1 leaves them: the column sums
// of every row above the band (read only when nbands > 1).
kernel void scan_band_apply(global T* data, global const T* band_offsets, int width, int height,
                            int band_rows) {
  const int band = get_global_id(0), nbands = get_global_size(0);
  const size_t img = get_global_id(1);
  const int y0 = band * band_rows, y1 = min(height, y0 + band_rows);
  if (y0 >= y1) return;
  global T* row = data + (img * height + y0) * (size_t)width;
  // First row: its running sum plus row y0 - 1 of the table (the running sum of the offsets).
  T acc = ZERO;
  if (band > 0) {
    global const T* off = band_offsets + (img * nbands + band) * (size_t)width;
    T above = ZERO;
    for (int x = 0; x < width; ++x) {
      acc += row[x];
      above += off[x];
      row[x] = acc + above;
    }
  } else {
    for (int x = 0; x < width; ++x) {
      acc += row[x];
      row[x] = acc;
    }
  }
  for (int y = y0 + 1; y < y1; ++y) {
    global const T* prev = row;
    row += width;
    acc = ZERO;
    for (int x = 0; x < width; ++x) {
      acc += row[x];
      row[x] = acc + prev[x];
    }
  }
}

// ---- Banded method for float tables, accumulated in double (devices with cl_khr_fp64) ----
//
// The float form of the sweep above adds serially, so its error grows with the width and the band
// (scan.cpp uses it only when asked, on a device without fp64). Here every sum is carried in
// double (SCAN_ACC: double or double4, TO_ACC and FROM_ACC its conversions, set by the host) and
// each table value is rounded to float once: the table is the exact SAT of its inputs to within
// half an ulp of each value plus the double sums' own error (n 2^-53 relative for n inputs),
// tighter than the passes, whose float additions run through up to VPT + SEG + 2 log2 WG levels.
// The sweep keeps row y - 1 of the table in double in a row of scratch per (band, image),
// `carry`, which stays in cache (width values).
// Step 1 is scan_band_offsets above, built with SCAN_ACC: `carry` is its offsets buffer.
#ifdef SCAN_ACC
// ACC_ADD(a, b) is a + b. On x86 CPUs with FMA (the compiler defines __FMA__) it is written as the
// fused multiply-add b * one + a, with `one` = 1.0 passed at run time so that the compiler cannot
// fold it back into an addition. The result is the same bits: b * 1 is exact and the fused
// operation rounds once, as the addition does. What changes is the unit: the sweep's eight
// additions per step then issue on the multiply-add pipes instead of sharing the adder pipes with
// its eight float/double conversions. Measured on PoCL (2-core AMD EPYC, Zen 5, one float4 table,
// medians of 300, device time): 256^2 41 -> 32 us, 1024^2 788 -> 673 us, 2048^2 3.49 -> 2.98 ms.
// Where additions and multiply-adds share ports it should gain nothing (not measured there); the
// bits are the same on any device.
#ifdef __FMA__
#define ACC_ADD(a, b) fma((b), (A)(one), (a))
#else
#define ACC_ADD(a, b) ((a) + (b))
#endif
// Step 3: the sweep. The band's carry row first becomes row y0 - 1 of the table (the running sum
// along x of the column sums above the band; zero for the first band, whose carry is not read
// before), then follows the sweep down: S(x, y) = S(x, y - 1) + sum_{x' <= x} I(x', y).
kernel void scan_band_apply_acc(global T* data, global A* carry, int width, int height,
                                int band_rows, double one) {
  const int band = get_global_id(0), nbands = get_global_size(0);
  const size_t img = get_global_id(1);
  const int y0 = band * band_rows, y1 = min(height, y0 + band_rows);
  if (y0 >= y1) return;
  global A* above = carry + (img * nbands + band) * (size_t)width;
  if (band > 0) {
    A acc = AZERO;
    for (int x = 0; x < width; ++x) {
      acc += above[x];
      above[x] = acc;
    }
  } else {
    for (int x = 0; x < width; ++x) above[x] = AZERO;
  }
  // Four rows at a time: each row's running sum is a chain of dependent additions along x, so
  // four chains interleaved keep the adder busy (one row at a time ran at a fifth of a copy's
  // bandwidth on PoCL, waiting on each addition's latency).
  global T* row = data + (img * height + y0) * (size_t)width;
  int y = y0;
  for (; y + 4 <= y1; y += 4, row += 4 * (size_t)width) {
    global T* r1 = row + width;
    global T* r2 = r1 + width;
    global T* r3 = r2 + width;
    A a0 = AZERO, a1 = AZERO, a2 = AZERO, a3 = AZERO;
    for (int x = 0; x < width; ++x) {
      a0 = ACC_ADD(a0, TO_ACC(row[x]));
      a1 = ACC_ADD(a1, TO_ACC(r1[x]));
      a2 = ACC_ADD(a2, TO_ACC(r2[x]));
      a3 = ACC_ADD(a3, TO_ACC(r3[x]));
      const A s0 = ACC_ADD(above[x], a0), s1 = ACC_ADD(s0, a1), s2 = ACC_ADD(s1, a2),
              s3 = ACC_ADD(s2, a3);
      above[x] = s3;
      row[x] = FROM_ACC(s0);
      r1[x] = FROM_ACC(s1);
      r2[x] = FROM_ACC(s2);
      r3[x] = FROM_ACC(s3);
    }
  }
  for (; y < y1; ++y, row += width) {
    A acc = AZERO;
    for (int x = 0; x < width; ++x) {
      acc = ACC_ADD(acc, TO_ACC(row[x]));
      const A s = ACC_ADD(above[x], acc);
      above[x] = s;
      row[x] = FROM_ACC(s);
    }
  }
}
#endif
