//===- RuntimeModule.cpp - Python bindings over the yasps runtime ---------===//
//
// The extension module `_yasps_runtime`: the C++ runtime without the
// compiler (it links no MLIR). The Newton system and its solver, local
// Hessian compression, contact's narrow phase and CCD
// (ContactBindings.cpp), and the CUDA backend (GpuRuntimeBindings.cpp).
//
//===----------------------------------------------------------------------===//

#include "ContactBindings.h"
#include "ErrorTranslation.h"
#include "GpuRuntimeBindings.h"
#include "KernelBindings.h"
#include "PcgBindings.h"
#include "ThreadPools.h"

#include "yasps/Runtime/Assembly/GlobalSystem.h"
#include "yasps/Runtime/Assembly/LocalCompression.h"
#include "yasps/Runtime/Sparse/PcgSolver.h"

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace nb = nanobind;

namespace {

/// The global Newton system of a scene, over the C++ runtime.
class PySystem {
public:
  using Int64Array = nb::ndarray<int64_t, nb::c_contig, nb::device::cpu>;
  using DoubleArray = nb::ndarray<double, nb::c_contig, nb::device::cpu>;
  using FloatArray = nb::ndarray<float, nb::c_contig, nb::device::cpu>;

  /// The runtime reads the DoF maps in place, from the caller's arrays
  /// (converted once by nanobind only if they are not C-ordered int64),
  /// which the system holds on to.
  PySystem(Int64Array blockOffsets, std::vector<Int64Array> dofMaps) {
    ::yasps::runtime::BlockLayout layout;
    layout.blockOffset.assign(blockOffsets.data(),
                              blockOffsets.data() + blockOffsets.size());
    system =
        std::make_unique<::yasps::runtime::GlobalSystem>(layout, view(dofMaps));
    staticMaps = std::move(dofMaps);
  }

  /// Replaces the dynamic energies (numbered after the static ones).
  void setDynamic(std::vector<Int64Array> dofMaps) {
    system->setDynamic(view(dofMaps));
    dynamicMaps = std::move(dofMaps);
  }

  int64_t size() const { return system->size(); }
  const ::yasps::runtime::GlobalSystem &runtime() const { return *system; }
  size_t storedBlocks() const {
    return system->staticHessian().numStoredBlocks() +
           system->dynamicHessian().numStoredBlocks();
  }
  void setZero() { system->setZero(); }
  void finishAssembly() { system->finishAssembly(); }
  bool singleProduct() const { return system->singleProduct(); }
  void setSingleProduct(bool on) { system->setSingleProduct(on); }

  /// add() of f64 or f32 local derivatives (Array: DoubleArray or
  /// FloatArray).
  template <typename Array>
  void add(size_t energy, Array gradients, Array hessians, unsigned threads) {
    if (energy >= system->numEnergies())
      throw std::invalid_argument("no energy " + std::to_string(energy));
    auto [count, n] = shape(energy);
    if (gradients.size() != size_t(count * n) ||
        hessians.size() != size_t(count * n * n))
      throw std::invalid_argument(
          "energy " + std::to_string(energy) + " expects " +
          std::to_string(count) + " gradients of " + std::to_string(n) +
          " and Hessians of " + std::to_string(n) + "x" + std::to_string(n));
    nb::gil_scoped_release release;
    system->add(energy, gradients.data(), hessians.data(),
                &::yasps::python::poolFor(threads));
  }

  void addToInstances(size_t energy, Int64Array instances,
                      DoubleArray hessians) {
    if (energy >= system->numEnergies())
      throw std::invalid_argument("no energy " + std::to_string(energy));
    auto [count, n] = shape(energy);
    (void)count;
    const size_t k = instances.size();
    if (hessians.size() != k * size_t(n * n))
      throw std::invalid_argument(
          "energy " + std::to_string(energy) + " expects " + std::to_string(k) +
          " Hessians of " + std::to_string(n) + "x" + std::to_string(n) +
          " for its " + std::to_string(k) + " instances");
    nb::gil_scoped_release release;
    system->addToInstances(energy, instances.data(), int64_t(k),
                           hessians.data());
  }

