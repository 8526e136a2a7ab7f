//===- GpuSolverKernels.h - the GPU linear solve's kernel bodies -*- C++ -*-=//
//
// The Newton system on the GPU (paper appendices B-D): assembly of local
// gradients and Hessians into the compressed block-sparse Hessian with
// atomic adds, SpMV specialised per block shape with the in-block row
// reduction of the paper's algorithm 7, block-Jacobi inversion and the
// vector steps of PCG, whose scalars stay on the device.
//
// Each kernel takes one argument struct by value and is written once here,
// as a body templated on a `Block`: one CUDA thread block. nvcc compiles the
// bodies with DeviceBlock (lib/Gpu/SolverKernels.cu); HostBlock runs the
// same bodies on the host, one thread after another, which is how the
// stand-in driver of the tests runs them without a GPU.
//
// Rules that make one body correct in both: a body runs its threads'
// work inside `forEachThread` lambdas, separated by `sync()` (a barrier on
// the GPU); values that pass from one phase to the next go through the
// block's shared memory, never through variables declared outside a
// lambda (which would be per-thread on the GPU but shared on the host).
// Code outside the lambdas only computes values uniform over the block.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_LIB_GPU_GPUSOLVERKERNELS_H
#define YASPS_RUNTIME_LIB_GPU_GPUSOLVERKERNELS_H

#include "yasps/Runtime/Sparse/BlockInverse.h"
#include "yasps/Runtime/Support/HostDevice.h"

