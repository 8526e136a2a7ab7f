//===- BroadPhase.cpp - pairs whose swept boxes overlap -------------------===//

#include "yasps/Runtime/Contact/BroadPhase.h"

#include "Blocks.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

namespace yasps::runtime::contact {

namespace {

/// An axis-aligned box, closed: boxes that touch overlap.
struct Box {
  std::array<double, 3> lo, hi;

  void grow(const Box &other) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], other.lo[k]);
      hi[k] = std::max(hi[k], other.hi[k]);
    }
  }
  /// Branch-free: in the broad phase's cells most tests fail, on no
  /// predictable axis.
  bool overlaps(const Box &other) const {
    return (lo[0] <= other.hi[0]) & (other.lo[0] <= hi[0]) &
           (lo[1] <= other.hi[1]) & (other.lo[1] <= hi[1]) &
           (lo[2] <= other.hi[2]) & (other.lo[2] <= hi[2]);
  }
};

/// Each vertex's box over V0 -> V1, grown by `inflation`.
std::vector<Box> vertexBoxes(Positions v0, Positions v1, double inflation) {
  std::vector<Box> boxes(v0.count);
  for (int64_t v = 0; v < v0.count; ++v) {
    Vec3 a = v0[v], b = v1[v];
    for (int k = 0; k < 3; ++k) {
      boxes[v].lo[k] = std::min(a[k], b[k]) - inflation;
      boxes[v].hi[k] = std::max(a[k], b[k]) + inflation;
    }
  }
  return boxes;
}

/// Each element's box: the union of its vertices' boxes.
template <size_t N>
std::vector<Box> elementBoxes(const std::vector<std::array<int32_t, N>> &elems,
                              const std::vector<Box> &vertices) {
  std::vector<Box> boxes;
  boxes.reserve(elems.size());
  for (const auto &elem : elems) {
    Box box = vertices[elem[0]];
    for (size_t k = 1; k < N; ++k)
      box.grow(vertices[elem[k]]);
    boxes.push_back(box);
  }
  return boxes;
}

/// Boxes listed per grid cell (every box in every cell it touches), one
/// array per bound: a cell's boxes are tested against another box a few at
/// a time. The bounds are f32 rounded outward (an f32 overlap holds
/// wherever the f64 boxes overlap), and each entry also has its box's id
/// and the cell of its box's low corner.
struct CellLists {
  /// Cell c's entries are [start[c], start[c + 1]).
  std::vector<int32_t> start;
  std::array<std::vector<float>, 3> lo, hi;
  std::array<std::vector<int32_t>, 3> lowCell;
  std::vector<int32_t> id;
};

/// `x` in f32, no larger than x (`down`) or no smaller. Moved 2^-23 of
/// itself outward first, more than rounding to nearest moves back.
float roundedOutward(double x, bool down) {
  const double shift = std::abs(x) * 0x1p-23;
  return static_cast<float>(down ? x - shift : x + shift);
}

/// flags[k] = whether entry first + k of `lists` overlaps the f32 box
/// [lo, hi] with their overlap starting in cell `at` (`starts`: whether the
/// box itself starts there, per axis): a loop without branches or
/// dependences, which the compiler vectorises (cloning it for AVX2 gained
/// nothing more).
void overlapFlags(const CellLists &lists, int32_t first, int32_t count,
                  std::array<float, 3> lo, std::array<float, 3> hi,
                  std::array<bool, 3> starts, const int32_t at[3],
                  uint8_t *__restrict flags) {
  // Raw pointers: a byte store may alias anything, the vectors' own
  // pointers included, which would otherwise be reloaded per entry.
  const float *__restrict lo0 = lists.lo[0].data() + first,
                          *__restrict lo1 = lists.lo[1].data() + first,
                          *__restrict lo2 = lists.lo[2].data() + first,
                          *__restrict hi0 = lists.hi[0].data() + first,
                          *__restrict hi1 = lists.hi[1].data() + first,
                          *__restrict hi2 = lists.hi[2].data() + first;
  const int32_t *__restrict low0 = lists.lowCell[0].data() + first,
                            *__restrict low1 = lists.lowCell[1].data() + first,
                            *__restrict low2 = lists.lowCell[2].data() + first;
  const int32_t at0 = at[0], at1 = at[1], at2 = at[2];
  const bool s0 = starts[0], s1 = starts[1], s2 = starts[2];
  for (int32_t k = 0; k < count; ++k)
    flags[k] = (lo[0] <= hi0[k]) & (lo0[k] <= hi[0]) & (lo[1] <= hi1[k]) &
               (lo1[k] <= hi[1]) & (lo[2] <= hi2[k]) & (lo2[k] <= hi[2]) &
               (s0 | (low0[k] == at0)) & (s1 | (low1[k] == at1)) &
               (s2 | (low2[k] == at2));
}

