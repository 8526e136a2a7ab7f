//===- SurfaceMesh.cpp - the primitives that can touch --------------------===//

#include "yasps/Runtime/Contact/SurfaceMesh.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

namespace yasps::runtime::contact {

namespace {

uint64_t edgeKey(int32_t a, int32_t b) {
  if (a > b)
    std::swap(a, b);
  return (static_cast<uint64_t>(static_cast<uint32_t>(a)) << 32) |
         static_cast<uint32_t>(b);
}

void checkVertex(int64_t v, int64_t count, const char *what) {
  if (v < 0 || v >= count)
    throw std::invalid_argument(std::string("SurfaceMesh: ") + what +
                                " index vertex " + std::to_string(v) +
                                " outside 0.." + std::to_string(count - 1));
}

} // namespace

void checkFinite(Positions v, const char *what) {
  for (int64_t i = 0; i < 3 * v.count; ++i)
    if (!std::isfinite(v.data[i]))
      throw std::invalid_argument(
          std::string(what) + ": vertex " + std::to_string(i / 3) +
          " has a non-finite coordinate (" + std::to_string(v.data[i]) + ")");
}

SurfaceMesh::SurfaceMesh(int64_t numVertices,
                         std::vector<std::array<int32_t, 2>> edges,
                         std::vector<std::array<int32_t, 3>> faces,
                         Positions rest)
    : numVertices_(numVertices), edges_(std::move(edges)),
      faces_(std::move(faces)) {
  if (rest.count != numVertices)
    throw std::invalid_argument("SurfaceMesh: " + std::to_string(rest.count) +
                                " rest positions for " +
                                std::to_string(numVertices) + " vertices");
  // The rest lengths scale the edge-edge mollifier.
  checkFinite(rest, "SurfaceMesh (rest positions)");
  std::unordered_map<uint64_t, int32_t> edgeIds;
  edgeIds.reserve(edges_.size());
  restLength2_.reserve(edges_.size());
  for (size_t e = 0; e < edges_.size(); ++e) {
    auto [a, b] = edges_[e];
    checkVertex(a, numVertices, "an edge");
    checkVertex(b, numVertices, "an edge");
    edgeIds.emplace(edgeKey(a, b), static_cast<int32_t>(e));
    restLength2_.push_back(squaredNorm(rest[a] - rest[b]));
  }
  std::vector<bool> onEdge(numVertices, false), onFace(edges_.size(), false);
  for (const auto &[a, b] : edges_)
    onEdge[a] = onEdge[b] = true;
  faceEdges_.reserve(faces_.size());
  for (const auto &face : faces_) {
    std::array<int32_t, 3> sides{};
    for (int k = 0; k < 3; ++k) {
      checkVertex(face[k], numVertices, "a face");
      auto found = edgeIds.find(edgeKey(face[k], face[(k + 1) % 3]));
      if (found == edgeIds.end())
        throw std::invalid_argument(
            "SurfaceMesh: a face side (" + std::to_string(face[k]) + ", " +
            std::to_string(face[(k + 1) % 3]) + ") is not among the edges");
      sides[k] = found->second;
      onFace[found->second] = true;
    }
    faceEdges_.push_back(sides);
  }
  for (int32_t v = 0; v < numVertices; ++v)
    if (!onEdge[v])
      codimVertices_.push_back(v);
  for (int32_t e = 0; e < static_cast<int32_t>(edges_.size()); ++e)
    if (!onFace[e])
      codimEdges_.push_back(e);
}

} // namespace yasps::runtime::contact
