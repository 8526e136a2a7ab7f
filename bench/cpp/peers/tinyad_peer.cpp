// TinyAD on the work of bench/cpu_peers.py (see peer_common.h), one thread.
//
//   tinyad_peer INPUT_DIR OUTPUT_DIR
//
// Per tet: TinyAD::Double<12> forward-mode gradient and Hessian of the
// elastic energy into per-tet buffers, and the same with TinyAD's
// project_positive_definite of the 12x12 Hessian (eigenvalues clamped at 0).
// Newton direction: TinyAD::ScalarFunction's eval_with_hessian_proj
// (derivatives, projection, Eigen triplet assembly) of elastic + inertia,
// then Eigen's ConjugateGradient with its diagonal (Jacobi) preconditioner
// to the relative residual `tolerance`.
#include "peer_common.h"

#include <Eigen/Dense>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/Sparse>
#include <TinyAD/ScalarFunction.hh>
#include <TinyAD/Utils/HessianProjection.hh>

#include <cmath>

namespace {

/// dt2 * vol * stable Neo-Hookean density of F (yasps.energies' formula).
template <typename T>
T elastic(const peers::Work &w, const Eigen::Matrix<T, 3, 3> &F, double vol) {
  using std::log;
  const T ic = F.squaredNorm();
  const T j = F.determinant();
  const T shifted = j - w.alpha();
  const T psi = 0.5 * w.mu * (ic - 3.0) - 0.5 * w.mu * log(ic + 1.0) +
                0.5 * w.lambda * shifted * shifted;
  return w.dt2 * vol * psi;
}

/// F = [x1 - x0, x2 - x0, x3 - x0] Dm^-1 of tet t from its corners.
template <typename T>
Eigen::Matrix<T, 3, 3>
deformation(const peers::Work &w, int t, const Eigen::Matrix<T, 3, 1> &x0,
            const Eigen::Matrix<T, 3, 1> &x1, const Eigen::Matrix<T, 3, 1> &x2,
            const Eigen::Matrix<T, 3, 1> &x3) {
  Eigen::Matrix<T, 3, 3> ds;
  ds.col(0) = x1 - x0;
  ds.col(1) = x2 - x0;
  ds.col(2) = x3 - x0;
  const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> inv(
      w.inv.data() + 9 * size_t(t));
  return ds * inv; // products with passive doubles: no AD temporaries
}

using AD = TinyAD::Double<12>;

/// The elastic energy of tet t as a TinyAD scalar over its 12 coordinates.
AD tet_energy(const peers::Work &w, int t) {
  Eigen::Matrix<double, 12, 1> local;
  for (int k = 0; k < 4; ++k)
    for (int d = 0; d < 3; ++d)
      local[3 * k + d] = w.x[3 * size_t(w.tets[4 * size_t(t) + k]) + d];
  const Eigen::Matrix<AD, 12, 1> a = AD::make_active(local);
  const Eigen::Matrix<AD, 3, 1> x0 = a.segment<3>(0), x1 = a.segment<3>(3),
                                x2 = a.segment<3>(6), x3 = a.segment<3>(9);
  return elastic<AD>(w, deformation<AD>(w, t, x0, x1, x2, x3), w.vol[t]);
}

/// Gradients and (optionally projected) Hessians of every tet into g, h.
void per_tet(const peers::Work &w, bool project, std::vector<double> &g,
             std::vector<double> &h) {
  for (int t = 0; t < w.n_tets; ++t) {
    AD e = tet_energy(w, t);
    if (project)
      TinyAD::project_positive_definite<12, double>(e.Hess, 0.0);
    Eigen::Map<Eigen::Matrix<double, 12, 1>>(g.data() + 12 * size_t(t)) =
        e.grad;
    Eigen::Map<Eigen::Matrix<double, 12, 12, Eigen::RowMajor>>(
        h.data() + 144 * size_t(t)) = e.Hess;
  }
}

} // namespace

