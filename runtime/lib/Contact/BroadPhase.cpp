//===- BroadPhase.cpp - pairs whose swept boxes overlap -------------------===//

#include "yasps/Runtime/Contact/BroadPhase.h"

#include "Blocks.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace yasps::runtime::contact {

namespace {

struct Box {
  std::array<double, 3> lo, hi;

  void grow(const Box &other) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], other.lo[k]);
      hi[k] = std::max(hi[k], other.hi[k]);
    }
  }
  bool overlaps(const Box &other) const {
    for (int k = 0; k < 3; ++k)
      if (lo[k] > other.hi[k] || other.lo[k] > hi[k])
        return false;
    return true;
  }
};

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

/// A uniform grid over boxes: each box is listed in every cell it touches
/// (cells as wide as the boxes are on average, so each box touches few),
/// and a query visits the boxes listed in the cells its own box touches.
/// Unlike a sweep along one axis it stays local on flat, spread-out
/// surfaces such as cloth.
class BoxGrid {
public:
  explicit BoxGrid(const std::vector<Box> &boxes) : boxes_(boxes) {
    lo_.fill(1e300);
    std::array<double, 3> hi;
    hi.fill(-1e300);
    double width = 0;
    for (const Box &box : boxes) {
      for (int k = 0; k < 3; ++k) {
        lo_[k] = std::min(lo_[k], box.lo[k]);
        hi[k] = std::max(hi[k], box.hi[k]);
        width += box.hi[k] - box.lo[k];
      }
    }
    if (boxes.empty())
      return;
    double cell = std::max(width / (3.0 * boxes.size()), 1e-300);
    // At most a few cells per box: a larger cell where the boxes are few
    // and the scene is wide.
    const double maxCells = 8.0 * boxes.size() + 64;
    for (;;) {
      double cells = 1;
      for (int k = 0; k < 3; ++k) {
        dims_[k] = std::max(1.0, std::ceil((hi[k] - lo_[k]) / cell));
        cells *= dims_[k];
      }
      if (cells <= maxCells)
        break;
      cell *= 2;
    }
    inverseCell_ = 1.0 / cell;
    start_.assign(static_cast<size_t>(dims_[0] * dims_[1] * dims_[2]) + 1, 0);
    for (const Box &box : boxes)
      forCells(box, [&](int64_t c) { ++start_[c + 1]; });
    for (size_t c = 1; c < start_.size(); ++c)
      start_[c] += start_[c - 1];
    items_.resize(start_.back());
    std::vector<int64_t> fill(start_.begin(), start_.end() - 1);
    for (int32_t i = 0; i < static_cast<int32_t>(boxes.size()); ++i)
      forCells(boxes[i], [&](int64_t c) { items_[fill[c]++] = i; });
  }

  /// Calls visit(i) for each box i listed in a cell that `box` touches (a
  /// box touching several of those cells comes once per cell).
  template <typename Visit> void query(const Box &box, Visit &&visit) const {
    if (items_.empty())
      return;
    forCells(box, [&](int64_t c) {
      for (int64_t at = start_[c]; at < start_[c + 1]; ++at)
        visit(items_[at]);
    });
  }

private:
  int64_t cellOf(double x, int k) const {
    double at = std::floor((x - lo_[k]) * inverseCell_);
    return static_cast<int64_t>(std::clamp(at, 0.0, dims_[k] - 1.0));
  }

  template <typename Visit> void forCells(const Box &box, Visit &&visit) const {
    int64_t from[3], to[3];
    for (int k = 0; k < 3; ++k) {
      from[k] = cellOf(box.lo[k], k);
      to[k] = cellOf(box.hi[k], k);
    }
    int64_t nx = static_cast<int64_t>(dims_[0]);
    int64_t ny = static_cast<int64_t>(dims_[1]);
    for (int64_t z = from[2]; z <= to[2]; ++z)
      for (int64_t y = from[1]; y <= to[1]; ++y)
        for (int64_t x = from[0]; x <= to[0]; ++x)
          visit((z * ny + y) * nx + x);
  }