  void addFactored(size_t energy, DoubleArray gradients, DoubleArray maps,
                   DoubleArray inner, int64_t m, unsigned threads) {
    if (energy >= system->numEnergies())
      throw std::invalid_argument("no energy " + std::to_string(energy));
    auto [count, n] = shape(energy);
    if (gradients.size() != size_t(count * n) ||
        maps.size() != size_t(count * m * n) ||
        inner.size() != size_t(count * m * m))
      throw std::invalid_argument(
          "energy " + std::to_string(energy) + " expects " +
          std::to_string(count) + " gradients of " + std::to_string(n) +
          ", inner maps of " + std::to_string(m) + "x" + std::to_string(n) +
          " and inner Hessians of " + std::to_string(m) + "x" +
          std::to_string(m));
    nb::gil_scoped_release release;
    system->addFactored(energy, gradients.data(), maps.data(), inner.data(), m,
                        &::yasps::python::poolFor(threads));
  }

  /// add_slot_factored: `tables` are (instances, rows, cols) Jacobians,
  /// `slots` (S, 3) rows of (inner start, inner stride, column) and
  /// `sources` (count, S, 2) pairs of (table, instance), table -1: none.
  void addSlotFactored(size_t energy, DoubleArray gradients, DoubleArray inner,
                       int64_t m, std::vector<DoubleArray> tables,
                       Int64Array slots, Int64Array sources, unsigned threads) {
    if (energy >= system->numEnergies())
      throw std::invalid_argument("no energy " + std::to_string(energy));
    auto [count, n] = shape(energy);
    ::yasps::runtime::SlotFactors factors;
    factors.numInner = m;
    for (DoubleArray &t : tables) {
      if (t.ndim() != 3)
        throw std::invalid_argument(
            "a Jacobian table must be (instances, rows, cols)");
      factors.tables.push_back({t.data(), int64_t(t.shape(0)),
                                int64_t(t.shape(1)), int64_t(t.shape(2))});
    }
    if (slots.ndim() != 2 || slots.shape(1) != 3)
      throw std::invalid_argument("slots must be (S, 3)");
    int64_t numSlots = int64_t(slots.shape(0));
    for (int64_t s = 0; s < numSlots; ++s)
      factors.slots.push_back({slots.data()[3 * s], slots.data()[3 * s + 1],
                               slots.data()[3 * s + 2]});
    if (gradients.size() != size_t(count * m) ||
        inner.size() != size_t(count * m * m) ||
        sources.size() != size_t(count * numSlots * 2))
      throw std::invalid_argument(
          "energy " + std::to_string(energy) + " expects " +
          std::to_string(count) + " inner gradients of " + std::to_string(m) +
          ", inner Hessians of " + std::to_string(m) + "x" + std::to_string(m) +
          " and " + std::to_string(numSlots) + " slot sources each");
    factors.sources = sources.data();
    nb::gil_scoped_release release;
    system->addSlotFactored(energy, gradients.data(), inner.data(), factors,
                            &::yasps::python::poolFor(threads));
  }

  void gradient(DoubleArray out) const {
    check(out, size_t(size()));
    std::copy(system->gradient().begin(), system->gradient().end(), out.data());
  }

  void dense(DoubleArray out) const {
    check(out, size_t(size() * size()));
    std::vector<double> d = system->toDense();
    std::copy(d.begin(), d.end(), out.data());
  }

  using MaskArray =
      nb::ndarray<uint8_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

  ::yasps::runtime::PcgResult
  solve(DoubleArray out, double tolerance, int64_t maxIterations,
        unsigned threads, std::optional<MaskArray> fixed,
        ::yasps::runtime::PcgStopping stopping,
        ::yasps::runtime::PcgPreconditioner preconditioner) {
    check(out, size_t(size()));
    ::yasps::runtime::PcgOptions options;
    options.preconditioner = preconditioner;
    options.relativeTolerance = tolerance;
    options.maxIterations = maxIterations;
    options.stopping = stopping;
    std::vector<uint8_t> mask;
    if (fixed) {
      mask.assign(fixed->data(), fixed->data() + fixed->shape(0));
      options.fixedDofs = &mask;
    }
    ::yasps::runtime::PcgResult result;
    {
      nb::gil_scoped_release release;
      result =
          solver->solve(system->hessianParts(), system->gradient().data(),
                        out.data(), options, ::yasps::python::poolFor(threads));
    }
    return result;
  }

