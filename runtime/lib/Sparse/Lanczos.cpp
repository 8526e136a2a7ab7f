//===- Lanczos.cpp - what CG's coefficients say about the spectrum --------===//

#include "yasps/Runtime/Sparse/Lanczos.h"

#include <algorithm>
#include <cmath>
#include <limits>

using namespace yasps::runtime;

/// The number of eigenvalues of the tridiagonal matrix below `x` (the sign
/// changes of its Sturm sequence, in the LDL^T form that does not overflow).
static std::size_t countBelow(const std::vector<double> &diagonal,
                              const std::vector<double> &offDiagonal,
                              double x) {
  std::size_t count = 0;
  double d = 1.0;
  const double tiny = std::numeric_limits<double>::min();
  for (std::size_t i = 0; i < diagonal.size(); ++i) {
    double off = i == 0 ? 0.0 : offDiagonal[i - 1];
    d = diagonal[i] - x - (i == 0 ? 0.0 : off * off / d);
    if (d == 0.0)
      d = -tiny;
    if (d < 0.0)
      ++count;
  }
  return count;
}

std::pair<double, double> yasps::runtime::tridiagonalExtremeEigenvalues(
    const std::vector<double> &diagonal,
    const std::vector<double> &offDiagonal) {
  // Gershgorin's discs hold the spectrum.
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t i = 0; i < diagonal.size(); ++i) {
    double radius = (i > 0 ? std::fabs(offDiagonal[i - 1]) : 0.0) +
                    (i + 1 < diagonal.size() ? std::fabs(offDiagonal[i]) : 0.0);
    lo = std::min(lo, diagonal[i] - radius);
    hi = std::max(hi, diagonal[i] + radius);
  }
  auto bisect = [&](std::size_t index) {
    // The eigenvalue with `index` eigenvalues below it.
    double a = lo, b = hi;
    for (int step = 0;
         step < 200 && b - a > 1e-15 * std::max(std::fabs(a), std::fabs(b));
         ++step) {
      double mid = 0.5 * (a + b);
      if (countBelow(diagonal, offDiagonal, mid) > index)
        b = mid;
      else
        a = mid;
    }
    return 0.5 * (a + b);
  };
  return {bisect(0), bisect(diagonal.size() - 1)};
}

std::pair<double, double>
yasps::runtime::ritzExtremeValues(const std::vector<double> &alphas,
                                  const std::vector<double> &betas) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::size_t k = alphas.size();
  if (k < 1 || betas.size() + 1 < k)
    return {nan, nan};
  std::vector<double> diagonal(k), offDiagonal(k - 1);
  for (std::size_t j = 0; j < k; ++j) {
    if (!(alphas[j] > 0.0) || (j + 1 < k && !(betas[j] >= 0.0)))
      return {nan, nan};
    diagonal[j] =
        1.0 / alphas[j] + (j > 0 ? betas[j - 1] / alphas[j - 1] : 0.0);
    if (j + 1 < k)
      offDiagonal[j] = std::sqrt(betas[j]) / alphas[j];
  }
  return tridiagonalExtremeEigenvalues(diagonal, offDiagonal);
}

double yasps::runtime::ritzConditionNumber(const std::vector<double> &alphas,
                                           const std::vector<double> &betas) {
  if (alphas.size() < 2)
    return std::numeric_limits<double>::quiet_NaN();
  auto [smallest, largest] = ritzExtremeValues(alphas, betas);
  if (std::isnan(smallest))
    return smallest;
  return smallest > 0.0 ? largest / smallest
                        : std::numeric_limits<double>::infinity();
}