/// A uniform grid over boxes of two sets, A and B (B may be A itself).
/// Pairs are found cell by cell: each A box of a cell against the cell's
/// B boxes, first in f32 over the cell's bound arrays, then the few whose
/// f32 boxes overlap in f64. A pair of overlapping boxes is kept only in
/// the cell that holds the low corner of their overlap (the larger of
/// their low corners' cells on each axis), so it comes once without a
/// record of pairs already seen. Cells as wide as the boxes are on average
/// keep the lists short, and unlike a sweep along one axis the grid stays
/// local on flat, spread-out surfaces such as cloth.
class PairGrid {
public:
  /// Lists the boxes in `scratch`'s lists, which it keeps until the grid
  /// goes (their capacity outlives it: see gridScratch).
  PairGrid(const std::vector<Box> &a, const std::vector<Box> *b,
           std::array<CellLists, 2> &scratch)
      : a_(a), b_(b ? *b : a), self_(!b), listsA_(scratch[0]),
        listsB_(scratch[1]) {
    lo_.fill(1e300);
    std::array<double, 3> hi;
    hi.fill(-1e300);
    double width = 0;
    size_t count = 0;
    for (const std::vector<Box> *set : {&a_, &b_}) {
      for (const Box &box : *set)
        for (int k = 0; k < 3; ++k) {
          lo_[k] = std::min(lo_[k], box.lo[k]);
          hi[k] = std::max(hi[k], box.hi[k]);
          width += box.hi[k] - box.lo[k];
        }
      count += set->size();
      if (self_)
        break;
    }
    if (count == 0) {
      listsA_.start.clear();
      return;
    }
    // Cells no more than 16 per box: larger cells where the boxes are few
    // and the scene is wide. A cap of 4 made the cells under a dense tet
    // bunny on a wide cloth four times too wide (225 faces in one); a cap
    // of 64 spent more on empty cells than it saved on tests.
    const double maxCells = 16.0 * count + 64;
    // As wide as the boxes on average, and no narrower than the scene's
    // extent over the cap: boxes of no width (points that do not move,
    // with no inflation) give no scale of their own, and a cell of
    // 1e-300 made the cell counts overflow (a crash from Python).
    double extent = 0.0;
    for (int k = 0; k < 3; ++k)
      extent = std::max(extent, hi[k] - lo_[k]);
    double cell = std::max(width / (3.0 * count), extent / maxCells);
    if (!(cell > 0.0))
      cell = 1.0; // every box at one point: one cell
    for (;;) {
      // Counted in double, cast once they are known to be few.
      double counts[3], cells = 1;
      for (int k = 0; k < 3; ++k) {
        counts[k] = std::max(1.0, std::ceil((hi[k] - lo_[k]) / cell));
        cells *= counts[k];
      }
      if (cells <= maxCells) {
        for (int k = 0; k < 3; ++k)
          dims_[k] = static_cast<int64_t>(counts[k]);
        break;
      }
      cell *= 2;
    }
    inverseCell_ = 1.0 / cell;
    const int64_t cells = dims_[0] * dims_[1] * dims_[2];
    fill(a_, cells, listsA_);
    if (!self_)
      fill(b_, cells, listsB_);
  }

  /// The cells (none without boxes).
  int64_t numCells() const {
    return listsA_.start.empty() ? 0 : dims_[0] * dims_[1] * dims_[2];
  }