  /// Scalar entries of the Hessian (both triangles, both parts; an entry
  /// of both parts counts twice).
  int64_t nonZeros() const {
    int64_t count = 0;
    for (const auto *H : system->hessianParts())
      for (size_t b = 0; b < H->numStoredBlocks(); ++b) {
        int64_t r = H->blockRow(b), c = H->blockCol(b);
        int64_t entries = H->layout().blockSize(r) * H->layout().blockSize(c);
        count += r == c ? entries : 2 * entries;
      }
    return count;
  }

  /// The Hessian in coordinate form, into arrays of nonZeros() entries
  /// (duplicates, from the two parts, are to be summed).
  void coordinates(Int64Array rows, Int64Array cols, DoubleArray values) const {
    size_t nnz = size_t(nonZeros());
    if (rows.size() != nnz || cols.size() != nnz)
      throw std::invalid_argument("coordinate arrays need " +
                                  std::to_string(nnz) + " entries");
    check(values, nnz);
    size_t k = 0;
    for (const auto *H : system->hessianParts()) {
      const auto &offset = H->layout().blockOffset;
      for (size_t b = 0; b < H->numStoredBlocks(); ++b) {
        int64_t r = H->blockRow(b), c = H->blockCol(b);
        int64_t nr = H->layout().blockSize(r), nc = H->layout().blockSize(c);
        const double *data = H->blockData(b);
        for (int64_t i = 0; i < nr; ++i)
          for (int64_t j = 0; j < nc; ++j) {
            rows.data()[k] = offset[r] + i;
            cols.data()[k] = offset[c] + j;
            values.data()[k++] = data[i * nc + j];
            if (r != c) {
              rows.data()[k] = offset[c] + j;
              cols.data()[k] = offset[r] + i;
              values.data()[k++] = data[i * nc + j];
            }
          }
      }
    }
  }

