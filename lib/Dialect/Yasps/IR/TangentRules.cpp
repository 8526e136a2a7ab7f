//===- TangentRules.cpp - derivative rules of yasps expressions -----------===//
//
// Forward-mode rules: each op emits the tangent of its result from its
// operands' tangents, in yasps IR and at the matrix level. A null Value is a
// zero tangent; rules skip the terms it would zero, so derivative code only
// contains the products that can be non-zero.
//
//===----------------------------------------------------------------------===//

#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "mlir/IR/Builders.h"
#include "mlir/IR/Matchers.h"

using namespace mlir;
using namespace mlir::yasps;

namespace {

/// Builds tangent expressions, treating null Values as zero.
class TangentBuilder {
public:
  TangentBuilder(OpBuilder &b, Location loc) : b(b), loc(loc) {}

  static MatrixType typeOf(Value v) { return cast<MatrixType>(v.getType()); }

  Value constant(MatrixType type, double value) {
    auto attr = DenseElementsAttr::get(
        type.getTensorType(), b.getFloatAttr(type.getElementType(), value));
    return ConstantOp::create(b, loc, type, attr);
  }
  Value scalar(MatrixType like, double value) {
    return constant(like.getScalarType(), value);
  }
  Value orZero(Value tangent, MatrixType type) {
    return tangent ? tangent : constant(type, 0.0);
  }

  Value add(Value x, Value y) {
    if (!x || !y)
      return x ? x : y;
    return AddOp::create(b, loc, x, y);
  }
  Value sub(Value x, Value y) {
    if (!y)
      return x;
    if (!x)
      return neg(y);
    return SubOp::create(b, loc, x, y);
  }
  Value neg(Value x) { return x ? NegOp::create(b, loc, x).getResult() : x; }
  /// m * s for a 1x1 s.
  Value scale(Value m, Value s) {
    if (!m || !s)
      return {};
    return ScaleOp::create(b, loc, typeOf(m), m, s);
  }
  Value scaleBy(Value m, double s) {
    return m ? scale(m, scalar(typeOf(m), s)) : m;
  }
  Value div(Value m, Value s) {
    return m ? DivOp::create(b, loc, typeOf(m), m, s).getResult() : m;
  }
  Value emul(Value x, Value y) {
    if (!x || !y)
      return {};
    return ElementwiseMulOp::create(b, loc, x, y);
  }
  Value matmul(Value x, Value y) {
    if (!x || !y)
      return {};
    MatrixType tx = typeOf(x), ty = typeOf(y);
    return MatmulOp::create(b, loc, tx.withShape(tx.getRows(), ty.getCols()), x,
                            y);
  }
  Value dot(Value x, Value y) {
    if (!x || !y)
      return {};
    return DotOp::create(b, loc, typeOf(x).getScalarType(), x, y);
  }
  Value trace(Value m) {
    return m ? TraceOp::create(b, loc, typeOf(m).getScalarType(), m).getResult()
             : m;
  }
  Value pow(Value base, Value exponent) {
    return PowOp::create(b, loc, typeOf(base), base, exponent);
  }
  /// Entrywise 1 / x.
  Value reciprocal(Value x) { return pow(x, scalar(typeOf(x), -1.0)); }

  OpBuilder &b;
  Location loc;
};

/// Product rule for a bilinear op f(a, b): f(da, b) + f(a, db). For a
/// symmetric f of one value with itself (a square), 2 f(a, da): the two
/// terms are equal but computed in different orders, which CSE cannot see,
/// and energies are full of squares.
template <typename Fn>
Value productRule(TangentBuilder &t, Value a, Value b, Value da, Value db, Fn f,
                  bool symmetric = false) {
  if (symmetric && a == b && da == db)
    return t.scaleBy(da ? f(a, da) : Value(), 2.0);
  return t.add(da ? f(da, b) : Value(), db ? f(a, db) : Value());
}

/// The value of a constant whose entries are all equal, if `v` is one.
std::optional<double> splatValue(Value v) {
  DenseElementsAttr dense;
  if (!matchPattern(v, m_Constant(&dense)) || !dense.isSplat())
    return std::nullopt;
  return dense.getSplatValue<APFloat>().convertToDouble();
}

FailureOr<Value> notDifferentiable(Operation *op, StringRef why) {
  return op->emitOpError() << "cannot be differentiated: " << why;
}

} // namespace

