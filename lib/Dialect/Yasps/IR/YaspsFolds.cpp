//===- YaspsFolds.cpp - folders of yasps expressions ----------------------===//
//
// Only folds that are obviously right: algebraic identities (x + 0, x * 1,
// transpose of transpose, ...) and constant evaluation of arithmetic on
// literal matrices, in IEEE arithmetic of the element type.
//
//===----------------------------------------------------------------------===//

#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "mlir/IR/Matchers.h"

using namespace mlir;
using namespace mlir::yasps;

namespace {
/// Dense row-major view of a constant matrix.
struct ConstMatrix {
  int64_t rows = 0, cols = 0;
  SmallVector<APFloat> values;

  const APFloat &at(int64_t r, int64_t c) const { return values[r * cols + c]; }
};
} // namespace

static std::optional<ConstMatrix> asConstMatrix(Attribute attr) {
  auto dense = dyn_cast_or_null<DenseFPElementsAttr>(attr);
  if (!dense || dense.getType().getRank() != 2)
    return std::nullopt;
  ConstMatrix m;
  m.rows = dense.getType().getDimSize(0);
  m.cols = dense.getType().getDimSize(1);
  m.values.assign(dense.getValues<APFloat>().begin(),
                  dense.getValues<APFloat>().end());
  return m;
}

static DenseFPElementsAttr toAttr(MatrixType type, ArrayRef<APFloat> values) {
  return cast<DenseFPElementsAttr>(
      DenseElementsAttr::get(type.getTensorType(), values));
}

/// True if `attr` is a constant matrix with every entry equal to `value`.
static bool isSplatOf(Attribute attr, double value) {
  auto dense = dyn_cast_or_null<DenseFPElementsAttr>(attr);
  if (!dense)
    return false;
  for (const APFloat &entry : dense.getValues<APFloat>()) {
    APFloat expected(value);
    bool losesInfo = false;
    expected.convert(entry.getSemantics(), APFloat::rmNearestTiesToEven,
                     &losesInfo);
    if (entry.compare(expected) != APFloat::cmpEqual)
      return false;
  }
  return true;
}

/// Whether every entry is a zero of the given sign: x + (-0) and x - (+0)
/// are x for every x, -0 included; x + (+0) is +0 for x = -0, so it is no
/// identity in IEEE arithmetic (upstream's arith folds alike).
static bool isSplatOfZero(Attribute attr, bool negative) {
  auto dense = dyn_cast_or_null<DenseFPElementsAttr>(attr);
  if (!dense)
    return false;
  for (const APFloat &entry : dense.getValues<APFloat>())
    if (!entry.isZero() || entry.isNegative() != negative)
      return false;
  return true;
}

static bool isIdentityMatrix(Value value, Attribute attr) {
  if (value.getDefiningOp<IdentityOp>())
    return true;
  std::optional<ConstMatrix> m = asConstMatrix(attr);
  if (!m || m->rows != m->cols)
    return false;
  for (int64_t r = 0; r < m->rows; ++r)
    for (int64_t c = 0; c < m->cols; ++c)
      if (!m->at(r, c).isExactlyValue(r == c ? 1.0 : 0.0))
        return false;
  return true;
}

using BinaryFn = function_ref<APFloat(const APFloat &, const APFloat &)>;

/// Entry-by-entry combination of two constants of the same shape, or of a
/// constant and a 1x1 constant (`rhsIsScalar`).
static Attribute foldEntrywise(MatrixType type, Attribute lhsAttr,
                               Attribute rhsAttr, BinaryFn fn,
                               bool rhsIsScalar = false) {
  std::optional<ConstMatrix> lhs = asConstMatrix(lhsAttr);
  std::optional<ConstMatrix> rhs = asConstMatrix(rhsAttr);
  if (!lhs || !rhs)
    return {};
  SmallVector<APFloat> out;
  for (size_t i = 0; i < lhs->values.size(); ++i)
    out.push_back(fn(lhs->values[i], rhs->values[rhsIsScalar ? 0 : i]));
  return toAttr(type, out);
}

static APFloat addFn(const APFloat &a, const APFloat &b) { return a + b; }
static APFloat subFn(const APFloat &a, const APFloat &b) { return a - b; }
static APFloat mulFn(const APFloat &a, const APFloat &b) { return a * b; }
static APFloat divFn(const APFloat &a, const APFloat &b) { return a / b; }

