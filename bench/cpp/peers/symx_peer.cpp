// SymX on the work of bench/cpu_peers.py (see peer_common.h), one thread.
//
//   symx_peer INPUT_DIR OUTPUT_DIR CODEGEN_DIR [COMPILER]
//
// COMPILER (default: SymX's own choice) is the command SymX runs to compile
// the code it generates, e.g. "flock /tmp/lock g++".
//
// Per tet: SymX's CompiledInLoop over the tets of energy, gradient and
// Hessian (value_gradient_hessian, the kernel its Newton solver evaluates,
// in scalar double as there) into per-tet buffers, and the same with SymX's
// project_to_PD_inplace of the 12x12 Hessian (eigenvalues clamped at 0). Newton
// direction: SymX's second order path as NewtonsMethod runs it
// (SecondOrderCompiledGlobal's evaluation of elastic + inertia, ProjectedNewton
// projection of every element Hessian, block-sparse assembly, block-diagonal
// PCG), with PCG's relative tolerance `tolerance` and no absolute one
// (NewtonsMethod adds a forcing-sequence absolute tolerance, left out here so
// that every tool stops at the same relative residual).
#include "peer_common.h"

#include <symx>

#include <BlockedSparseMatrix/solve_pcg.h>

namespace {

using namespace symx;

/// Everything SymX's symbols are mapped to; kept alive and in place.
struct Data {
  std::vector<std::array<int32_t, 5>> tets; // tet index, v0..v3
  std::vector<std::array<int32_t, 1>> verts;
  std::vector<Eigen::Vector3d> x, x_hat;
  std::vector<std::array<double, 9>> inv; // row-major
  std::vector<double> vol;
  double dt2 = 0, mu = 0, lambda = 0, alpha = 0, mass = 0;
};

/// dt2 * vol * stable Neo-Hookean density (yasps.energies' formula) of the
/// tet with corners x (symbols of d.x: SymX differentiates with respect to
/// these very symbols; making them again would make new ones).
Scalar elastic(MappedWorkspace<double> &mws, Element &elem, Data &d,
               const std::vector<Vector> &x) {
  Matrix inv = mws.make_matrix(d.inv, {3, 3}, elem[0]);
  Scalar vol = mws.make_scalar(d.vol, elem[0]);
  Scalar dt2 = mws.make_scalar(d.dt2);
  Scalar mu = mws.make_scalar(d.mu);
  Scalar lambda = mws.make_scalar(d.lambda);
  Scalar alpha = mws.make_scalar(d.alpha);
  // Rows x_k - x_0, transposed: the columns of Ds.
  Matrix ds =
      Matrix(collect_scalars({x[1] - x[0], x[2] - x[0], x[3] - x[0]}), {3, 3})
          .transpose();
  Matrix F = ds * inv;
  Scalar ic = F.frobenius_norm_sq();
  Scalar j = F.det();
  Scalar psi = 0.5 * mu * (ic - 3.0) - 0.5 * mu * log(ic + 1.0) +
               0.5 * lambda * (j - alpha) * (j - alpha);
  return dt2 * vol * psi;
}

Scalar inertia(MappedWorkspace<double> &mws, Element &elem, Data &d) {
  Vector x = mws.make_vector(d.x, elem[0]);
  Vector x_hat = mws.make_vector(d.x_hat, elem[0]);
  Scalar mass = mws.make_scalar(d.mass);
  return 0.5 * mass * (x - x_hat).squared_norm();
}

/// Per-tet gradient and Hessian buffers filled by a CompiledInLoop's run.
template <typename Loop>
void per_tet(Loop &loop, bool project, std::vector<double> &g,
             std::vector<double> &h) {
  loop.run(1, [&](View<double> out, int32_t elem, int32_t, View<int32_t>) {
    double *gt = g.data() + 12 * size_t(elem);
    double *ht = h.data() + 144 * size_t(elem);
    for (int i = 0; i < 12; ++i)
      gt[i] = out[1 + i];
    for (int i = 0; i < 144; ++i)
      ht[i] = out[13 + i];
    if (project)
      project_to_PD_inplace(ht, 12, 0.0, false);
  });
}

} // namespace

