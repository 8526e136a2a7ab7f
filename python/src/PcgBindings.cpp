//===- PcgBindings.cpp - PCG's options and reports for Python -------------===//

#include "PcgBindings.h"

#include "yasps/Runtime/Sparse/Pcg.h"

namespace nb = nanobind;
using ::yasps::runtime::PcgPreconditioner;
using ::yasps::runtime::PcgResult;
using ::yasps::runtime::PcgStop;
using ::yasps::runtime::PcgStopping;

void yasps::python::bindPcg(nb::module_ &m) {
  nb::enum_<PcgStopping>(m, "PcgStopping", "When PCG stops on success.")
      .value("residual", PcgStopping::Residual)
      .value("energy_norm", PcgStopping::EnergyNorm)
      .value("preconditioned", PcgStopping::Preconditioned);
  nb::enum_<PcgPreconditioner>(m, "PcgPreconditioner", "PCG's preconditioner.")
      .value("block_jacobi", PcgPreconditioner::BlockJacobi)
      .value("multilevel", PcgPreconditioner::Multilevel);
  nb::enum_<PcgStop>(m, "PcgStop", "Why PCG stopped.")
      .value("converged", PcgStop::Converged)
      .value("max_iterations", PcgStop::MaxIterations)
      .value("breakdown", PcgStop::Breakdown)
      .value("non_finite", PcgStop::NonFinite)
      .value("round_off", PcgStop::RoundOff);
  nb::class_<PcgResult>(m, "PcgReport", "What one PCG solve did.")
      .def_ro("iterations", &PcgResult::iterations)
      .def_ro("relative_residual", &PcgResult::relativeResidual,
              "||b - H x|| / ||b|| recomputed from the returned x")
      .def_ro("converged", &PcgResult::converged)
      .def_ro("stop", &PcgResult::stop)
      .def_ro("energy_error", &PcgResult::energyError,
              "estimated relative energy-norm error (NaN if not estimated)")
      .def_ro("preconditioned_residual", &PcgResult::preconditionedResidual,
              "sqrt(r^T M^-1 r / b^T M^-1 b) of the last iterate")
      .def_ro("condition_estimate", &PcgResult::conditionEstimate,
              "condition number of M^-1 H from CG's Ritz values (NaN with "
              "fewer than two iterations)")
      .def_ro("diagonal_ratio", &PcgResult::diagonalRatio,
              "max / min diagonal entry of H on the free DoFs: a lower "
              "bound of its condition number")
      .def_ro("residual_replacements", &PcgResult::residualReplacements)
      .def_ro("levels", &PcgResult::levels,
              "The preconditioner's levels (1 for block-Jacobi)");
}