  /// y = H x with the runtime's SpMV.
  void multiply(DoubleArray x, DoubleArray y, unsigned threads) const {
    check(x, size_t(size()));
    check(y, size_t(size()));
    nb::gil_scoped_release release;
    system->multiply(x.data(), y.data(), ::yasps::python::poolFor(threads));
  }

private:
  static void check(const DoubleArray &out, size_t size) {
    if (out.size() != size)
      throw std::invalid_argument("output array of " +
                                  std::to_string(out.size()) +
                                  " entries, expected " + std::to_string(size));
  }
  /// The runtime's view of (count, params) DoF maps.
  static std::vector<::yasps::runtime::DofMap>
  view(const std::vector<Int64Array> &dofMaps) {
    std::vector<::yasps::runtime::DofMap> maps;
    for (const Int64Array &map : dofMaps) {
      if (map.ndim() != 2)
        throw std::invalid_argument("a DoF map must be (count, params)");
      maps.push_back(
          {(int64_t)map.shape(0), (int64_t)map.shape(1), map.data()});
    }
    return maps;
  }
  std::pair<int64_t, int64_t> shape(size_t energy) const {
    bool isStatic = energy < staticMaps.size();
    const Int64Array &map =
        isStatic ? staticMaps[energy] : dynamicMaps[energy - staticMaps.size()];
    return {(int64_t)map.shape(0), (int64_t)map.shape(1)};
  }
  std::vector<Int64Array> staticMaps, dynamicMaps;
  std::unique_ptr<::yasps::runtime::GlobalSystem> system;
  /// Solves this system, keeping its multilevel preconditioner from one
  /// Newton iteration to the next.
  std::unique_ptr<::yasps::runtime::PcgSolver> solver =
      std::make_unique<::yasps::runtime::PcgSolver>();
};

/// A NumPy array that owns `values`.
template <typename T>
nb::ndarray<nb::numpy, T> ownedArray(std::vector<T> &&values,
                                     std::vector<size_t> shape) {
  auto *heap = new std::vector<T>(std::move(values));
  nb::capsule owner(
      heap, [](void *p) noexcept { delete static_cast<std::vector<T> *>(p); });
  return nb::ndarray<nb::numpy, T>(heap->data(), shape.size(), shape.data(),
                                   owner);
}

using DofArray =
    nb::ndarray<int64_t, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
using MatrixBatch =
    nb::ndarray<double, nb::ndim<3>, nb::c_contig, nb::device::cpu>;

/// The local Hessians compressed by DoF (paper 7.2), grouped by size: a
/// list of (k, instances, matrices (m, k, k)).
nb::list compressLocalHessians(DofArray dofs, MatrixBatch hessians) {
  int64_t count = dofs.shape(0), n = dofs.shape(1);
  if (hessians.shape(0) != size_t(count) || hessians.shape(1) != size_t(n) ||
      hessians.shape(2) != size_t(n))
    throw std::invalid_argument("hessians must be (count, n, n) for DoF maps "
                                "of (count, n)");
  std::vector<::yasps::runtime::CompressedBatch> batches;
  {
    nb::gil_scoped_release release;
    batches = ::yasps::runtime::compressLocalHessians(count, n, dofs.data(),
                                                      hessians.data());
  }
  nb::list out;
  for (auto &batch : batches) {
    size_t m = batch.instances.size(), k = size_t(batch.size);
    out.append(
        nb::make_tuple(batch.size, ownedArray(std::move(batch.instances), {m}),
                       ownedArray(std::move(batch.matrices), {m, k, k})));
  }
  return out;
}

/// The compressed size of every instance of a DoF map (count, n).
nb::ndarray<nb::numpy, int64_t> compressedSizes(DofArray dofs) {
  int64_t count = dofs.shape(0), n = dofs.shape(1);
  std::vector<int64_t> sizes(static_cast<size_t>(count));
  for (int64_t i = 0; i < count; ++i)
    sizes[i] = ::yasps::runtime::compressedSize(n, dofs.data() + i * n);
  return ownedArray(std::move(sizes), {size_t(count)});
}

/// Writes projected compressed matrices back to (count, n, n) `out`.
void expandLocalHessians(
    DofArray dofs, int64_t k,
    nb::ndarray<int64_t, nb::ndim<1>, nb::c_contig, nb::device::cpu> instances,
    MatrixBatch projected, MatrixBatch out) {
  int64_t count = dofs.shape(0), n = dofs.shape(1);
  if (out.shape(0) != size_t(count) || out.shape(1) != size_t(n) ||
      out.shape(2) != size_t(n) || projected.shape(0) != instances.shape(0) ||
      projected.shape(1) != size_t(k) || projected.shape(2) != size_t(k))
    throw std::invalid_argument("expand_local_hessians: inconsistent shapes");
  ::yasps::runtime::CompressedBatch batch;
  batch.size = k;
  batch.instances.assign(instances.data(),
                         instances.data() + instances.shape(0));
  ::yasps::runtime::expandLocalHessians(count, n, dofs.data(), batch,
                                        projected.data(), out.data());
}

} // namespace