#define TANGENT(OP)                                                            \
  FailureOr<Value> OP::emitTangent(OpBuilder &builder, ArrayRef<Value> tangents)

// Leaves of the differentiation pass, which seeds their tangents itself.
TANGENT(ReadOp) {
  return notDifferentiable(*this, "reads are seeded by yasps-differentiate");
}
TANGENT(JoinOp) {
  return notDifferentiable(*this, "JOINs are seeded by yasps-differentiate");
}
TANGENT(UnionOp) {
  return notDifferentiable(*this, "UNIONs are seeded by yasps-differentiate");
}
TANGENT(ProjectOp) {
  return notDifferentiable(
      *this, "PSD projection applies to derivatives, not before them");
}

// Constants, DoF numbers, comparisons and stopped gradients.
TANGENT(ConstantOp) { return Value(); }
TANGENT(DofIndexOp) { return Value(); }
TANGENT(IdentityOp) { return Value(); }
TANGENT(CmpOp) { return Value(); }
TANGENT(StopGradientOp) { return Value(); }

// Linear ops: the same op on the tangents.
TANGENT(AddOp) {
  return TangentBuilder(builder, getLoc()).add(tangents[0], tangents[1]);
}
TANGENT(SubOp) {
  return TangentBuilder(builder, getLoc()).sub(tangents[0], tangents[1]);
}
TANGENT(NegOp) { return TangentBuilder(builder, getLoc()).neg(tangents[0]); }
TANGENT(TransposeOp) {
  if (!tangents[0])
    return Value();
  return TransposeOp::create(builder, getLoc(), getMatrixType(), tangents[0])
      .getResult();
}
TANGENT(ResizeOp) {
  if (!tangents[0])
    return Value();
  return ResizeOp::create(builder, getLoc(), getMatrixType(), tangents[0])
      .getResult();
}
TANGENT(RowOp) {
  if (!tangents[0])
    return Value();
  return RowOp::create(builder, getLoc(), getMatrixType(), tangents[0],
                       getIndex())
      .getResult();
}
TANGENT(ColOp) {
  if (!tangents[0])
    return Value();
  return ColOp::create(builder, getLoc(), getMatrixType(), tangents[0],
                       getIndex())
      .getResult();
}
TANGENT(ElementOp) {
  if (!tangents[0])
    return Value();
  return ElementOp::create(builder, getLoc(), getMatrixType(), tangents[0],
                           getRow(), getCol())
      .getResult();
}
TANGENT(SliceOp) {
  if (!tangents[0])
    return Value();
  return SliceOp::create(builder, getLoc(), getMatrixType(), tangents[0],
                         getRowOffset(), getColOffset())
      .getResult();
}
TANGENT(TraceOp) {
  return TangentBuilder(builder, getLoc()).trace(tangents[0]);
}
TANGENT(SumOp) {
  if (!tangents[0])
    return Value();
  return SumOp::create(builder, getLoc(), getMatrixType(), tangents[0])
      .getResult();
}
TANGENT(ConcatOp) {
  if (llvm::all_of(tangents, [](Value v) { return !v; }))
    return Value();
  TangentBuilder t(builder, getLoc());
  SmallVector<Value> parts;
  for (auto [input, tangent] : llvm::zip(getInputs(), tangents))
    parts.push_back(t.orZero(tangent, TangentBuilder::typeOf(input)));
  return ConcatOp::create(builder, getLoc(), getMatrixType(), getAxis(), parts)
      .getResult();
}
TANGENT(SelectOp) {
  if (!tangents[1] && !tangents[2])
    return Value();
  TangentBuilder t(builder, getLoc());
  return SelectOp::create(builder, getLoc(), getMatrixType(), getCondition(),
                          t.orZero(tangents[1], getMatrixType()),
                          t.orZero(tangents[2], getMatrixType()))
      .getResult();
}