OpFoldResult ConstantOp::fold(FoldAdaptor) { return getValue(); }

OpFoldResult IdentityOp::fold(FoldAdaptor) {
  MatrixType type = getMatrixType();
  const llvm::fltSemantics &sem = type.getElementType().getFloatSemantics();
  SmallVector<APFloat> values;
  for (int64_t r = 0; r < type.getRows(); ++r)
    for (int64_t c = 0; c < type.getCols(); ++c)
      values.push_back(APFloat::getZero(sem));
  for (int64_t i = 0; i < type.getRows(); ++i)
    values[i * type.getCols() + i] = APFloat::getOne(sem);
  return toAttr(type, values);
}

OpFoldResult AddOp::fold(FoldAdaptor adaptor) {
  if (isSplatOfZero(adaptor.getRhs(), /*negative=*/true))
    return getLhs();
  if (isSplatOfZero(adaptor.getLhs(), /*negative=*/true))
    return getRhs();
  return foldEntrywise(getMatrixType(), adaptor.getLhs(), adaptor.getRhs(),
                       addFn);
}

OpFoldResult SubOp::fold(FoldAdaptor adaptor) {
  if (isSplatOfZero(adaptor.getRhs(), /*negative=*/false))
    return getLhs();
  return foldEntrywise(getMatrixType(), adaptor.getLhs(), adaptor.getRhs(),
                       subFn);
}

OpFoldResult ElementwiseMulOp::fold(FoldAdaptor adaptor) {
  if (isSplatOf(adaptor.getRhs(), 1.0))
    return getLhs();
  if (isSplatOf(adaptor.getLhs(), 1.0))
    return getRhs();
  return foldEntrywise(getMatrixType(), adaptor.getLhs(), adaptor.getRhs(),
                       mulFn);
}

OpFoldResult NegOp::fold(FoldAdaptor adaptor) {
  if (auto inner = getOperand().getDefiningOp<NegOp>())
    return inner.getOperand();
  std::optional<ConstMatrix> m = asConstMatrix(adaptor.getOperand());
  if (!m)
    return {};
  for (APFloat &value : m->values)
    value.changeSign();
  return toAttr(getMatrixType(), m->values);
}

OpFoldResult ScaleOp::fold(FoldAdaptor adaptor) {
  if (isSplatOf(adaptor.getRhs(), 1.0))
    return getLhs();
  return foldEntrywise(getMatrixType(), adaptor.getLhs(), adaptor.getRhs(),
                       mulFn,
                       /*rhsIsScalar=*/true);
}

OpFoldResult DivOp::fold(FoldAdaptor adaptor) {
  if (isSplatOf(adaptor.getRhs(), 1.0))
    return getLhs();
  return foldEntrywise(getMatrixType(), adaptor.getLhs(), adaptor.getRhs(),
                       divFn,
                       /*rhsIsScalar=*/true);
}

OpFoldResult MatmulOp::fold(FoldAdaptor adaptor) {
  if (isIdentityMatrix(getRhs(), adaptor.getRhs()))
    return getLhs();
  if (isIdentityMatrix(getLhs(), adaptor.getLhs()))
    return getRhs();
  std::optional<ConstMatrix> lhs = asConstMatrix(adaptor.getLhs());
  std::optional<ConstMatrix> rhs = asConstMatrix(adaptor.getRhs());
  if (!lhs || !rhs)
    return {};
  const llvm::fltSemantics &sem =
      getMatrixType().getElementType().getFloatSemantics();
  SmallVector<APFloat> out;
  for (int64_t r = 0; r < lhs->rows; ++r)
    for (int64_t c = 0; c < rhs->cols; ++c) {
      APFloat sum = APFloat::getZero(sem);
      for (int64_t k = 0; k < lhs->cols; ++k)
        sum = sum + lhs->at(r, k) * rhs->at(k, c);
      out.push_back(sum);
    }
  return toAttr(getMatrixType(), out);
}