  const std::vector<Box> &boxes_;
  std::array<double, 3> lo_;
  std::array<double, 3> dims_{1, 1, 1};
  double inverseCell_ = 1;
  std::vector<int64_t> start_;
  std::vector<int32_t> items_;
};

/// Runs block(begin, end, found) over [0, count) in ordered blocks and
/// appends what each found to `out`, in block order.
template <typename Block>
void inBlocks(ThreadPool *pool, int64_t count, Block &&block,
              std::vector<std::array<int32_t, 2>> &out) {
  // A block of primitives costs a few microseconds at least.
  int64_t blocks = blockCount(pool, count, 256);
  std::vector<std::vector<std::array<int32_t, 2>>> found(blocks);
  forBlocks(pool, count, blocks, [&](int64_t b, int64_t begin, int64_t end) {
    block(static_cast<int32_t>(begin), static_cast<int32_t>(end), found[b]);
  });
  for (auto &part : found)
    out.insert(out.end(), part.begin(), part.end());
}

/// The codimensional points against each other and against the
/// codimensional edges (ipctk's extra candidates for points and rods). A
/// codimensional point is on no edge, so no pair shares a vertex.
void codimCandidates(const SurfaceMesh &mesh, const std::vector<Box> &vertices,
                     const std::vector<Box> &edges, Candidates &out) {
  const std::vector<int32_t> &points = mesh.codimVertices();
  if (points.empty())
    return;
  std::vector<Box> pointBoxes;
  pointBoxes.reserve(points.size());
  for (int32_t v : points)
    pointBoxes.push_back(vertices[v]);
  BoxGrid grid(pointBoxes);
  std::vector<int32_t> seen(points.size(), -1);
  for (int32_t i = 0; i < static_cast<int32_t>(points.size()); ++i)
    grid.query(pointBoxes[i], [&](int32_t j) {
      if (j <= i || seen[j] == i)
        return;
      seen[j] = i;
      if (pointBoxes[i].overlaps(pointBoxes[j]))
        out.vertexVertex.push_back({points[i], points[j]});
    });
  seen.assign(points.size(), -1);
  for (int32_t e : mesh.codimEdges())
    grid.query(edges[e], [&](int32_t j) {
      if (seen[j] == e)
        return;
      seen[j] = e;
      if (edges[e].overlaps(pointBoxes[j]))
        out.edgeVertex.push_back({e, points[j]});
    });
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
  BoxGrid vertexGrid(vertices);
  BoxGrid edgeGrid(edges);

  // Each face against the vertices in its cells; a stamp per vertex keeps
  // a vertex met in several cells from coming twice.
  auto faceBlock = [&](int32_t begin, int32_t end, auto &found) {
    std::vector<int32_t> seen(vertices.size(), -1);
    for (int32_t f = begin; f < end; ++f) {
      const auto &corners = mesh.faces()[f];
      vertexGrid.query(faces[f], [&](int32_t v) {
        if (seen[v] == f || v == corners[0] || v == corners[1] ||
            v == corners[2])
          return;
        seen[v] = f;
        if (faces[f].overlaps(vertices[v]))
          found.push_back({f, v});
      });
    }
  };
  // Each edge against the edges after it in its cells.
  auto edgeBlock = [&](int32_t begin, int32_t end, auto &found) {
    std::vector<int32_t> seen(edges.size(), -1);
    for (int32_t a = begin; a < end; ++a) {
      const auto &ends = mesh.edges()[a];
      edgeGrid.query(edges[a], [&](int32_t b) {
        if (b <= a || seen[b] == a)
          return;
        seen[b] = a;
        const auto &other = mesh.edges()[b];
        if (ends[0] == other[0] || ends[0] == other[1] || ends[1] == other[0] ||
            ends[1] == other[1])
          return;
        if (edges[a].overlaps(edges[b]))
          found.push_back({a, b});
      });
    }
  };
  inBlocks(pool, static_cast<int64_t>(faces.size()), faceBlock, out.faceVertex);
  inBlocks(pool, static_cast<int64_t>(edges.size()), edgeBlock, out.edgeEdge);
  codimCandidates(mesh, vertices, edges, out);
  return out;
}

} // namespace yasps::runtime::contact