namespace yasps::runtime::gpu {

/// Threads per block of every solver kernel (a power of two: reductions
/// halve it).
constexpr int kThreadsPerBlock = 128;
/// Blocks of a reduction launch at most: reductions write one partial sum
/// per block, which a single thread then adds up in order, so results do
/// not depend on timing.
constexpr int kMaxPartials = 1024;
/// The largest block row count of the specialised SpMV kernels' shared
/// memory; other shapes use the generic kernel.
constexpr int kMaxSpecialisedRows = 12;
/// The largest inner size of factored assembly (J^T P J).
constexpr int kMaxInner = 64;

/// The block shapes with specialised (unrolled) SpMV kernels: the DoF
/// group sizes of points in 1-3 dimensions and of affine bodies (12).
#define YASPS_SPMV_SHAPES(X)                                                   \
  X(1, 1)                                                                      \
  X(1, 2)                                                                      \
  X(1, 3)                                                                      \
  X(1, 12)                                                                     \
  X(2, 1)                                                                      \
  X(2, 2) X(2, 3) X(2, 12) X(3, 1) X(3, 2) X(3, 3) X(3, 12) X(12, 1) X(12, 2)  \
      X(12, 3) X(12, 12)

/// Why PCG stopped (PcgState::stopped); 0 while it runs.
enum PcgStop : int {
  kPcgRunning = 0,
  kPcgConverged = 1,
  kPcgMaxIterations = 2,
  kPcgBreakdown = 3,
  kPcgNonFinite = 4,
};

/// The scalars of a PCG solve, kept on the device so that iterations run
/// without waiting for the host. Every PCG kernel returns at once when
/// `stopped` is set, so the host may queue iterations past the end.
/// The stopping rules of PcgState::rule (PcgStopping's, in its order).
enum PcgRule : int {
  kPcgRuleResidual = 0,
  kPcgRuleEnergyNorm = 1,
  kPcgRulePreconditioned = 2,
};

/// The most iterations the energy-norm estimate may look ahead on the GPU
/// (PcgOptions::energyDelay): its terms are kept in a ring of this size.
constexpr int kPcgMaxEnergyDelay = 64;

struct PcgState {
  double tolerance;
  long long maxIterations;
  /// PcgRule; and for kPcgRuleEnergyNorm, the iterations it looks ahead.
  int rule;
  int energyDelay;
  /// r^T M^-1 r at the start: the preconditioned rule's reference.
  double rz0;
  /// alpha_j r_j^T z_j of the last kPcgMaxEnergyDelay iterations (iteration
  /// j at j % kPcgMaxEnergyDelay) and their sum over all iterations.
  double terms[kPcgMaxEnergyDelay];
  double termSum;
  /// What the energy-norm and preconditioned rules compared with the
  /// tolerance at the last check (NaN before they could).
  double energyError, preconditionedResidual;
  double bNorm, threshold, rNorm, rz, alpha, beta;
  /// ||r|| / ||b|| when stopped (NaN for non-finite input or breakdown on
  /// a non-finite p^T H p).
  double residual;
  long long iterations;
  int stopped;
  /// Set by kernels that meet a non-finite input.
  int nonFinite;
};

/// The steps of yasps_pcg_scalar, which runs on one thread.
enum PcgScalarStep : int {
  /// bNorm = sqrt(sum of partials); stop at once for non-finite input or
  /// b = 0.
  kPcgBegin = 0,
  /// Stop for a non-finite residual, convergence or the iteration limit.
  kPcgCheck = 1,
  /// pq = sum; stop on breakdown, else alpha = rz / pq.
  kPcgAlpha = 2,
  /// rNorm = sqrt(sum); one more iteration; stop once converged.
  kPcgAfterUpdate = 3,
  /// rz' = sum; beta = rz' / rz (0 on the first call); rz = rz'.
  kPcgBeta = 4,
};

//===----------------------------------------------------------------------===//
// Argument structs (one per kernel, passed by value)
//===----------------------------------------------------------------------===//

/// Adds `count` instances' local gradients (count x n) and Hessians
/// (count x n x n, row-major) into the global gradient and Hessian values.
/// With `inner` set, the Hessians are factored (paper 7.2): instance i's is
/// J^T P J with J = `hessians` (count x innerSize x n) and P = `inner`
/// (count x innerSize x innerSize); `mapsColumnMajor` says that each J is
/// stored column-major (as the generated kernels write matrices).
struct AssembleArgs {
  long long count, numParams, maxBlocks, innerSize;
  int mapsColumnMajor;
  const double *gradients, *hessians, *inner;
  /// Per instance and parameter: its global DoF, its instance-local block
  /// and offset in it (-1: not a DoF).
  const long long *dofs;
  const int *localBlock, *offset;
  /// Per instance, its local blocks' sizes (count x maxBlocks).
  const int *blockSize;
  /// Per instance and pair of local blocks (a, b): where the stored block
  /// of (a, b) starts in `values`, or -1 where the pair lies in the lower
  /// triangle (its entries come in through (b, a)).
  const long long *pairValue;
  double *gradient, *values;
};

/// y += H x for the stored blocks [0, count) of one shape (rows x cols):
/// block k at scalar coordinates (rowDof[k], colDof[k]) has row-major
/// values values[k * rows * cols ...]. Off-diagonal blocks also add their
/// transpose. `state`, when set, skips the launch once PCG has stopped.
struct SpmvArgs {
  long long count, rows, cols;
  /// 32-bit: an SpMV moves each block's coordinates once, 8 of its
  /// 80 bytes (a 3x3 block) instead of 16 of 88.
  const int *rowDof, *colDof;
  const double *values, *x;
  double *y;
  const PcgState *state;
};

/// Sets `nonFinite` in `state` if one of values[0, n) is NaN or infinite.
struct CheckFiniteArgs {
  long long n;
  const double *values;
  PcgState *state;
};

/// The inverse diagonal blocks of the block-Jacobi preconditioner: block b
/// covers DoFs [blockOffset[b], blockOffset[b + 1]) and its inverse lives
/// at inverse[inverseStart[b] ...]. It inverts the sum of the parts'
/// diagonal blocks: part p's starts at values[p][diagonalValue[p][b]]
/// (-1: the part has none).
struct JacobiInvertArgs {
  long long numBlocks, numParts;
  const long long *blockOffset, *inverseStart;
  const long long *diagonalValue[2];
  const double *values[2];
  const unsigned char *fixed;
  double *inverse;
  /// Scratch: s * s entries per block at inverseStart (a and l), s at
  /// blockOffset (free DoFs).
  double *scratchA, *scratchL;
  long long *scratchFree;
};

/// z = M^-1 r block by block, and the partial sums of r . z.
struct JacobiApplyArgs {
  long long numBlocks;
  const long long *blockOffset, *inverseStart;
  const double *inverse, *r;
  double *z, *partials;
  const PcgState *state;
};

/// Partial sums of a . b; with `fixed`, b's fixed entries are zeroed first
/// (in place).
struct DotArgs {
  long long n;
  const double *a;
  double *b;
  const unsigned char *fixed;
  double *partials;
  const PcgState *state;
};

/// x = 0, r = b with fixed entries zeroed, partial sums of r . r;
/// non-finite entries of r set state->nonFinite.
struct PcgInitArgs {
  long long n;
  const double *b;
  const unsigned char *fixed;
  double *x, *r, *partials;
  PcgState *state;
};

/// x += alpha p, r -= alpha q, partial sums of r . r.
struct PcgUpdateArgs {
  long long n;
  const double *p, *q;
  double *x, *r, *partials;
  const PcgState *state;
};

/// p = z + beta p.
struct PcgDirectionArgs {
  long long n;
  const double *z;
  double *p;
  const PcgState *state;
};

/// One scalar step (PcgScalarStep) over `numPartials` partial sums.
struct PcgScalarArgs {
  int step;
  long long numPartials;
  const double *partials;
  PcgState *state;
};

//===----------------------------------------------------------------------===//
// Blocks
//===----------------------------------------------------------------------===//

/// Shared memory of one block, sized for the kernel that needs most (SpMV:
/// a row segment per thread, and each thread's row and column).
struct SharedMemory {
  double values[kThreadsPerBlock * kMaxSpecialisedRows];
  long long rows[kThreadsPerBlock], cols[kThreadsPerBlock];
};

#if defined(__CUDACC__)
/// The block a CUDA kernel runs in.
struct DeviceBlock {
  SharedMemory *shared;
  __device__ long long index() const { return blockIdx.x; }
  __device__ long long numBlocks() const { return gridDim.x; }
  __device__ int size() const { return blockDim.x; }
  template <typename F> __device__ void forEachThread(F &&f) {
    f(int(threadIdx.x));
  }
  __device__ void sync() { __syncthreads(); }
};
#endif

/// A block run on the host, its threads one after another.
struct HostBlock {
  SharedMemory *shared;
  long long blockIndex = 0, gridSize = 1;
  int blockSize = kThreadsPerBlock;
  long long index() const { return blockIndex; }
  long long numBlocks() const { return gridSize; }
  int size() const { return blockSize; }
  template <typename F> void forEachThread(F &&f) {
    for (int t = 0; t < blockSize; ++t)
      f(t);
  }
  void sync() {}
};

//===----------------------------------------------------------------------===//
// Bodies
//===----------------------------------------------------------------------===//

/// Sums shared->values[0, size) into partials[block index] (a tree in
/// shared memory; every thread has written its value).
template <typename Block>
YASPS_HD void blockSumToPartial(Block &block, double *partials) {
  double *v = block.shared->values;
  for (int width = block.size() / 2; width > 0; width /= 2) {
    block.sync();
    block.forEachThread([&](int t) {
      if (t < width)
        v[t] += v[t + width];
    });
  }
  block.forEachThread([&](int t) {
    if (t == 0)
      partials[block.index()] = v[0];
  });
}

/// Element i of a grid-stride loop: thread t's elements are t, t + stride...
template <typename Block> YASPS_HD long long firstElement(Block &block, int t) {
  return block.index() * block.size() + t;
}
template <typename Block> YASPS_HD long long gridStride(Block &block) {
  return block.numBlocks() * block.size();
}

template <typename Block>
YASPS_HD void assembleBody(Block &block, const AssembleArgs &args) {
  block.forEachThread([&](int t) {
    long long i = firstElement(block, t);
    if (i >= args.count)
      return;
    const long long n = args.numParams, m = args.maxBlocks;
    const double *g = args.gradients + i * n;
    const long long *dofs = args.dofs + i * n;
    const int *local = args.localBlock + i * n;
    const int *offset = args.offset + i * n;
    const int *size = args.blockSize + i * m;
    const long long *pair = args.pairValue + i * m * m;
    for (long long a = 0; a < n; ++a)
      if (local[a] >= 0)
        atomicAddDouble(&args.gradient[dofs[a]], g[a]);
    const long long k = args.innerSize;
    const double *j = args.hessians + i * (args.inner ? k * n : n * n);
    // Entry (r, c) of J is j[r * rs + c * cs].
    const long long rs = args.mapsColumnMajor ? 1 : n;
    const long long cs = args.mapsColumnMajor ? k : 1;
    const double *p = args.inner ? args.inner + i * k * k : nullptr;
    for (long long b = 0; b < n; ++b) {
      if (local[b] < 0)
        continue;
      // Column b of the Hessian: h[a] = H[a][b], read from the dense
      // Hessian or formed as J^T (P J[:, b]).
      double pj[kMaxInner];
      if (p)
        for (long long r = 0; r < k; ++r) {
          double sum = 0.0;
          for (long long c = 0; c < k; ++c)
            sum += p[r * k + c] * j[c * rs + b * cs];
          pj[r] = sum;
        }
      for (long long a = 0; a < n; ++a) {
        if (local[a] < 0)
          continue;
        long long start = pair[local[a] * m + local[b]];
        if (start < 0)
          continue;
        double h;
        if (p) {
          h = 0.0;
          for (long long r = 0; r < k; ++r)
            h += j[r * rs + a * cs] * pj[r];
        } else {
          h = j[a * n + b];
        }
        atomicAddDouble(
            &args.values[start + offset[a] * size[local[b]] + offset[b]], h);
      }
    }
  });
}

/// SpMV over one shape's blocks, one block per thread (the paper's
/// algorithm 7). The products of a CUDA block's blocks are first summed
/// per row segment in shared memory: blocks are sorted by row, so runs of
/// threads share a row and one atomic add per entry and run suffices.
/// Rows and Cols are the shape when known at compile time (unrolled
/// products), 0 for the generic kernel (which adds every product
/// atomically).
template <int Rows, int Cols, typename Block>
YASPS_HD void spmvBody(Block &block, const SpmvArgs &args) {
  if (args.state && args.state->stopped)
    return;
  const long long rows = Rows ? Rows : args.rows;
  const long long cols = Cols ? Cols : args.cols;
  SharedMemory &shared = *block.shared;
  block.forEachThread([&](int t) {
    long long k = firstElement(block, t);
    if (k >= args.count) {
      shared.rows[t] = -1;
      return;
    }
    long long row = args.rowDof[k], col = args.colDof[k];
    const double *values = args.values + k * rows * cols;
    shared.rows[t] = row;
    shared.cols[t] = col;
    for (long long r = 0; r < rows; ++r) {
      double sum = 0.0;
      for (long long c = 0; c < cols; ++c)
        sum += values[r * cols + c] * args.x[col + c];
      if (Rows)
        shared.values[t * Rows + r] = sum;
      else
        atomicAddDouble(&args.y[row + r], sum);
    }
  });
  block.sync();
  block.forEachThread([&](int t) {
    long long row = shared.rows[t];
    if (row < 0)
      return;
    if (Rows && (t == 0 || shared.rows[t - 1] != row)) {
      // The head of a run of threads on one row adds up the run.
      double sum[Rows ? Rows : 1];
      for (int r = 0; r < Rows; ++r)
        sum[r] = 0.0;
      for (int s = t; s < block.size() && shared.rows[s] == row; ++s)
        for (int r = 0; r < Rows; ++r)
          sum[r] += shared.values[s * Rows + r];
      for (int r = 0; r < Rows; ++r)
        atomicAddDouble(&args.y[row + r], sum[r]);
    }
    long long col = shared.cols[t];
    if (col == row)
      return;
    // The stored upper block B at (row, col) also stands for B^T at
    // (col, row).
    const double *values = args.values + firstElement(block, t) * rows * cols;
    for (long long c = 0; c < cols; ++c) {
      double sum = 0.0;
      for (long long r = 0; r < rows; ++r)
        sum += values[r * cols + c] * args.x[row + r];
      atomicAddDouble(&args.y[col + c], sum);
    }
  });
}

template <typename Block>
YASPS_HD void checkFiniteBody(Block &block, const CheckFiniteArgs &args) {
  block.forEachThread([&](int t) {
    for (long long i = firstElement(block, t); i < args.n;
         i += gridStride(block))
      if (!hdIsFinite(args.values[i])) {
        args.state->nonFinite = 1;
        return;
      }
  });
}

template <typename Block>
YASPS_HD void jacobiInvertBody(Block &block, const JacobiInvertArgs &args) {
  block.forEachThread([&](int t) {
    long long b = firstElement(block, t);
    if (b >= args.numBlocks)
      return;
    long long o = args.blockOffset[b], s = args.blockOffset[b + 1] - o;
    long long start = args.inverseStart[b];
    double *inverse = args.inverse + start;
    for (long long e = 0; e < s * s; ++e)
      inverse[e] = 0.0;
    for (long long part = 0; part < args.numParts; ++part) {
      long long diagonal = args.diagonalValue[part][b];
      if (diagonal >= 0)
        for (long long e = 0; e < s * s; ++e)
          inverse[e] += args.values[part][diagonal + e];
    }
    invertDiagonalBlock(s, inverse, args.fixed ? args.fixed + o : nullptr,
                        args.scratchFree + o, args.scratchA + start,
                        args.scratchL + start);
  });
}

/// Runs `element(i)` for i in [0, n) over the grid (each thread strides by
/// the grid's size) and writes each block's sum of the results to
/// partials[block index].
template <typename Block, typename Element>
YASPS_HD void sumOverGrid(Block &block, long long n, double *partials,
                          Element &&element) {
  block.forEachThread([&](int t) {
    double sum = 0.0;
    for (long long i = firstElement(block, t); i < n; i += gridStride(block))
      sum += element(i);
    block.shared->values[t] = sum;
  });
  blockSumToPartial(block, partials);
}

template <typename Block>
YASPS_HD void jacobiApplyBody(Block &block, const JacobiApplyArgs &args) {
  if (args.state->stopped)
    return;
  sumOverGrid(block, args.numBlocks, args.partials, [&](long long b) {
    long long o = args.blockOffset[b], s = args.blockOffset[b + 1] - o;
    const double *inverse = args.inverse + args.inverseStart[b];
    double rz = 0.0;
    for (long long i = 0; i < s; ++i) {
      double sum = 0.0;
      for (long long j = 0; j < s; ++j)
        sum += inverse[i * s + j] * args.r[o + j];
      args.z[o + i] = sum;
      rz += args.r[o + i] * sum;
    }
    return rz;
  });
}

template <typename Block>
YASPS_HD void dotBody(Block &block, const DotArgs &args) {
  if (args.state && args.state->stopped)
    return;
  sumOverGrid(block, args.n, args.partials, [&](long long i) {
    if (args.fixed && args.fixed[i])
      args.b[i] = 0.0;
    return args.a[i] * args.b[i];
  });
}

template <typename Block>
YASPS_HD void pcgInitBody(Block &block, const PcgInitArgs &args) {
  sumOverGrid(block, args.n, args.partials, [&](long long i) {
    double r = args.fixed && args.fixed[i] ? 0.0 : args.b[i];
    if (!hdIsFinite(r))
      args.state->nonFinite = 1;
    args.x[i] = 0.0;
    args.r[i] = r;
    return r * r;
  });
}

template <typename Block>
YASPS_HD void pcgUpdateBody(Block &block, const PcgUpdateArgs &args) {
  if (args.state->stopped)
    return;
  const double alpha = args.state->alpha;
  sumOverGrid(block, args.n, args.partials, [&](long long i) {
    args.x[i] += alpha * args.p[i];
    double r = args.r[i] - alpha * args.q[i];
    args.r[i] = r;
    return r * r;
  });
}

template <typename Block>
YASPS_HD void pcgDirectionBody(Block &block, const PcgDirectionArgs &args) {
  if (args.state->stopped)
    return;
  const double beta = args.state->beta;
  block.forEachThread([&](int t) {
    for (long long i = firstElement(block, t); i < args.n;
         i += gridStride(block))
      args.p[i] = args.z[i] + beta * args.p[i];
  });
}

/// Stops PCG with `why`; the residual is ||r|| / ||b|| or `residual`.
YASPS_HD inline void pcgStop(PcgState &state, int why, double residual) {
  state.stopped = why;
  state.residual = residual;
}

/// Whether the stopping rule's tolerance is met now, as the CPU's PCG
/// judges it (Pcg.cpp): the updated residual, the energy-norm estimate
/// over energyDelay iterations, or r^T M^-1 r against its start.
YASPS_HD inline bool pcgToleranceMet(PcgState &state) {
  if (state.rz0 > 0.0)
    state.preconditionedResidual =
        hdSqrt((state.rz > 0.0 ? state.rz : 0.0) / state.rz0);
  switch (state.rule) {
  case kPcgRuleEnergyNorm: {
    const long long d = state.energyDelay, k = state.iterations;
    if (k < d)
      return false;
    double ahead = 0.0;
    for (long long j = k - d; j < k; ++j)
      ahead += state.terms[j % kPcgMaxEnergyDelay];
    const double sum = state.termSum > 1e-300 ? state.termSum : 1e-300;
    state.energyError = hdSqrt(ahead / sum);
    return state.energyError <= state.tolerance;
  }
  case kPcgRulePreconditioned:
    return state.preconditionedResidual <= state.tolerance;
  default:
    return state.rNorm <= state.threshold;
  }
}

template <typename Block>
YASPS_HD void pcgScalarBody(Block &block, const PcgScalarArgs &args) {
  block.forEachThread([&](int t) {
    if (t != 0 || block.index() != 0)
      return;
    PcgState &state = *args.state;
    if (state.stopped)
      return;
    double sum = 0.0;
    for (long long i = 0; i < args.numPartials; ++i)
      sum += args.partials[i];
    const double nan = hdNaN();
    switch (args.step) {
    case kPcgBegin:
      state.iterations = 0;
      state.rz = state.rz0 = state.termSum = 0.0;
      state.energyError = state.preconditionedResidual = nan;
      if (state.nonFinite)
        return pcgStop(state, kPcgNonFinite, nan);
      state.bNorm = state.rNorm = hdSqrt(sum);
      if (state.bNorm == 0.0)
        return pcgStop(state, kPcgConverged, 0.0);
      state.threshold = state.tolerance * state.bNorm;
      return;
    case kPcgCheck:
      if (!hdIsFinite(state.rNorm))
        return pcgStop(state, kPcgNonFinite, nan);
      if (pcgToleranceMet(state))
        return pcgStop(state, kPcgConverged, state.rNorm / state.bNorm);
      if (state.iterations == state.maxIterations)
        return pcgStop(state, kPcgMaxIterations, state.rNorm / state.bNorm);
      return;
    case kPcgAlpha:
      // H is not positive definite along p (or rz vanished): CG cannot go
      // on.
      if (!(sum > 0.0) || !hdIsFinite(sum) || !(state.rz > 0.0))
        return pcgStop(state, kPcgBreakdown,
                       hdIsFinite(sum) ? state.rNorm / state.bNorm : nan);
      state.alpha = state.rz / sum;
      return;
    case kPcgAfterUpdate: {
      // The energy-norm estimate's term of this iteration, alpha r^T z
      // (rz is still this iteration's).
      const double term = state.alpha * state.rz;
      state.terms[state.iterations % kPcgMaxEnergyDelay] = term;
      state.termSum += term;
      ++state.iterations;
      state.rNorm = hdSqrt(sum);
      // The other rules are judged at the next check, on the next r^T z.
      if (state.rule == kPcgRuleResidual && state.rNorm <= state.threshold)
        pcgStop(state, kPcgConverged, state.rNorm / state.bNorm);
      return;
    }
    case kPcgBeta:
      state.beta = state.rz == 0.0 ? 0.0 : sum / state.rz;
      state.rz = sum;
      if (state.rz0 == 0.0)
        state.rz0 = sum;
      return;
    }
  });
}

} // namespace yasps::runtime::gpu

#endif // YASPS_RUNTIME_LIB_GPU_GPUSOLVERKERNELS_H
