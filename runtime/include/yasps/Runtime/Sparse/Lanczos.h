//===- Lanczos.h - what CG's coefficients say about the spectrum -*- C++
//-*-===//
//
// Conjugate gradient is the Lanczos process in disguise: its step lengths
// and direction updates define a tridiagonal matrix whose eigenvalues (Ritz
// values) approach the extreme eigenvalues of the preconditioned matrix.
// PCG reports the condition number they show, at no extra product.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SPARSE_LANCZOS_H
#define YASPS_RUNTIME_SPARSE_LANCZOS_H

#include <utility>
#include <vector>

namespace yasps::runtime {

/// The ratio of the largest to the smallest eigenvalue of the Lanczos
/// tridiagonal matrix of k CG iterations with step lengths `alphas` (k of
/// them) and direction coefficients `betas` (beta_j = r_{j+1}.z_{j+1} /
/// r_j.z_j, at least k - 1 of them). NaN for k < 2 or coefficients that do
/// not come from a positive definite matrix (an alpha <= 0, a beta < 0).
double ritzConditionNumber(const std::vector<double> &alphas,
                           const std::vector<double> &betas);

/// The smallest and largest eigenvalue of that Lanczos matrix (k >= 1
/// iterations). They lie inside the preconditioned matrix's spectrum: the
/// largest is a lower estimate of its largest eigenvalue, and converges
/// within a few iterations. {NaN, NaN} where
/// ritzConditionNumber would be NaN for a reason other than k < 2.
std::pair<double, double> ritzExtremeValues(const std::vector<double> &alphas,
                                            const std::vector<double> &betas);

/// The eigenvalues of the symmetric tridiagonal matrix with `diagonal` and
/// `offDiagonal` (one fewer) closest to its spectrum's ends: {smallest,
/// largest}, by Sturm-sequence bisection to a relative accuracy near
/// round-off.
std::pair<double, double>
tridiagonalExtremeEigenvalues(const std::vector<double> &diagonal,
                              const std::vector<double> &offDiagonal);

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SPARSE_LANCZOS_H
