//===- BroadPhase.cpp - pairs whose swept boxes overlap -------------------===//

#include "yasps/Runtime/Contact/BroadPhase.h"

#include "Blocks.h"

#include <algorithm>
#include <cmath>
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

/// A box in a grid cell's list, with the primitive it bounds.
struct Entry {
  Box box;
  int32_t id;
};

/// A uniform grid over boxes of two sets, A and B (B may be A itself), each
/// box entered in every cell it touches with a copy of its bounds. Pairs
/// are found cell by cell, every A entry of a cell against every B entry,
/// reading the cell's lists front to back. A pair of overlapping boxes is
/// kept only in the cell that holds the low corner of their overlap, so it
/// comes once without a record of pairs already seen. Cells as wide as the
/// boxes are on average keep the lists short, and unlike a sweep along one
/// axis the grid stays local on flat, spread-out surfaces such as cloth.
class PairGrid {
public:
  PairGrid(const std::vector<Box> &a, const std::vector<Box> *b) {
    const std::vector<Box> &other = b ? *b : a;
    lo_.fill(1e300);
    std::array<double, 3> hi;
    hi.fill(-1e300);
    double width = 0;
    size_t count = 0;
    for (const std::vector<Box> *set : {&a, &other}) {
      for (const Box &box : *set)
        for (int k = 0; k < 3; ++k) {
          lo_[k] = std::min(lo_[k], box.lo[k]);
          hi[k] = std::max(hi[k], box.hi[k]);
          width += box.hi[k] - box.lo[k];
        }
      count += set->size();
      if (!b)
        break;
    }
    if (count == 0)
      return;
    double cell = std::max(width / (3.0 * count), 1e-300);
    // Cells no more than 16 per box: larger cells where the boxes are few
    // and the scene is wide. A cap of 4 made the cells under a dense tet
    // bunny on a wide cloth four times too wide (225 faces in one); a cap
    // of 64 spent more on empty cells than it saved on tests.
    const double maxCells = 16.0 * count + 64;
    for (;;) {
      double cells = 1;
      for (int k = 0; k < 3; ++k) {
        dims_[k] = static_cast<int64_t>(
            std::max(1.0, std::ceil((hi[k] - lo_[k]) / cell)));
        cells *= static_cast<double>(dims_[k]);
      }
      if (cells <= maxCells)
        break;
      cell *= 2;
    }
    inverseCell_ = 1.0 / cell;
    const int64_t cells = dims_[0] * dims_[1] * dims_[2];
    fill(a, cells, startA_, entriesA_);
    if (b)
      fill(*b, cells, startB_, entriesB_);
  }

  /// The cells (none without boxes).
  int64_t numCells() const {
    return startA_.empty() ? 0 : dims_[0] * dims_[1] * dims_[2];
  }

  /// Calls found(a, b) for each pair of an A box and a B box that overlap
  /// and have the low corner of their overlap in one of cells [begin, end),
  /// cell by cell; with B = A, for each overlapping pair of A boxes, the
  /// lower id first.
  template <typename Found>
  void pairsInCells(int64_t begin, int64_t end, Found &&found) const {
    const bool self = entriesB_.empty() && startB_.empty();
    for (int64_t c = begin; c < end; ++c) {
      const int64_t at[3] = {c % dims_[0], (c / dims_[0]) % dims_[1],
                             c / (dims_[0] * dims_[1])};
      // Whether the overlap of two boxes starts in this cell.
      auto startsHere = [&](const Box &x, const Box &y) {
        for (int k = 0; k < 3; ++k)
          if (cellOf(std::max(x.lo[k], y.lo[k]), k) != at[k])
            return false;
        return true;
      };
      const Entry *firstA = entriesA_.data() + startA_[c];
      const Entry *lastA = entriesA_.data() + startA_[c + 1];
      if (self) {
        for (const Entry *x = firstA; x != lastA; ++x)
          for (const Entry *y = x + 1; y != lastA; ++y)
            if (x->box.overlaps(y->box) && startsHere(x->box, y->box))
              found(std::min(x->id, y->id), std::max(x->id, y->id));
        continue;
      }
      const Entry *firstB = entriesB_.data() + startB_[c];
      const Entry *lastB = entriesB_.data() + startB_[c + 1];
      for (const Entry *x = firstA; x != lastA; ++x)
        for (const Entry *y = firstB; y != lastB; ++y)
          if (x->box.overlaps(y->box) && startsHere(x->box, y->box))
            found(x->id, y->id);
    }
  }

private:
  /// The cell of coordinate x on axis k. Every coordinate asked for is at
  /// least lo_[k] (a box's, or the larger of two boxes' low corners), so
  /// truncation floors it (std::floor was a library call: a third of the
  /// pair tests' time).
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
            std::vector<int64_t> &start, std::vector<Entry> &entries) const {
    start.assign(static_cast<size_t>(cells) + 1, 0);
    for (const Box &box : boxes)
      forCells(box, [&](int64_t c) { ++start[c + 1]; });
    for (size_t c = 1; c < start.size(); ++c)
      start[c] += start[c - 1];
    entries.resize(static_cast<size_t>(start.back()));
    std::vector<int64_t> next(start.begin(), start.end() - 1);
    for (int32_t i = 0; i < static_cast<int32_t>(boxes.size()); ++i)
      forCells(boxes[i], [&](int64_t c) {
        entries[next[c]++] = Entry{boxes[i], i};
      });
  }

  std::array<double, 3> lo_;
  std::array<int64_t, 3> dims_{1, 1, 1};
  double inverseCell_ = 1;
  std::vector<int64_t> startA_, startB_;
  std::vector<Entry> entriesA_, entriesB_;
};

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
      pool, PairGrid(pointBoxes, nullptr),
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
      pool, PairGrid(edgeBoxes, &pointBoxes),
      [](int32_t, int32_t) { return true; }, pairs);
  for (auto [e, j] : pairs)
    out.edgeVertex.push_back({codimEdges[e], points[j]});
}

} // namespace

Candidates sweptCandidates(const SurfaceMesh &mesh, Positions v0, Positions v1,
                           double inflation, ThreadPool *pool) {
  if (v0.count != mesh.numVertices() || v1.count != mesh.numVertices())
    throw std::invalid_argument(
        "sweptCandidates: positions of " + std::to_string(v0.count) + " and " +
        std::to_string(v1.count) + " vertices for a " + "mesh of " +
        std::to_string(mesh.numVertices()));
  checkFinite(v0, "sweptCandidates");
  checkFinite(v1, "sweptCandidates");
  std::vector<Box> vertices = vertexBoxes(v0, v1, inflation);
  std::vector<Box> edges = elementBoxes(mesh.edges(), vertices);
  std::vector<Box> faces = elementBoxes(mesh.faces(), vertices);
  Candidates out;
  gridPairs(
      pool, PairGrid(faces, &vertices),
      [&](int32_t f, int32_t v) {
        const auto &corners = mesh.faces()[f];
        return v != corners[0] && v != corners[1] && v != corners[2];
      },
      out.faceVertex);
  gridPairs(
      pool, PairGrid(edges, nullptr),
      [&](int32_t a, int32_t b) {
        const auto &x = mesh.edges()[a], &y = mesh.edges()[b];
        return x[0] != y[0] && x[0] != y[1] && x[1] != y[0] && x[1] != y[1];
      },
      out.edgeEdge);
  codimCandidates(mesh, vertices, edges, pool, out);
  return out;
}

} // namespace yasps::runtime::contact