OpFoldResult TransposeOp::fold(FoldAdaptor adaptor) {
  if (auto inner = getOperand().getDefiningOp<TransposeOp>())
    return inner.getOperand();
  if (getOperand().getType() == getMatrixType() && getMatrixType().isScalar())
    return getOperand();
  std::optional<ConstMatrix> m = asConstMatrix(adaptor.getOperand());
  if (!m)
    return {};
  SmallVector<APFloat> out;
  for (int64_t c = 0; c < m->cols; ++c)
    for (int64_t r = 0; r < m->rows; ++r)
      out.push_back(m->at(r, c));
  return toAttr(getMatrixType(), out);
}

OpFoldResult CofactorOp::fold(FoldAdaptor adaptor) {
  // Constant operands (the unit directions of derivatives) fold to
  // constants; up to 3x3, where the minors are at most 2x2.
  std::optional<ConstMatrix> m = asConstMatrix(adaptor.getOperand());
  if (!m || m->rows > 3)
    return {};
  const llvm::fltSemantics &semantics = m->values.front().getSemantics();
  auto entry = [&](int64_t r, int64_t c) {
    APFloat v = m->at(r, c);
    bool losesInfo = false;
    v.convert(APFloat::IEEEdouble(), APFloat::rmNearestTiesToEven, &losesInfo);
    return v.convertToDouble();
  };
  int64_t n = m->rows;
  SmallVector<APFloat> out;
  for (int64_t r = 0; r < n; ++r)
    for (int64_t c = 0; c < n; ++c) {
      double value = 1.0;
      if (n == 2) {
        value = entry(1 - r, 1 - c);
      } else if (n == 3) {
        int64_t r0 = (r + 1) % 3, r1 = (r + 2) % 3;
        int64_t c0 = (c + 1) % 3, c1 = (c + 2) % 3;
        // Cyclic indices give the signed minor directly.
        value = entry(r0, c0) * entry(r1, c1) - entry(r0, c1) * entry(r1, c0);
      }
      if (n == 2 && (r + c) % 2)
        value = -value;
      if (value == 0.0)
        value = 0.0; // no negative zeros in folded structure
      APFloat v(value);
      bool losesInfo = false;
      v.convert(semantics, APFloat::rmNearestTiesToEven, &losesInfo);
      out.push_back(v);
    }
  return toAttr(getMatrixType(), out);
}

OpFoldResult StopGradientOp::fold(FoldAdaptor adaptor) {
  // Derivatives of constants are zero anyway, and one stop is enough.
  if (adaptor.getOperand())
    return adaptor.getOperand();
  if (auto inner = getOperand().getDefiningOp<StopGradientOp>())
    return inner.getResult();
  return {};
}

OpFoldResult ResizeOp::fold(FoldAdaptor) {
  if (getOperand().getType() == getMatrixType())
    return getOperand();
  // resize(resize(x)) reads the same column-major sequence as resize(x).
  if (auto inner = getOperand().getDefiningOp<ResizeOp>()) {
    getOperandMutable().assign(inner.getOperand());
    return getResult();
  }
  return {};
}

/// The block of constant `attr` at (row0, col0) with `type`'s shape.
static Attribute foldBlock(Attribute attr, MatrixType type, int64_t row0,
                           int64_t col0) {
  std::optional<ConstMatrix> m = asConstMatrix(attr);
  if (!m)
    return {};
  SmallVector<APFloat> out;
  for (int64_t r = 0; r < type.getRows(); ++r)
    for (int64_t c = 0; c < type.getCols(); ++c)
      out.push_back(m->at(row0 + r, col0 + c));
  return toAttr(type, out);
}

OpFoldResult RowOp::fold(FoldAdaptor adaptor) {
  return foldBlock(adaptor.getOperand(), getMatrixType(), getIndex(), 0);
}

OpFoldResult ColOp::fold(FoldAdaptor adaptor) {
  return foldBlock(adaptor.getOperand(), getMatrixType(), 0, getIndex());
}

OpFoldResult ElementOp::fold(FoldAdaptor adaptor) {
  return foldBlock(adaptor.getOperand(), getMatrixType(), getRow(), getCol());
}

OpFoldResult SliceOp::fold(FoldAdaptor adaptor) {
  return foldBlock(adaptor.getOperand(), getMatrixType(), getRowOffset(),
                   getColOffset());
}
