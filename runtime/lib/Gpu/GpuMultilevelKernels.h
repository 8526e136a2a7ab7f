//===- GpuMultilevelKernels.h - the GPU V-cycle's kernel bodies -*- C++ -*-===//
//
// The multilevel preconditioner (Multilevel.h) on the device: the bodies of
// the kernels that compute the coarse levels' values, move vectors between
// levels, smooth, and solve the coarsest level. The levels' structure comes
// from the host's Multilevel; SpMV, block-Jacobi inversion and the dot
// products are the PCG kernels' (GpuSolverKernels.h), whose rules these
// bodies follow.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_LIB_GPU_GPUMULTILEVELKERNELS_H
#define YASPS_RUNTIME_LIB_GPU_GPUMULTILEVELKERNELS_H

#include "GpuSolverKernels.h"

namespace yasps::runtime::gpu {

/// Adds `count` fine stored blocks into the coarse level's values: block k
/// (rows[k] x cols[k], row-major at fineValue[k], at scalar coordinates
/// (rowDof[k], colDof[k])) with entries at fixed DoFs masked, lands at
/// coarseValue[k], transposed where bit 0 of flags[k] is set, and a second
/// time with that bit flipped where bit 1 is (a block between two members
/// of one aggregate).
struct CoarsenArgs {
  long long count;
  const long long *fineValue, *coarseValue, *rowDof, *colDof;
  const int *rows, *cols, *flags;
  const double *fine;
  const unsigned char *fixed;
  double *coarse;
};

/// Between a level and the next coarser one: aggregate a has `size[a]`
/// DoFs from coarseDof[a] and members whose first DoFs are
/// memberDof[memberStart[a] .. memberStart[a + 1]). Restriction sums the
/// members' entries of `fine` into `coarse`; prolongation adds the
/// aggregate's entries of `coarse` to its members' entries of `fine`
/// (leaving fixed DoFs).
struct TransferArgs {
  long long numAggregates;
  const long long *coarseDof, *memberStart, *memberDof;
  const int *size;
  const unsigned char *fixed;
  double *fine, *coarse;
  const PcgState *state;
};

/// out = damping * D^-1 in, or out += that with `accumulate`, block by
/// block (the inverse blocks as in JacobiApplyArgs).
struct SmoothArgs {
  long long numBlocks;
  const long long *blockOffset, *inverseStart;
  const double *inverse, *in;
  double *out;
  double damping;
  int accumulate;
  const PcgState *state;
};

/// t = r - t over n entries (t holding a product), 0 at fixed DoFs.
struct ResidualArgs {
  long long n;
  const double *r;
  double *t;
  const unsigned char *fixed;
  const PcgState *state;
};

/// Adds the stored blocks [0, count) of one shape (as in SpmvArgs) into
/// the dense n x n `dense` (row-major), both triangles, leaving entries at
/// fixed DoFs out.
struct DenseScatterArgs {
  long long count, rows, cols;
  const int *rowDof, *colDof;
  const double *values;
  const unsigned char *fixed;
  long long n;
  double *dense;
};

/// Adds to rowSums, for the stored blocks [0, count) of one shape (as in
/// DenseScatterArgs), the row sums of |D^-1 B| over the rows of a block's
/// row, and of |D^-1 B^T| over those of its column (off the diagonal):
/// D^-1 the block-Jacobi inverse of the rows' block (dofBlock maps a DoF
/// to its block), entries at fixed DoFs left out. Their largest total
/// bounds lmax(D^-1 A), as BlockJacobi::eigenvalueBound on the CPU.
struct RowBoundArgs {
  long long count, rows, cols;
  const int *rowDof, *colDof;
  const double *values;
  const long long *dofBlock, *inverseStart;
  const double *inverse;
  const unsigned char *fixed;
  double *rowSums;
};

/// Inverts the n x n symmetric positive definite `a` (row-major) in place,
/// in one CUDA block: Gauss-Jordan without pivoting. A zero row (the DoFs
/// of fixed aggregates) is taken as the identity's; a pivot that is not
/// positive sets *failed.
struct DenseInvertArgs {
  long long n;
  double *a;
  int *failed;
};

/// z = a r for the n x n `a`, one row per thread.
struct DenseApplyArgs {
  long long n;
  const double *a, *r;
  double *z;
  const PcgState *state;
};

template <typename Block>
YASPS_HD void coarsenBody(Block &block, const CoarsenArgs &args) {
  block.forEachThread([&](int t) {
    long long k = firstElement(block, t);
    if (k >= args.count)
      return;
    const long long rows = args.rows[k], cols = args.cols[k];
    const long long rowDof = args.rowDof[k], colDof = args.colDof[k];
    const double *fine = args.fine + args.fineValue[k];
    double *coarse = args.coarse + args.coarseValue[k];
    for (int copy = 0; copy < 2; ++copy) {
      int flags = args.flags[k];
      if (copy == 1 && !(flags & 2))
        break;
      bool transposed = ((flags & 1) != 0) != (copy == 1);
      for (long long r = 0; r < rows; ++r)
        for (long long c = 0; c < cols; ++c) {
          if (args.fixed && (args.fixed[rowDof + r] || args.fixed[colDof + c]))
            continue;
          double v = fine[r * cols + c];
          atomicAddDouble(
              transposed ? &coarse[c * rows + r] : &coarse[r * cols + c], v);
        }
    }
  });
}

template <typename Block>
YASPS_HD void restrictBody(Block &block, const TransferArgs &args) {
  if (args.state && args.state->stopped)
    return;
  block.forEachThread([&](int t) {
    for (long long a = firstElement(block, t); a < args.numAggregates;
         a += gridStride(block)) {
      const long long o = args.coarseDof[a], s = args.size[a];
      for (long long k = 0; k < s; ++k) {
        double sum = 0.0;
        for (long long m = args.memberStart[a]; m < args.memberStart[a + 1];
             ++m)
          sum += args.fine[args.memberDof[m] + k];
        args.coarse[o + k] = sum;
      }
    }
  });
}

template <typename Block>
YASPS_HD void prolongBody(Block &block, const TransferArgs &args) {
  if (args.state && args.state->stopped)
    return;
  block.forEachThread([&](int t) {
    for (long long a = firstElement(block, t); a < args.numAggregates;
         a += gridStride(block)) {
      const long long o = args.coarseDof[a], s = args.size[a];
      for (long long m = args.memberStart[a]; m < args.memberStart[a + 1];
           ++m) {
        const long long f = args.memberDof[m];
        for (long long k = 0; k < s; ++k)
          if (!args.fixed || !args.fixed[f + k])
            args.fine[f + k] += args.coarse[o + k];
      }
    }
  });
}

template <typename Block>
YASPS_HD void smoothBody(Block &block, const SmoothArgs &args) {
  if (args.state && args.state->stopped)
    return;
  block.forEachThread([&](int t) {
    for (long long b = firstElement(block, t); b < args.numBlocks;
         b += gridStride(block)) {
      const long long o = args.blockOffset[b], s = args.blockOffset[b + 1] - o;
      const double *inverse = args.inverse + args.inverseStart[b];
      for (long long i = 0; i < s; ++i) {
        double sum = 0.0;
        for (long long j = 0; j < s; ++j)
          sum += inverse[i * s + j] * args.in[o + j];
        double v = args.damping * sum;
        args.out[o + i] = args.accumulate ? args.out[o + i] + v : v;
      }
    }
  });
}

template <typename Block>
YASPS_HD void residualBody(Block &block, const ResidualArgs &args) {
  if (args.state && args.state->stopped)
    return;
  block.forEachThread([&](int t) {
    for (long long i = firstElement(block, t); i < args.n;
         i += gridStride(block))
      args.t[i] = args.fixed && args.fixed[i] ? 0.0 : args.r[i] - args.t[i];
  });
}

template <typename Block>
YASPS_HD void denseScatterBody(Block &block, const DenseScatterArgs &args) {
  block.forEachThread([&](int t) {
    long long k = firstElement(block, t);
    if (k >= args.count)
      return;
    const long long row = args.rowDof[k], col = args.colDof[k];
    const double *values = args.values + k * args.rows * args.cols;
    for (long long r = 0; r < args.rows; ++r)
      for (long long c = 0; c < args.cols; ++c) {
        if (args.fixed && (args.fixed[row + r] || args.fixed[col + c]))
          continue;
        double v = values[r * args.cols + c];
        atomicAddDouble(&args.dense[(row + r) * args.n + col + c], v);
        if (row != col)
          atomicAddDouble(&args.dense[(col + c) * args.n + row + r], v);
      }
  });
}

template <typename Block>
YASPS_HD void rowBoundBody(Block &block, const RowBoundArgs &args) {
  block.forEachThread([&](int t) {
    long long k = firstElement(block, t);
    if (k >= args.count)
      return;
    const long long row = args.rowDof[k], col = args.colDof[k];
    const double *values = args.values + k * args.rows * args.cols;
    for (int side = 0; side < 2 && (side == 0 || row != col); ++side) {
      const bool transposed = side == 1;
      const long long first = transposed ? col : row;
      const long long other = transposed ? row : col;
      const long long n = transposed ? args.cols : args.rows;
      const long long m = transposed ? args.rows : args.cols;
      const double *inv =
          args.inverse + args.inverseStart[args.dofBlock[first]];
      for (long long i = 0; i < n; ++i) {
        if (args.fixed && args.fixed[first + i])
          continue;
        double sum = 0.0;
        for (long long j = 0; j < m; ++j) {
          if (args.fixed && args.fixed[other + j])
            continue;
          double v = 0.0;
          for (long long q = 0; q < n; ++q)
            v += inv[i * n + q] * (transposed ? values[j * args.cols + q]
                                              : values[q * args.cols + j]);
          sum += v < 0.0 ? -v : v;
        }
        atomicAddDouble(&args.rowSums[first + i], sum);
      }
    }
  });
}

template <typename Block>
YASPS_HD void denseInvertBody(Block &block, const DenseInvertArgs &args) {
  const long long n = args.n;
  double *a = args.a;
  // Zero rows become the identity's (the matrix is symmetric: so do their
  // columns).
  block.forEachThread([&](int t) {
    for (long long i = t; i < n; i += block.size()) {
      bool zero = true;
      for (long long j = 0; j < n && zero; ++j)
        zero = a[i * n + j] == 0.0;
      if (zero)
        a[i * n + i] = 1.0;
    }
  });
  for (long long k = 0; k < n; ++k) {
    block.sync();
    // The pivot, read before its row changes, through shared memory.
    block.forEachThread([&](int t) {
      if (t == 0) {
        double pivot = a[k * n + k];
        if (!(pivot > 0.0) || !hdIsFinite(pivot)) {
          *args.failed = 1;
          pivot = 1.0;
        }
        block.shared->values[0] = pivot;
      }
    });
    block.sync();
    block.forEachThread([&](int t) {
      const double pivot = block.shared->values[0];
      for (long long j = t; j < n; j += block.size())
        a[k * n + j] = (j == k ? 1.0 : a[k * n + j]) / pivot;
    });
    block.sync();
    block.forEachThread([&](int t) {
      for (long long i = t; i < n; i += block.size()) {
        if (i == k)
          continue;
        const double f = a[i * n + k];
        a[i * n + k] = 0.0;
        for (long long j = 0; j < n; ++j)
          a[i * n + j] -= f * a[k * n + j];
      }
    });
  }
}

template <typename Block>
YASPS_HD void denseApplyBody(Block &block, const DenseApplyArgs &args) {
  if (args.state && args.state->stopped)
    return;
  block.forEachThread([&](int t) {
    for (long long i = firstElement(block, t); i < args.n;
         i += gridStride(block)) {
      double sum = 0.0;
      for (long long j = 0; j < args.n; ++j)
        sum += args.a[i * args.n + j] * args.r[j];
      args.z[i] = sum;
    }
  });
}

} // namespace yasps::runtime::gpu

#endif // YASPS_RUNTIME_LIB_GPU_GPUMULTILEVELKERNELS_H
