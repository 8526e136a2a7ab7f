//===- SolverKernels.cu - the GPU linear solve's kernels ------------------===//
//
// The kernels of the GPU Newton system: thin wrappers that give the bodies
// of GpuSolverKernels.h their thread block. Hand-written CUDA (not
// generated): they do not depend on the scene's energies, only on the block
// shapes, which are enumerated by YASPS_SPMV_SHAPES. Built by nvcc into one
// fatbin (cubins for sm_80 and sm_90, PTX for newer chips) that the runtime
// embeds.
//
//===----------------------------------------------------------------------===//

#include "GpuMultilevelKernels.h"

using namespace yasps::runtime::gpu;

#define YASPS_SOLVER_KERNEL(NAME, ARGS, BODY)                                  \
  extern "C" __global__ void __launch_bounds__(kThreadsPerBlock)               \
      NAME(ARGS args) {                                                        \
    __shared__ SharedMemory shared;                                            \
    DeviceBlock block{&shared};                                                \
    BODY(block, args);                                                         \
  }

YASPS_SOLVER_KERNEL(yasps_assemble, AssembleArgs, assembleBody)
YASPS_SOLVER_KERNEL(yasps_check_finite, CheckFiniteArgs, checkFiniteBody)
YASPS_SOLVER_KERNEL(yasps_jacobi_invert, JacobiInvertArgs, jacobiInvertBody)
YASPS_SOLVER_KERNEL(yasps_jacobi_apply, JacobiApplyArgs, jacobiApplyBody)
YASPS_SOLVER_KERNEL(yasps_dot, DotArgs, dotBody)
YASPS_SOLVER_KERNEL(yasps_pcg_init, PcgInitArgs, pcgInitBody)
YASPS_SOLVER_KERNEL(yasps_pcg_update, PcgUpdateArgs, pcgUpdateBody)
YASPS_SOLVER_KERNEL(yasps_pcg_direction, PcgDirectionArgs, pcgDirectionBody)
YASPS_SOLVER_KERNEL(yasps_pcg_scalar, PcgScalarArgs, pcgScalarBody)
YASPS_SOLVER_KERNEL(yasps_spmv_any, SpmvArgs, (spmvBody<0, 0>))
YASPS_SOLVER_KERNEL(yasps_ml_coarsen, CoarsenArgs, coarsenBody)
YASPS_SOLVER_KERNEL(yasps_ml_restrict, TransferArgs, restrictBody)
YASPS_SOLVER_KERNEL(yasps_ml_prolong, TransferArgs, prolongBody)
YASPS_SOLVER_KERNEL(yasps_ml_smooth, SmoothArgs, smoothBody)
YASPS_SOLVER_KERNEL(yasps_ml_residual, ResidualArgs, residualBody)
YASPS_SOLVER_KERNEL(yasps_ml_dense_scatter, DenseScatterArgs, denseScatterBody)
YASPS_SOLVER_KERNEL(yasps_ml_row_bound, RowBoundArgs, rowBoundBody)
YASPS_SOLVER_KERNEL(yasps_ml_dense_invert, DenseInvertArgs, denseInvertBody)
YASPS_SOLVER_KERNEL(yasps_ml_dense_apply, DenseApplyArgs, denseApplyBody)

#define YASPS_SPMV_KERNEL(R, C)                                                \
  YASPS_SOLVER_KERNEL(yasps_spmv_##R##x##C, SpmvArgs, (spmvBody<R, C>))
YASPS_SPMV_SHAPES(YASPS_SPMV_KERNEL)