int main(int argc, char **argv) {
  if (argc != 4 && argc != 5) {
    std::cerr << "usage: symx_peer INPUT_DIR OUTPUT_DIR CODEGEN_DIR "
                 "[COMPILER]\n";
    return 2;
  }
  const peers::Work w = peers::read_work(argv[1]);
  const std::string out = argv[2], codegen = argv[3];
  if (argc == 5)
    set_compiler_path(argv[4]);

  Data d;
  d.dt2 = w.dt2, d.mu = w.mu, d.lambda = w.lambda, d.alpha = w.alpha();
  d.mass = w.mass;
  for (int v = 0; v < w.n_verts; ++v) {
    d.x.emplace_back(w.x[3 * v], w.x[3 * v + 1], w.x[3 * v + 2]);
    d.x_hat.emplace_back(w.x_hat[3 * v], w.x_hat[3 * v + 1],
                         w.x_hat[3 * v + 2]);
    d.verts.push_back({v});
  }
  for (int t = 0; t < w.n_tets; ++t) {
    const int32_t *v = w.tets.data() + 4 * size_t(t);
    d.tets.push_back({t, v[0], v[1], v[2], v[3]});
    std::array<double, 9> inv;
    std::copy(w.inv.begin() + 9 * t, w.inv.begin() + 9 * t + 9, inv.begin());
    d.inv.push_back(inv);
    d.vol.push_back(w.vol[t]);
  }

  // Per tet: the elastic energy's kernel over the tets.
  auto [mws, element] = MappedWorkspace<double>::create(d.tets);
  std::vector<Vector> corners = mws->make_vectors(d.x, element.slice(1, 5));
  Scalar energy = elastic(*mws, element, d, corners);
  std::vector<Scalar> dofs = collect_scalars(corners);
  std::vector<Scalar> values = value_gradient_hessian(energy, dofs);
  const std::string checksum = mws->get_workspace().get_checksum();
  double t0 = peers::now();
  auto loop = CompiledInLoop<double>::create(mws, values, "yasps_peer_snh",
                                             codegen, checksum);
  peers::report("compile_per_tet_s", peers::now() - t0);

  std::vector<double> g(12 * size_t(w.n_tets)), h(144 * size_t(w.n_tets));
  per_tet(*loop, false, g, h);
  peers::write_array(out + "/grad.bin", g.data(), 12 * size_t(w.check));
  peers::write_array(out + "/hess.bin", h.data(), 144 * size_t(w.check));
  peers::report("grad_hess_s", peers::median_time(w.repeat, [&] {
                  per_tet(*loop, false, g, h);
                }));
  peers::report("grad_hess_proj_s", peers::median_time(w.repeat, [&] {
                  per_tet(*loop, true, g, h);
                }));
  peers::report("projection", "12x12 (full, SymX project_to_PD_inplace)");

  // One Newton direction through SymX's second-order path.
  spGlobalPotential G = GlobalPotential::create();
  G->add_potential("yasps_peer_elastic", d.tets,
                   [&](MappedWorkspace<double> &m, Element &e) {
                     return elastic(m, e, d,
                                    m.make_vectors(d.x, e.slice(1, 5)));
                   });
  G->add_potential(
      "yasps_peer_inertia", d.verts,
      [&](MappedWorkspace<double> &m, Element &e) { return inertia(m, e, d); });
  G->add_dof(d.x);
  spContext context = Context::create();
  context->n_threads = 1;
  context->compilation_directory = codegen;
  context->output->set_console_verbosity(Verbosity::Minimal);
  t0 = peers::now();
  SecondOrderCompiledGlobal compiled(G, context);
  peers::report("compile_newton_s", peers::now() - t0);

  const int ndofs = G->get_total_n_dofs();
  std::vector<double> total, eval, project, assemble, solve;
  int iterations = 0;
  double residual = 0.0;
  bsm::PCGContext pcg_context;
  for (int r = 0; r <= w.repeat; ++r) { // round 0 warms up
    const double ta = peers::now();
    double E = 0.0;
    Eigen::VectorXd grad(ndofs);
    spElementHessians element_hessians =
        compiled.evaluate_P__dP_du__local_d2P_du2(E, grad);
    const double tb = peers::now();
    element_hessians->project_to_PD_inplace__all(0.0, false);
    const double tc = peers::now();
    ElementHessians::spBSM hess = element_hessians->assemble_global(1, ndofs);
    const double td = peers::now();
    hess->set_preconditioner(bsm::Preconditioner::BlockDiagonal);
    hess->prepare_preconditioning(1);
    Eigen::VectorXd rhs = -grad, du = Eigen::VectorXd::Zero(ndofs);
    bsm::PCGInfo info =
        bsm::solve_pcg(*hess, du.data(), rhs.data(), ndofs, 0.0, w.tolerance,
                       100000, 1, false, pcg_context);
    const double te = peers::now();
    if (!info.converged) {
      std::cerr << "symx_peer: PCG did not converge\n";
      return 1;
    }
    if (r > 0) {
      total.push_back(te - ta);
      eval.push_back(tb - ta);
      project.push_back(tc - tb);
      assemble.push_back(td - tc);
      solve.push_back(te - td);
    }
    iterations = info.n_iterations;
    Eigen::VectorXd hdu(ndofs);
    hess->spmxv_from_ptr(hdu.data(), du.data(), 1);
    residual = (rhs - hdu).norm() / rhs.norm();
  }
  peers::report("newton_s", peers::median(total));
  peers::report("newton_derivatives_s", peers::median(eval));
  peers::report("newton_projection_s", peers::median(project));
  peers::report("newton_assembly_s", peers::median(assemble));
  peers::report("solve_s", peers::median(solve));
  peers::report("iterations", iterations);
  peers::report("relative_residual", residual);
  peers::report("solver", "SymX/BSM block-diagonal PCG");
  return 0;
}