int main(int argc, char **argv) {
  if (argc != 3) {
    std::cerr << "usage: tinyad_peer INPUT_DIR OUTPUT_DIR\n";
    return 2;
  }
  const peers::Work w = peers::read_work(argv[1]);
  const std::string out = argv[2];
  std::vector<double> g(12 * size_t(w.n_tets)), h(144 * size_t(w.n_tets));

  // Check values: the unprojected derivatives of the first tets.
  per_tet(w, false, g, h);
  peers::write_array(out + "/grad.bin", g.data(), 12 * size_t(w.check));
  peers::write_array(out + "/hess.bin", h.data(), 144 * size_t(w.check));

  const double plain =
      peers::median_time(w.repeat, [&] { per_tet(w, false, g, h); });
  peers::report("grad_hess_s", plain);
  const double projected =
      peers::median_time(w.repeat, [&] { per_tet(w, true, g, h); });
  peers::report("grad_hess_proj_s", projected);
  peers::report("projection", "12x12 (full, TinyAD project_positive_definite)");

  // One Newton direction through TinyAD's sparse interface.
  auto func = TinyAD::scalar_function<3>(TinyAD::range(w.n_verts));
  func.settings.n_threads = 1;
  func.add_elements<4>(
      TinyAD::range(w.n_tets),
      [&](auto &element) -> TINYAD_SCALAR_TYPE(element) {
        using T = TINYAD_SCALAR_TYPE(element);
        const int t = static_cast<int>(element.handle);
        const int32_t *v = w.tets.data() + 4 * size_t(t);
        const Eigen::Matrix<T, 3, 1> x0 = element.variables(v[0]);
        const Eigen::Matrix<T, 3, 1> x1 = element.variables(v[1]);
        const Eigen::Matrix<T, 3, 1> x2 = element.variables(v[2]);
        const Eigen::Matrix<T, 3, 1> x3 = element.variables(v[3]);
        return elastic<T>(w, deformation<T>(w, t, x0, x1, x2, x3), w.vol[t]);
      });
  func.add_elements<1>(TinyAD::range(w.n_verts),
                       [&](auto &element) -> TINYAD_SCALAR_TYPE(element) {
                         using T = TINYAD_SCALAR_TYPE(element);
                         const Eigen::Index v = element.handle;
                         const Eigen::Matrix<T, 3, 1> x = element.variables(v);
                         const Eigen::Vector3d x_hat(w.x_hat[3 * v],
                                                     w.x_hat[3 * v + 1],
                                                     w.x_hat[3 * v + 2]);
                         return 0.5 * w.mass * (x - x_hat).squaredNorm();
                       });
  const Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(
      w.x.data(), static_cast<Eigen::Index>(w.x.size()));

  using Solver =
      Eigen::ConjugateGradient<Eigen::SparseMatrix<double>,
                               Eigen::Lower | Eigen::Upper,
                               Eigen::DiagonalPreconditioner<double>>;
  std::vector<double> total, solve;
  int iterations = 0;
  double residual = 0.0;
  for (int r = 0; r <= w.repeat; ++r) { // round 0 warms up
    const double t0 = peers::now();
    double f = 0.0;
    Eigen::VectorXd grad;
    Eigen::SparseMatrix<double> hess;
    func.eval_with_hessian_proj(x, f, grad, hess, 0.0);
    const double t1 = peers::now();
    Solver cg;
    cg.setTolerance(w.tolerance);
    cg.setMaxIterations(100000);
    cg.compute(hess);
    const Eigen::VectorXd dx = cg.solve(grad);
    const double t2 = peers::now();
    if (cg.info() != Eigen::Success) {
      std::cerr << "tinyad_peer: Eigen CG did not converge\n";
      return 1;
    }
    if (r > 0) {
      total.push_back(t2 - t0);
      solve.push_back(t2 - t1);
    }
    iterations = static_cast<int>(cg.iterations());
    residual = (grad - hess * dx).norm() / grad.norm();
  }
  peers::report("newton_s", peers::median(total));
  peers::report("solve_s", peers::median(solve));
  peers::report("iterations", iterations);
  peers::report("relative_residual", residual);
  peers::report("solver", "Eigen ConjugateGradient, diagonal preconditioner");
  return 0;
}