  /// Calls found(a, b) for each pair of an A box and a B box that overlap
  /// and have the low corner of their overlap in one of cells [begin, end),
  /// cell by cell; with B = A, for each overlapping pair of A boxes, the
  /// lower id first.
  template <typename Found>
  void pairsInCells(int64_t begin, int64_t end, Found &&found) const {
    const CellLists &la = listsA_, &lb = self_ ? listsA_ : listsB_;
    std::vector<int32_t> hits;
    std::vector<uint8_t> mask;
    for (int64_t c = begin; c < end; ++c) {
      const int32_t firstA = la.start[c], lastA = la.start[c + 1];
      const int32_t lastB = lb.start[c + 1];
      if (firstA == lastA || lb.start[c] == lastB)
        continue;
      const int32_t at[3] = {static_cast<int32_t>(c % dims_[0]),
                             static_cast<int32_t>((c / dims_[0]) % dims_[1]),
                             static_cast<int32_t>(c / (dims_[0] * dims_[1]))};
      const int32_t firstCellB = lb.start[c];
      // One flag per B entry of the cell, padded to whole 8-byte words.
      mask.resize(static_cast<size_t>(lastB - firstCellB + 8));
      for (int32_t i = firstA; i < lastA; ++i) {
        const int32_t firstB = self_ ? i + 1 : firstCellB;
        const float x0 = la.lo[0][i], x1 = la.lo[1][i], x2 = la.lo[2][i];
        const float y0 = la.hi[0][i], y1 = la.hi[1][i], y2 = la.hi[2][i];
        // The overlap of two boxes in this cell starts here on an axis
        // when either box starts here (neither starts past it): integer
        // equalities, where a max would not vectorise without SSE4.1.
        const bool s0 = la.lowCell[0][i] == at[0],
                   s1 = la.lowCell[1][i] == at[1],
                   s2 = la.lowCell[2][i] == at[2];
        // The B entries whose f32 boxes overlap entry i's and whose
        // overlap starts in this cell: flags first, in a loop without a
        // branch or a dependence that the compiler vectorises, then the
        // few set ones, skipped a word of eight at a time.
        const int32_t count = lastB - firstB;
        uint8_t *flags = mask.data();
        overlapFlags(lb, firstB, count, {x0, x1, x2}, {y0, y1, y2},
                     {s0, s1, s2}, at, flags);
        std::fill(flags + count, flags + count + 8, uint8_t{0});
        size_t n = 0;
        hits.resize(static_cast<size_t>(count));
        for (int32_t k = 0; k < count; k += 8) {
          uint64_t word;
          std::memcpy(&word, flags + k, sizeof word);
          if (!word)
            continue;
          for (int32_t b = 0; b < 8 && k + b < count; ++b) {
            hits[n] = firstB + k + b;
            n += flags[k + b];
          }
        }
        const int32_t idA = la.id[i];
        for (size_t h = 0; h < n; ++h) {
          const int32_t idB = lb.id[hits[h]];
          if (!a_[idA].overlaps(b_[idB]))
            continue;
          if (self_)
            found(std::min(idA, idB), std::max(idA, idB));
          else
            found(idA, idB);
        }
      }
    }
  }

private:
  /// The cell of coordinate x on axis k. Every coordinate asked for is at
  /// least lo_[k] (a box's low corner), so truncation floors it
  /// (std::floor was a library call).
  int64_t cellOf(double x, int k) const {
    const double at = std::max(0.0, (x - lo_[k]) * inverseCell_);
    return std::min(static_cast<int64_t>(at), dims_[k] - 1);
  }

  template <typename Visit> void forCells(const Box &box, Visit &&visit) const {
    int64_t from[3], to[3];
    for (int k = 0; k < 3; ++k) {
      from[k] = cellOf(box.lo[k], k);
      to[k] = cellOf(box.hi[k], k);
    }
    for (int64_t z = from[2]; z <= to[2]; ++z)
      for (int64_t y = from[1]; y <= to[1]; ++y)
        for (int64_t x = from[0]; x <= to[0]; ++x)
          visit((z * dims_[1] + y) * dims_[0] + x);
  }