// Products.
TANGENT(ElementwiseMulOp) {
  TangentBuilder t(builder, getLoc());
  return productRule(
      t, getLhs(), getRhs(), tangents[0], tangents[1],
      [&](Value x, Value y) { return t.emul(x, y); }, /*symmetric=*/true);
}
TANGENT(ScaleOp) {
  TangentBuilder t(builder, getLoc());
  // s * s (both 1x1): 2 s s'.
  if (getLhs() == getRhs() && tangents[0] == tangents[1])
    return t.scaleBy(t.scale(getLhs(), tangents[0]), 2.0);
  return t.add(t.scale(tangents[0], getRhs()), t.scale(getLhs(), tangents[1]));
}
TANGENT(MatmulOp) {
  TangentBuilder t(builder, getLoc());
  return productRule(t, getLhs(), getRhs(), tangents[0], tangents[1],
                     [&](Value x, Value y) { return t.matmul(x, y); });
}
TANGENT(DotOp) {
  TangentBuilder t(builder, getLoc());
  return productRule(
      t, getLhs(), getRhs(), tangents[0], tangents[1],
      [&](Value x, Value y) { return t.dot(x, y); }, /*symmetric=*/true);
}
TANGENT(CrossOp) {
  TangentBuilder t(builder, getLoc());
  return productRule(t, getLhs(), getRhs(), tangents[0], tangents[1],
                     [&](Value x, Value y) -> Value {
                       return CrossOp::create(builder, getLoc(), x, y);
                     });
}
// (a / s)' = a' r - (a / s) (s' r) with r = 1 / s: one division, shared
// by every direction (CSE), instead of two per direction.
TANGENT(DivOp) {
  if (!tangents[0] && !tangents[1])
    return Value();
  TangentBuilder t(builder, getLoc());
  Value r = t.reciprocal(getRhs());
  Value first = t.scale(tangents[0], r);
  Value second =
      tangents[1] ? t.scale(getResult(), t.scale(tangents[1], r)) : Value();
  return t.sub(first, second);
}