NB_MODULE(_yasps_runtime, m) {
  m.doc() = "Bindings over the yasps runtime: the Newton system, local "
            "Hessian compression and the CUDA backend (no compiler).";

  ::yasps::python::translateRuntimeErrors();
  ::yasps::python::bindPcg(m);
  ::yasps::python::bindKernelLaunch(m);
  ::yasps::python::bindContact(m);
  ::yasps::python::bindGpuRuntime(m);
  nb::class_<PySystem>(m, "GlobalSystem",
                       "The block-sparse Newton system of a scene.")
      .def(nb::init<PySystem::Int64Array, std::vector<PySystem::Int64Array>>(),
           nb::arg("block_offsets"), nb::arg("dof_maps"))
      .def_prop_ro("size", &PySystem::size)
      .def("set_dynamic", &PySystem::setDynamic, nb::arg("dof_maps"),
           "Replaces the dynamic energies (numbered after the static ones) "
           "and rebuilds only their structure")
      .def("add_slot_factored", &PySystem::addSlotFactored, nb::arg("energy"),
           nb::arg("gradients"), nb::arg("inner"), nb::arg("m"),
           nb::arg("tables"), nb::arg("slots"), nb::arg("sources"),
           nb::arg("threads") = 0,
           "Adds an energy whose local Hessians are J^T P J with J taken "
           "slot by slot from shared Jacobian tables (instances, rows, "
           "cols): inner gradients (count, m), projected inner Hessians P "
           "(count, m, m), slots (S, 3) of (inner start, inner stride, "
           "column), sources (count, S, 2) of (table, instance), table -1 "
           "for none")
      .def("add_factored", &PySystem::addFactored, nb::arg("energy"),
           nb::arg("gradients"), nb::arg("maps"), nb::arg("inner"),
           nb::arg("m"), nb::arg("threads") = 0,
           "Adds an energy whose local Hessians are J^T P J, from the inner "
           "maps J (count, m, n) and projected inner Hessians P (count, m, "
           "m)")
      .def("set_zero", &PySystem::setZero)
      .def("finish_assembly", &PySystem::finishAssembly,
           "Ends an assembly: with single_product, takes the Hessian "
           "blocks' f32 copies that products then read")
      .def_prop_rw("single_product", &PySystem::singleProduct,
                   &PySystem::setSingleProduct,
                   "Whether multiply and solve read the Hessian's blocks "
                   "rounded to f32 (f64 vectors and arithmetic), from the "
                   "next finish_assembly on")
      .def("add", &PySystem::add<PySystem::DoubleArray>, nb::arg("energy"),
           nb::arg("gradients"), nb::arg("hessians"), nb::arg("threads") = 0,
           "Adds an energy's local gradients and Hessians (both f64, or "
           "both f32); with more than one thread, instances are split "
           "across threads (atomic adds)")
      .def("add", &PySystem::add<PySystem::FloatArray>, nb::arg("energy"),
           nb::arg("gradients"), nb::arg("hessians"), nb::arg("threads") = 0)
      .def("add_to_instances", &PySystem::addToInstances, nb::arg("energy"),
           nb::arg("instances"), nb::arg("hessians"),
           "Adds local Hessians (f64, k x n x n) to the k listed instances "
           "of an energy only, nothing to the gradient")
      .def("gradient", &PySystem::gradient, nb::arg("out"))
      .def("dense", &PySystem::dense, nb::arg("out"))
      .def_prop_ro("non_zeros", &PySystem::nonZeros)
      .def_prop_ro("stored_blocks",
                   [](const PySystem &self) { return self.storedBlocks(); })
      .def("coordinates", &PySystem::coordinates, nb::arg("rows"),
           nb::arg("cols"), nb::arg("values"))
      .def("multiply", &PySystem::multiply, nb::arg("x"), nb::arg("y"),
           nb::arg("threads") = 0)
      .def("solve", &PySystem::solve, nb::arg("out"), nb::arg("tolerance"),
           nb::arg("max_iterations"), nb::arg("threads") = 0,
           nb::arg("fixed") = nb::none(),
           nb::arg("stopping") = ::yasps::runtime::PcgStopping::Residual,
           nb::arg("preconditioner") =
               ::yasps::runtime::PcgPreconditioner::BlockJacobi,
           "PCG on H x = g into out; `fixed` (uint8 per DoF) excludes DoFs, "
           "whose solution is 0; returns a PcgReport");
  ::yasps::python::bindGpuSystem(
      m, [](nb::handle system) -> const ::yasps::runtime::GlobalSystem & {
        return nb::cast<const PySystem &>(system).runtime();
      });

  m.def("compress_local_hessians", &compressLocalHessians, nb::arg("dofs"),
        nb::arg("hessians"),
        "Local Hessians with repeated DoFs merged and padding dropped "
        "(paper 7.2), grouped by compressed size k: [(k, instances, "
        "matrices (m, k, k))]");
  m.def("compressed_sizes", &compressedSizes, nb::arg("dofs"),
        "Distinct DoFs >= 0 of each row of a DoF map (count, n)");
  m.def("expand_local_hessians", &expandLocalHessians, nb::arg("dofs"),
        nb::arg("k"), nb::arg("instances"), nb::arg("projected"),
        nb::arg("out"),
        "Writes compressed (projected) matrices back to (count, n, n), each "
        "entry at the first parameter of its DoF");
}