  /// Lists each box in the cells it touches, by increasing id per cell.
  void fill(const std::vector<Box> &boxes, int64_t cells,
            CellLists &lists) const {
    // Counts at start[c + 1], summed: start[c + 1] is where cell c ends.
    // Each entry is then placed at --start[c + 1], boxes from the last, so
    // start[c + 1] ends up where cell c begins; the front slot is dropped.
    std::vector<int32_t> &start = lists.start;
    start.assign(static_cast<size_t>(cells) + 2, 0);
    std::vector<std::array<int32_t, 3>> low(boxes.size());
    for (size_t i = 0; i < boxes.size(); ++i) {
      forCells(boxes[i], [&](int64_t c) { ++start[c + 1]; });
      for (int k = 0; k < 3; ++k)
        low[i][k] = static_cast<int32_t>(cellOf(boxes[i].lo[k], k));
    }
    for (size_t c = 1; c + 1 < start.size(); ++c)
      start[c] += start[c - 1];
    start.back() = start[start.size() - 2];
    const size_t entries = static_cast<size_t>(start.back());
    for (int k = 0; k < 3; ++k) {
      lists.lo[k].resize(entries);
      lists.hi[k].resize(entries);
      lists.lowCell[k].resize(entries);
    }
    lists.id.resize(entries);
    for (int32_t i = static_cast<int32_t>(boxes.size()) - 1; i >= 0; --i) {
      float lo[3], hi[3];
      for (int k = 0; k < 3; ++k) {
        lo[k] = roundedOutward(boxes[i].lo[k], true);
        hi[k] = roundedOutward(boxes[i].hi[k], false);
      }
      forCells(boxes[i], [&](int64_t c) {
        const int32_t at = --start[c + 1];
        for (int k = 0; k < 3; ++k) {
          lists.lo[k][at] = lo[k];
          lists.hi[k][at] = hi[k];
          lists.lowCell[k][at] = low[i][k];
        }
        lists.id[at] = i;
      });
    }
    start.erase(start.begin());
  }

  const std::vector<Box> &a_, &b_;
  const bool self_;
  std::array<double, 3> lo_;
  std::array<int64_t, 3> dims_{1, 1, 1};
  double inverseCell_ = 1;
  CellLists &listsA_, &listsB_;
};

/// The calling thread's grid lists, kept between broad phases: a scene's
/// lists take megabytes, which fresh vectors took from the system (and
/// faulted in) at every call, 9% of the broad phase's time.
std::array<CellLists, 2> &gridScratch() {
  static thread_local std::array<CellLists, 2> scratch;
  return scratch;
}

/// The pairs of `grid` that `keep` accepts, appended to `out` in cell
/// order, the cells in ordered blocks on `pool`.
template <typename Keep>
void gridPairs(ThreadPool *pool, const PairGrid &grid, Keep &&keep,
               std::vector<std::array<int32_t, 2>> &out) {
  const int64_t cells = grid.numCells();
  // A block of cells costs a few microseconds at least.
  const int64_t blocks = blockCount(pool, cells, 512);
  std::vector<std::vector<std::array<int32_t, 2>>> found(blocks);
  forBlocks(pool, cells, blocks, [&](int64_t b, int64_t begin, int64_t end) {
    grid.pairsInCells(begin, end, [&](int32_t x, int32_t y) {
      if (keep(x, y))
        found[b].push_back({x, y});
    });
  });
  for (auto &part : found)
    out.insert(out.end(), part.begin(), part.end());
}