// Matrix functions, kept at the matrix level.
// det(A)' = det(A) trace(A^-1 A')
// det(A)' = <cof(A), A'>: polynomial in A, so that second derivatives of
// determinants need no inverse (paper 10.5 keeps them in terms of det and
// the inverse; the cofactor form is what hand-derived code uses).
TANGENT(DetOp) {
  if (!tangents[0])
    return Value();
  TangentBuilder t(builder, getLoc());
  MatrixType type = TangentBuilder::typeOf(getOperand());
  if (type.getRows() == 1)
    return tangents[0];
  Value cof = CofactorOp::create(builder, getLoc(), type, getOperand());
  return t.dot(cof, tangents[0]);
}
// 2x2: cof is linear, cof(A)' = cof(A'). 3x3: the columns of cof(A) are
// a2 x a3, a3 x a1, a1 x a2 (a_j the columns of A), so by the product rule
// column j is a'_k x a_l + a_k x a'_l. Larger: cof = det A^-T.
TANGENT(CofactorOp) {
  if (!tangents[0])
    return Value();
  TangentBuilder t(builder, getLoc());
  Location loc = getLoc();
  MatrixType type = getMatrixType();
  int64_t n = type.getRows();
  Value a = getOperand(), da = tangents[0];
  if (n == 1)
    return Value();
  if (n == 2)
    return CofactorOp::create(builder, loc, type, da).getResult();
  if (n == 3) {
    MatrixType column = type.withShape(3, 1);
    auto col = [&](Value m, int64_t j) -> Value {
      return ColOp::create(builder, loc, column, m,
                           builder.getI64IntegerAttr(j));
    };
    auto cross = [&](Value x, Value y) -> Value {
      return CrossOp::create(builder, loc, x, y);
    };
    SmallVector<Value> columns;
    for (int64_t j = 0; j < 3; ++j) {
      int64_t k = (j + 1) % 3, l = (j + 2) % 3;
      columns.push_back(
          t.add(cross(col(da, k), col(a, l)), cross(col(a, k), col(da, l))));
    }
    return ConcatOp::create(builder, loc, type, ConcatAxis::horizontal, columns)
        .getResult();
  }
  // cof = det A^-T: cof' = det (tr(A^-1 A') A^-T - (A^-1 A' A^-1)^T).
  Value inv = InverseOp::create(builder, loc, type, a);
  Value det = DetOp::create(builder, loc, type.getScalarType(), a);
  Value invDa = t.matmul(inv, da);
  Value first =
      t.scale(TransposeOp::create(builder, loc, type, inv), t.trace(invDa));
  Value second = TransposeOp::create(builder, loc, type, t.matmul(invDa, inv));
  return t.scale(t.sub(first, second), det);
}
// (A^-1)' = -A^-1 A' A^-1
TANGENT(InverseOp) {
  if (!tangents[0])
    return Value();
  TangentBuilder t(builder, getLoc());
  return t.neg(t.matmul(t.matmul(getResult(), tangents[0]), getResult()));
}
// |A|' = <A, A'> (1 / |A|), the reciprocal shared by every direction.
TANGENT(NormOp) {
  if (!tangents[0])
    return Value();
  TangentBuilder t(builder, getLoc());
  return t.scale(t.dot(getOperand(), tangents[0]), t.reciprocal(getResult()));
}
// The sum s of signed singular values, by implicit differentiation of its
// defining polynomial (see the op's description), in terms of s itself so
// that second derivatives follow by the same rule:
//   2x2: s = sqrt(I + 2 J), s' = <A + cof A, A'> / s;
//   3x3: P(s) = (s^2 - I)^2 - 8 J s - 4 II = 0 gives
//   s' = ((s^2 - I) <A, A'> + 2 <cof A, cof(A)'> + 2 s <cof A, A'>)
//        / (s (s^2 - I) - 2 J),
// whose denominator is (s1 + s2)(s2 + s3)(s1 + s3) in the signed singular
// values: zero only where the polar rotation is not unique.
TANGENT(SingularValueSumOp) {
  if (!tangents[0])
    return Value();
  TangentBuilder t(builder, getLoc());
  Location loc = getLoc();
  Value a = getOperand(), da = tangents[0], s = getResult();
  MatrixType type = TangentBuilder::typeOf(a);
  if (type.getRows() == 1)
    return da;
  auto cofactor = CofactorOp::create(builder, loc, type, a);
  Value cof = cofactor.getResult();
  if (type.getRows() == 2)
    return t.scale(t.add(t.dot(a, da), t.dot(cof, da)), t.reciprocal(s));
  FailureOr<Value> dcof = cofactor.emitTangent(builder, {da});
  if (failed(dcof))
    return failure();
  Value gap = t.sub(
      t.emul(s, s),
      SquaredNormOp::create(builder, loc, type.getScalarType(), a).getResult());
  Value det = DetOp::create(builder, loc, type.getScalarType(), a);
  Value numerator =
      t.add(t.add(t.emul(gap, t.dot(a, da)), t.scaleBy(t.dot(cof, *dcof), 2.0)),
            t.scaleBy(t.emul(s, t.dot(cof, da)), 2.0));
  Value denominator = t.sub(t.emul(s, gap), t.scaleBy(det, 2.0));
  return t.emul(numerator, t.reciprocal(denominator));
}
// (|A|^2)' = 2 <A, A'>
TANGENT(SquaredNormOp) {
  TangentBuilder t(builder, getLoc());
  return t.scaleBy(t.dot(getOperand(), tangents[0]), 2.0);
}

