//===- ContactBindings.cpp - the runtime's narrow phase and CCD -----------===//
//
// Positions cross as (N, 3) C-ordered f64 arrays read in place; pairs come
// back as NumPy arrays per pair kind, ready for the dynamic primitives.
// `threads` picks the pool as for the Newton system (0: the default one);
// results do not depend on it.
//
//===----------------------------------------------------------------------===//

#include "ContactBindings.h"
#include "ThreadPools.h"

#include "yasps/Runtime/Contact/AdditiveCcd.h"
#include "yasps/Runtime/Contact/CollisionSet.h"

#include <nanobind/ndarray.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <stdexcept>
#include <string>

namespace nb = nanobind;
using namespace ::yasps::runtime::contact;

namespace {

using PositionArray =
    nb::ndarray<const double, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
template <typename T>
using IndexArray =
    nb::ndarray<const T, nb::ndim<2>, nb::c_contig, nb::device::cpu>;

Positions positions(const PositionArray &v, const char *what) {
  if (v.shape(1) != 3)
    throw std::invalid_argument(
        std::string(what) + ": positions must be (N, 3), got (" +
        std::to_string(v.shape(0)) + ", " + std::to_string(v.shape(1)) + ")");
  return {v.data(), static_cast<int64_t>(v.shape(0))};
}

template <size_t N>
std::vector<std::array<int32_t, N>> rows(const IndexArray<int32_t> &a,
                                         const char *what) {
  if (a.shape(0) > 0 && a.shape(1) != N)
    throw std::invalid_argument(std::string("ContactMesh: ") + what +
                                " must have " + std::to_string(N) + " columns");
  std::vector<std::array<int32_t, N>> out(a.shape(0));
  for (size_t i = 0; i < a.shape(0); ++i)
    for (size_t k = 0; k < N; ++k)
      out[i][k] = a(i, k);
  return out;
}

/// A vector handed to NumPy without a copy: the array owns it.
template <typename T>
nb::ndarray<nb::numpy, T> toNumpy(std::vector<T> &&values, size_t rows,
                                  size_t cols) {
  auto *owned = new std::vector<T>(std::move(values));
  nb::capsule owner(
      owned, [](void *p) noexcept { delete static_cast<std::vector<T> *>(p); });
  size_t shape[2] = {rows, cols};
  return nb::ndarray<nb::numpy, T>(owned->data(), cols ? 2 : 1, shape, owner);
}

nb::ndarray<nb::numpy, int32_t>
pairsOf(const std::vector<std::array<int32_t, 2>> &pairs) {
  std::vector<int32_t> flat;
  flat.reserve(2 * pairs.size());
  for (const auto &[a, b] : pairs)
    flat.insert(flat.end(), {a, b});
  return toNumpy(std::move(flat), pairs.size(), 2);
}

} // namespace

void yasps::python::bindContact(nb::module_ &m) {
  nb::class_<SurfaceMesh>(m, "ContactMesh",
                          "The contact surface: vertices, edges (every face "
                          "side among them) and faces, with rest positions.")
      .def(
          "__init__",
          [](SurfaceMesh *self, const PositionArray &rest,
             const IndexArray<int32_t> &edges,
             const IndexArray<int32_t> &faces) {
            Positions r = positions(rest, "ContactMesh");
            new (self) SurfaceMesh(r.count, rows<2>(edges, "edges"),
                                   rows<3>(faces, "faces"), r);
          },
          nb::arg("rest"), nb::arg("edges"), nb::arg("faces"))
      .def_prop_ro("num_vertices", &SurfaceMesh::numVertices);

  nb::class_<Candidates>(m, "ContactCandidates",
                         "The candidate pairs of a broad phase.")
      .def_prop_ro(
          "face_vertex",
          [](const Candidates &c) { return pairsOf(c.faceVertex); },
          nb::rv_policy::move, "(face, vertex) rows")
      .def_prop_ro(
          "edge_edge", [](const Candidates &c) { return pairsOf(c.edgeEdge); },
          nb::rv_policy::move, "(edge, edge) rows")
      .def_prop_ro(
          "vertex_vertex",
          [](const Candidates &c) { return pairsOf(c.vertexVertex); },
          nb::rv_policy::move, "(vertex, vertex) rows of codimensional points")
      .def_prop_ro(
          "edge_vertex",
          [](const Candidates &c) { return pairsOf(c.edgeVertex); },
          nb::rv_policy::move,
          "(edge, vertex) rows of codimensional edges and points")
      .def("__len__", &Candidates::size);

  m.def(
      "contact_candidates",
      [](const SurfaceMesh &mesh, const PositionArray &v0,
         const PositionArray &v1, double inflation, unsigned threads) {
        return sweptCandidates(mesh, positions(v0, "contact_candidates"),
                               positions(v1, "contact_candidates"), inflation,
                               &yasps::python::poolFor(threads));
      },
      nb::arg("mesh"), nb::arg("v0"), nb::arg("v1"), nb::arg("inflation"),
      nb::arg("threads") = 0,
      "The pairs whose boxes, swept over v0 -> v1 and grown by inflation, "
      "overlap");

  m.def(
      "contact_collision_set",
      [](const SurfaceMesh &mesh, const Candidates &candidates,
         const PositionArray &v, double dhat, unsigned threads) {
        Positions at = positions(v, "contact_collision_set");
        if (at.count != mesh.numVertices())
          throw std::invalid_argument("contact_collision_set: positions of " +
                                      std::to_string(at.count) +
                                      " vertices for a mesh of " +
                                      std::to_string(mesh.numVertices()));
        CollisionSet set = buildCollisionSet(mesh, candidates, at, dhat,
                                             &yasps::python::poolFor(threads));
        nb::list kinds;
        for (int k = 0; k < kNumPairKinds; ++k) {
          PairList &list = set.pairs[k];
          size_t n = list.size();
          kinds.append(nb::make_tuple(
              toNumpy(std::move(list.vertices), n, kPairArity[k]),
              toNumpy(std::move(list.epsX), n, 0),
              toNumpy(std::move(list.weight), n, 0)));
        }
        return nb::make_tuple(kinds, set.minDistance2);
      },
      nb::arg("mesh"), nb::arg("candidates"), nb::arg("v"), nb::arg("dhat"),
      nb::arg("threads") = 0,
      "IPC's collision set among the candidates at v: ([(vertices, eps_x, "
      "weight)] per pair kind in PAIR_TYPES' order, smallest squared "
      "distance)");

  m.def(
      "contact_step_bound",
      [](const SurfaceMesh &mesh, const Candidates &candidates,
         const PositionArray &v0, const PositionArray &v1, double minDistance,
         unsigned threads) {
        Positions a = positions(v0, "contact_step_bound");
        Positions b = positions(v1, "contact_step_bound");
        if (a.count != mesh.numVertices() || b.count != mesh.numVertices())
          throw std::invalid_argument("contact_step_bound: positions do not "
                                      "match the mesh's vertices");
        StepBound bound = additiveStepBound(mesh, candidates, a, b, minDistance,
                                            kAdditiveCcdRescaling,
                                            &yasps::python::poolFor(threads));
        return std::make_tuple(bound.fraction, bound.minDistance2);
      },
      nb::arg("mesh"), nb::arg("candidates"), nb::arg("v0"), nb::arg("v1"),
      nb::arg("min_distance"), nb::arg("threads") = 0,
      "(the largest fraction of v0 -> v1 keeping the candidates min_distance "
      "apart, by the additive CCD; their smallest squared distance at v0)");
}
