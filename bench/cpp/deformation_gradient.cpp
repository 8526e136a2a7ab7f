// The benchmark's hand-written reference: F = Ds * DmInv for every tet,
// single thread, the same data layout as yasps (column-major per instance).
#include <cstdint>

extern "C" void deformation_gradient(const double *x, const int32_t *tets,
                                     const double *dmInv, double *out,
                                     int64_t numTets) {
  for (int64_t t = 0; t < numTets; ++t) {
    const int32_t *v = tets + 4 * t;
    const double *x0 = x + 3 * v[0];
    double ds[9]; // column-major 3x3: column k = x_{k+1} - x_0
    for (int k = 0; k < 3; ++k)
      for (int r = 0; r < 3; ++r)
        ds[3 * k + r] = x[3 * v[k + 1] + r] - x0[r];
    const double *d = dmInv + 9 * t;
    double *f = out + 9 * t;
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r)
        f[3 * c + r] = ds[r] * d[3 * c] + ds[3 + r] * d[3 * c + 1] +
                       ds[6 + r] * d[3 * c + 2];
  }
}