// Entrywise functions: f'(a) * a', entry by entry.
TANGENT(SqrtOp) {
  TangentBuilder t(builder, getLoc());
  return t.scaleBy(t.emul(tangents[0], t.reciprocal(getResult())), 0.5);
}
TANGENT(LogOp) {
  TangentBuilder t(builder, getLoc());
  return t.emul(tangents[0], t.reciprocal(getOperand()));
}
TANGENT(ExpOp) {
  TangentBuilder t(builder, getLoc());
  return t.emul(tangents[0], getResult());
}
TANGENT(SinOp) {
  if (!tangents[0])
    return Value();
  TangentBuilder t(builder, getLoc());
  return t.emul(tangents[0],
                CosOp::create(builder, getLoc(), getOperand()).getResult());
}
TANGENT(CosOp) {
  if (!tangents[0])
    return Value();
  TangentBuilder t(builder, getLoc());
  return t.neg(t.emul(
      tangents[0], SinOp::create(builder, getLoc(), getOperand()).getResult()));
}
// |a|' = sign(a) a', with sign(0) = 1 (a subgradient).
TANGENT(AbsOp) {
  if (!tangents[0])
    return Value();
  TangentBuilder t(builder, getLoc());
  MatrixType type = getMatrixType();
  Value negative = CmpOp::create(builder, getLoc(), CmpPredicate::lt,
                                 getOperand(), t.constant(type, 0.0));
  Value sign = SelectOp::create(builder, getLoc(), type, negative,
                                t.constant(type, -1.0), t.constant(type, 1.0));
  return t.emul(tangents[0], sign);
}
// atan2(y, x)' = (x y' - y x') / (x^2 + y^2)
TANGENT(Atan2Op) {
  if (!tangents[0] && !tangents[1])
    return Value();
  TangentBuilder t(builder, getLoc());
  Value y = getLhs(), x = getRhs();
  Value numerator = t.sub(t.emul(x, tangents[0]), t.emul(y, tangents[1]));
  Value denominator = t.add(t.emul(x, x), t.emul(y, y));
  return t.emul(numerator, t.reciprocal(denominator));
}
// min/max pass the tangent of the operand they select (the lhs on ties).
TANGENT(MinOp) {
  if (!tangents[0] && !tangents[1])
    return Value();
  TangentBuilder t(builder, getLoc());
  Value lhsWins =
      CmpOp::create(builder, getLoc(), CmpPredicate::le, getLhs(), getRhs());
  return SelectOp::create(builder, getLoc(), getMatrixType(), lhsWins,
                          t.orZero(tangents[0], getMatrixType()),
                          t.orZero(tangents[1], getMatrixType()))
      .getResult();
}
TANGENT(MaxOp) {
  if (!tangents[0] && !tangents[1])
    return Value();
  TangentBuilder t(builder, getLoc());
  Value lhsWins =
      CmpOp::create(builder, getLoc(), CmpPredicate::ge, getLhs(), getRhs());
  return SelectOp::create(builder, getLoc(), getMatrixType(), lhsWins,
                          t.orZero(tangents[0], getMatrixType()),
                          t.orZero(tangents[1], getMatrixType()))
      .getResult();
}
// (a^e)' = e a^(e-1) a' + a^e log(a) e'
TANGENT(PowOp) {
  TangentBuilder t(builder, getLoc());
  Value base = getBase(), exponent = getExponent();
  MatrixType expType = TangentBuilder::typeOf(exponent);
  // (1/x)' = -(1/x)^2 x': a product of the result with itself, not a
  // pow(x, -2) call (reciprocals come from every division, log and norm).
  if (splatValue(exponent) == -1.0 && !tangents[1])
    return t.neg(t.emul(t.emul(getResult(), getResult()), tangents[0]));
  Value first;
  if (tangents[0]) {
    Value lowered = t.sub(exponent, t.constant(expType, 1.0));
    Value derivative = t.pow(base, lowered);
    Value scaled = expType.isScalar() ? t.scale(derivative, exponent)
                                      : t.emul(derivative, exponent);
    first = t.emul(scaled, tangents[0]);
  }
  Value second;
  if (tangents[1]) {
    Value logBase = LogOp::create(builder, getLoc(), base);
    Value factor = t.emul(getResult(), logBase);
    second = expType.isScalar() ? t.scale(factor, tangents[1])
                                : t.emul(factor, tangents[1]);
  }
  return t.add(first, second);
}

#undef TANGENT