/// The codimensional points against each other and against the
/// codimensional edges (ipctk's extra candidates for points and rods). A
/// codimensional point is on no edge, so no pair shares a vertex.
void codimCandidates(const SurfaceMesh &mesh, const std::vector<Box> &vertices,
                     const std::vector<Box> &edges, ThreadPool *pool,
                     Candidates &out) {
  const std::vector<int32_t> &points = mesh.codimVertices();
  if (points.empty())
    return;
  std::vector<Box> pointBoxes;
  pointBoxes.reserve(points.size());
  for (int32_t v : points)
    pointBoxes.push_back(vertices[v]);
  std::vector<std::array<int32_t, 2>> pairs;
  gridPairs(
      pool, PairGrid(pointBoxes, nullptr, gridScratch()),
      [](int32_t, int32_t) { return true; }, pairs);
  for (auto [i, j] : pairs)
    out.vertexVertex.push_back({points[i], points[j]});
  const std::vector<int32_t> &codimEdges = mesh.codimEdges();
  if (codimEdges.empty())
    return;
  std::vector<Box> edgeBoxes;
  edgeBoxes.reserve(codimEdges.size());
  for (int32_t e : codimEdges)
    edgeBoxes.push_back(edges[e]);
  pairs.clear();
  gridPairs(
      pool, PairGrid(edgeBoxes, &pointBoxes, gridScratch()),
      [](int32_t, int32_t) { return true; }, pairs);
  for (auto [e, j] : pairs)
    out.edgeVertex.push_back({codimEdges[e], points[j]});
}

} // namespace

void checkCandidates(const SurfaceMesh &mesh, const Candidates &candidates,
                     const char *who) {
  const int64_t counts[3] = {static_cast<int64_t>(mesh.faces().size()),
                             static_cast<int64_t>(mesh.edges().size()),
                             mesh.numVertices()};
  const char *names[3] = {"face", "edge", "vertex"};
  enum { Face, Edge, Vertex };
  auto check = [&](const std::vector<std::array<int32_t, 2>> &pairs, int first,
                   int second) {
    for (const auto &pair : pairs)
      for (int k = 0; k < 2; ++k) {
        const int kind = k == 0 ? first : second;
        if (pair[k] < 0 || pair[k] >= counts[kind])
          throw std::invalid_argument(
              std::string(who) + ": a candidate's " + names[kind] + " " +
              std::to_string(pair[k]) + " is not one of the mesh's " +
              std::to_string(counts[kind]) +
              " (candidates of another contact mesh?)");
      }
  };
  check(candidates.faceVertex, Face, Vertex);
  check(candidates.edgeEdge, Edge, Edge);
  check(candidates.vertexVertex, Vertex, Vertex);
  check(candidates.edgeVertex, Edge, Vertex);
}

Candidates sweptCandidates(const SurfaceMesh &mesh, Positions v0, Positions v1,
                           double inflation, ThreadPool *pool) {
  if (v0.count != mesh.numVertices() || v1.count != mesh.numVertices())
    throw std::invalid_argument(
        "sweptCandidates: positions of " + std::to_string(v0.count) + " and " +
        std::to_string(v1.count) + " vertices for a " + "mesh of " +
        std::to_string(mesh.numVertices()));
  checkFinite(v0, "sweptCandidates");
  checkFinite(v1, "sweptCandidates");
  if (!(inflation >= 0.0) || !std::isfinite(inflation))
    throw std::invalid_argument(
        "sweptCandidates: the inflation must be a finite distance >= 0, got " +
        std::to_string(inflation));
  std::vector<Box> vertices = vertexBoxes(v0, v1, inflation);
  std::vector<Box> edges = elementBoxes(mesh.edges(), vertices);
  std::vector<Box> faces = elementBoxes(mesh.faces(), vertices);
  Candidates out;
  gridPairs(
      pool, PairGrid(faces, &vertices, gridScratch()),
      [&](int32_t f, int32_t v) {
        const auto &corners = mesh.faces()[f];
        return v != corners[0] && v != corners[1] && v != corners[2];
      },
      out.faceVertex);
  gridPairs(
      pool, PairGrid(edges, nullptr, gridScratch()),
      [&](int32_t a, int32_t b) {
        const auto &x = mesh.edges()[a], &y = mesh.edges()[b];
        return x[0] != y[0] && x[0] != y[1] && x[1] != y[0] && x[1] != y[1];
      },
      out.edgeEdge);
  codimCandidates(mesh, vertices, edges, pool, out);
  return out;
}

} // namespace yasps::runtime::contact
