// Shared by the CPU peer drivers of bench/cpu_peers.py: the work's inputs as
// the script writes them, timing, and what the drivers hand back.
//
// Input directory (written by bench/cpu_peers.py, little-endian, packed):
//   params.txt  "n_verts n_tets dt2 mu lambda mass tolerance repeat check"
//   x.bin       n_verts * 3 doubles, the deformed positions
//   x_hat.bin   n_verts * 3 doubles, the inertia targets
//   tets.bin    n_tets * 4 int32, vertex indices
//   inv.bin     n_tets * 9 doubles, Dm^-1 row-major (Dm = rest edge columns)
//   vol.bin     n_tets doubles, rest volumes
//
// The energy is yasps.energies' (bench/benchlib/elastic_scenes.py's snh_scene):
//   elastic(t) = dt2 * vol * [mu/2 (I_C - 3) - mu/2 log(I_C + 1)
//                             + lambda/2 (J - alpha)^2],
//   F = [x1 - x0, x2 - x0, x3 - x0] Dm^-1, I_C = |F|^2, J = det F,
//   alpha = 1 + 3 mu / (4 lambda);
//   inertia(v) = mass/2 |x - x_hat|^2.
//
// Outputs (in the output directory): grad.bin (check * 12 doubles) and
// hess.bin (check * 144 doubles, row-major) of the first `check` tets'
// unprojected elastic derivatives, local order (x0, y0, z0, x1, ...), and
// on stdout one line per result, "@peer key value" (after a line break:
// the peers print lines of their own, not always ending them).
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

namespace peers {

/// The work's data and constants.
struct Work {
  int n_verts = 0;
  int n_tets = 0;
  double dt2 = 0.0;
  double mu = 0.0;
  double lambda = 0.0;
  double mass = 0.0;
  double tolerance = 0.0;
  int repeat = 1;
  int check = 0;
  std::vector<double> x;     // n_verts * 3
  std::vector<double> x_hat; // n_verts * 3
  std::vector<int32_t> tets; // n_tets * 4
  std::vector<double> inv;   // n_tets * 9, row-major
  std::vector<double> vol;   // n_tets

  /// alpha of the stable Neo-Hookean energy.
  double alpha() const { return 1.0 + 0.75 * mu / lambda; }
};

template <typename T>
std::vector<T> read_array(const std::string &path, size_t count) {
  std::vector<T> values(count);
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw std::runtime_error("cannot open " + path);
  in.read(reinterpret_cast<char *>(values.data()),
          static_cast<std::streamsize>(count * sizeof(T)));
  if (static_cast<size_t>(in.gcount()) != count * sizeof(T))
    throw std::runtime_error("short read from " + path);
  return values;
}

inline Work read_work(const std::string &dir) {
  Work w;
  std::ifstream params(dir + "/params.txt");
  if (!(params >> w.n_verts >> w.n_tets >> w.dt2 >> w.mu >> w.lambda >>
        w.mass >> w.tolerance >> w.repeat >> w.check))
    throw std::runtime_error("cannot read " + dir + "/params.txt");
  w.x = read_array<double>(dir + "/x.bin", 3 * size_t(w.n_verts));
  w.x_hat = read_array<double>(dir + "/x_hat.bin", 3 * size_t(w.n_verts));
  w.tets = read_array<int32_t>(dir + "/tets.bin", 4 * size_t(w.n_tets));
  w.inv = read_array<double>(dir + "/inv.bin", 9 * size_t(w.n_tets));
  w.vol = read_array<double>(dir + "/vol.bin", size_t(w.n_tets));
  w.check = std::min(w.check, w.n_tets);
  return w;
}

inline void write_array(const std::string &path, const double *data,
                        size_t count) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char *>(data),
            static_cast<std::streamsize>(count * sizeof(double)));
  if (!out)
    throw std::runtime_error("cannot write " + path);
}

inline double now() {
  using clock = std::chrono::steady_clock;
  return std::chrono::duration<double>(clock::now().time_since_epoch()).count();
}

/// Median of a sample (copied).
inline double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  if (n == 0)
    return 0.0;
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

/// Median wall time in seconds of `repeat` calls of fn after one warm-up.
template <typename Fn> double median_time(int repeat, Fn &&fn) {
  fn();
  std::vector<double> times;
  for (int r = 0; r < repeat; ++r) {
    const double t0 = now();
    fn();
    times.push_back(now() - t0);
  }
  return median(times);
}

inline void report(const std::string &key, double value) {
  std::printf("\n@peer %s %.17g\n", key.c_str(), value);
  std::fflush(stdout);
}

inline void report(const std::string &key, const std::string &value) {
  std::printf("\n@peer %s %s\n", key.c_str(), value.c_str());
  std::fflush(stdout);
}

} // namespace peers
