//===- YaspsExprOps.cpp - verifiers of per-instance expressions -----------===//
//
// Every diagnostic names the computed attribute the expression belongs to and
// the shapes involved, so a user can find the line of Python that built it.
//
//===----------------------------------------------------------------------===//

#include "yasps/Dialect/Yasps/IR/Yasps.h"

using namespace mlir;
using namespace mlir::yasps;

/// " in computed attribute @m::@p::@a", for the end of a diagnostic.
static std::string where(Operation *op) {
  auto attr = op->getParentOfType<AttrOp>();
  return attr ? " in " + describe(attr) : std::string();
}

static MatrixType matrixOf(Value value) {
  return cast<MatrixType>(value.getType());
}

static LogicalResult verifySameElementType(Operation *op, TypeRange types) {
  Type first = cast<MatrixType>(types.front()).getElementType();
  for (Type type : types.drop_front())
    if (cast<MatrixType>(type).getElementType() != first)
      return op->emitOpError() << "mixes element types " << types.front()
                               << " and " << type << where(op);
  return success();
}

static LogicalResult verifySquare(Operation *op, MatrixType type) {
  if (!type.isSquare())
    return op->emitOpError()
           << "needs a square matrix, got " << type << where(op);
  return success();
}

static LogicalResult verifyResultShape(Operation *op, MatrixType expected,
                                       MatrixType actual, StringRef why) {
  if (expected != actual)
    return op->emitOpError()
           << why << " gives " << expected << ", not " << actual << where(op);
  return success();
}

//===----------------------------------------------------------------------===//
// Reads: ReadOp, JoinOp, UnionOp
//===----------------------------------------------------------------------===//

LogicalResult ReadOp::verifySymbolUses(SymbolTableCollection &tables) {
  Operation *decl =
      lookupInScene(getEnclosingScene(*this), getAttribute(), &tables);
  if (!isAttributeDecl(decl))
    return emitOpError() << getAttribute() << " does not name an attribute"
                         << where(*this);
  MatrixType declared = getAttributeType(decl);
  if (declared != getMatrixType())
    return emitOpError() << "reads " << describe(decl) << " as "
                         << getMatrixType() << " but it is " << declared
                         << where(*this);
  Operation *owner = getOwningEntity(*this);
  Operation *declOwner = getOwningEntity(decl);
  if (!isOnLineageOf(declOwner, owner))
    return emitOpError() << "reads " << describe(decl) << " of "
                         << describe(declOwner) << ", which is not on the "
                         << "lineage of " << describe(owner) << where(*this)
                         << "; use a JOIN through a connectivity or a UNION";
  return success();
}

LogicalResult DofIndexOp::verifySymbolUses(SymbolTableCollection &tables) {
  SceneOp scene = getEnclosingScene(*this);
  Operation *decl = lookupInScene(scene, getTarget(), &tables);
  if (!isAttributeDecl(decl))
    return emitOpError() << getTarget() << " does not name an attribute"
                         << where(*this);
  bool isTarget = false;
  for (auto minimize : scene.getBodyBlock().getOps<MinimizeOp>())
    for (auto target : minimize.getTargets().getAsRange<SymbolRefAttr>())
      isTarget |= lookupInScene(scene, target, &tables) == decl;
  if (!isTarget)
    return emitOpError() << describe(decl)
                         << " is not a minimisation target (yasps.minimize), "
                            "so its entries have no DoF numbers"
                         << where(*this);
  MatrixType declared = getAttributeType(decl);
  MatrixType expected = declared.withShape(declared.getNumElements(), 1);
  if (getMatrixType() != expected)
    return emitOpError() << "the DoF numbers of " << describe(decl) << " ("
                         << declared << ") form a " << expected << ", not a "
                         << getMatrixType() << where(*this);
  Operation *owner = getOwningEntity(*this);
  Operation *declOwner = getOwningEntity(decl);
  if (!isOnLineageOf(declOwner, owner))
    return emitOpError() << "numbers the DoFs of " << describe(decl) << " of "
                         << describe(declOwner) << ", which is not on the "
                         << "lineage of " << describe(owner) << where(*this);
  return success();
}

LogicalResult JoinOp::verifySymbolUses(SymbolTableCollection &tables) {
  Operation *owner = getOwningEntity(*this);
  auto primitive = dyn_cast_or_null<PrimitiveOp>(owner);
  if (!primitive)
    return emitOpError() << "JOIN needs a connectivity of a primitive, but "
                         << describe((*this)->getParentOp()) << " is owned by "
                         << describe(owner);
  auto connectivity = dyn_cast_or_null<ConnectivityOp>(
      tables.lookupSymbolIn(primitive, getConnectivityAttr()));
  if (!connectivity)
    return emitOpError() << describe(primitive) << " has no connectivity "
                         << getConnectivityAttr() << where(*this);
  SceneOp scene = getEnclosingScene(*this);
  Operation *source = lookupInScene(scene, getSource(), &tables);
  if (!isAttributeDecl(source))
    return emitOpError() << "JOIN source " << getSource()
                         << " does not name an attribute" << where(*this);
  Operation *target = lookupInScene(scene, connectivity.getTarget(), &tables);
  Operation *sourceOwner = getOwningEntity(source);
  if (sourceOwner != target)
    return emitOpError() << "JOIN source " << describe(source) << " lives on "
                         << describe(sourceOwner) << " but "
                         << describe(connectivity) << " targets "
                         << (target ? describe(target) : std::string("nothing"))
                         << where(*this);
  MatrixType sourceType = getAttributeType(source);
  int64_t arity = connectivity.getArity();
  MatrixType expected =
      sourceType.withShape(arity, sourceType.getNumElements());
  if (expected != getMatrixType())
    return emitOpError() << "JOIN of " << sourceType << " through arity-"
                         << arity << " " << describe(connectivity) << " gives "
                         << expected << ", not " << getMatrixType()
                         << where(*this);
  return success();
}

LogicalResult UnionOp::verifySymbolUses(SymbolTableCollection &tables) {
  auto owner = dyn_cast_or_null<PrimitiveUnionOp>(getOwningEntity(*this));
  if (!owner)
    return emitOpError() << "UNION must be in an attribute of a primitive "
                            "union, not of "
                         << describe(getOwningEntity(*this)) << where(*this);
  SceneOp scene = getEnclosingScene(*this);
  for (auto ref : owner.getMembers().getAsRange<SymbolRefAttr>()) {
    Operation *member = lookupInScene(scene, ref, &tables);
    if (!isa_and_nonnull<PrimitiveOp, PrimitiveUnionOp>(member))
      return owner.verifySymbolUses(tables); // reports the bad member
    Operation *decl = tables.lookupSymbolIn(member, getNameAttr());
    if (!isAttributeDecl(decl))
      return emitOpError() << "UNION member " << describe(member)
                           << " has no attribute " << getNameAttr()
                           << where(*this);
    if (getAttributeType(decl) != getMatrixType())
      return emitOpError() << "UNION member " << describe(decl) << " is "
                           << getAttributeType(decl) << " but the union reads "
                           << getMatrixType() << where(*this);
  }
  return success();
}

//===----------------------------------------------------------------------===//
// Constants
//===----------------------------------------------------------------------===//

LogicalResult ConstantOp::inferReturnTypes(
    MLIRContext *context, std::optional<Location> location, ValueRange operands,
    DictionaryAttr attributes, OpaqueProperties properties, RegionRange regions,
    SmallVectorImpl<Type> &inferredReturnTypes) {
  Adaptor adaptor(operands, attributes, properties, regions);
  auto tensorType = dyn_cast_or_null<RankedTensorType>(
      adaptor.getValue() ? adaptor.getValue().getType() : Type());
  if (!tensorType || tensorType.getRank() != 2 ||
      !isa<FloatType>(tensorType.getElementType()))
    return emitOptionalError(location,
                             "'yasps.constant' needs a 2-D float tensor "
                             "literal such as dense<1.0> : tensor<1x1xf64>");
  auto elementType = cast<FloatType>(tensorType.getElementType());
  if (tensorType.getNumElements() == 0 ||
      !(elementType.isF32() || elementType.isF64()))
    return emitOptionalError(location,
                             "'yasps.constant' needs a non-empty "
                             "f32 or f64 literal, got ",
                             tensorType);
  inferredReturnTypes.push_back(
      MatrixType::get(context, tensorType.getDimSize(0),
                      tensorType.getDimSize(1), elementType));
  return success();
}

LogicalResult ConstantOp::verify() {
  if (!isa<DenseFPElementsAttr>(getValue()))
    return emitOpError() << "needs a dense float literal" << where(*this);
  return success();
}

LogicalResult IdentityOp::verify() {
  return verifySquare(*this, getMatrixType());
}

//===----------------------------------------------------------------------===//
// Elementwise ops with broadcast operands
//===----------------------------------------------------------------------===//

LogicalResult PowOp::verify() {
  MatrixType base = matrixOf(getBase()), exponent = matrixOf(getExponent());
  if (failed(verifySameElementType(*this, {base, exponent})))
    return failure();
  if (!exponent.isScalar() && exponent != base)
    return emitOpError() << "exponent must be 1x1 or the base's shape " << base
                         << ", got " << exponent << where(*this);
  return success();
}

LogicalResult SelectOp::verify() {
  MatrixType condition = matrixOf(getCondition()), value = getMatrixType();
  if (failed(verifySameElementType(*this, {condition, value})))
    return failure();
  if (!condition.isScalar() && condition != value)
    return emitOpError() << "condition must be 1x1 or the values' shape "
                         << value << ", got " << condition << where(*this);
  return success();
}

static LogicalResult verifyScalarRhs(Operation *op, MatrixType lhs,
                                     MatrixType rhs) {
  if (failed(verifySameElementType(op, {lhs, rhs})))
    return failure();
  if (!rhs.isScalar())
    return op->emitOpError() << "needs a 1x1 scalar on the right, got " << rhs
                             << " (with " << lhs << ")" << where(op);
  return success();
}

LogicalResult ScaleOp::verify() {
  return verifyScalarRhs(*this, matrixOf(getLhs()), matrixOf(getRhs()));
}

LogicalResult DivOp::verify() {
  return verifyScalarRhs(*this, matrixOf(getLhs()), matrixOf(getRhs()));
}

//===----------------------------------------------------------------------===//
// Matrix algebra
//===----------------------------------------------------------------------===//

LogicalResult MatmulOp::verify() {
  MatrixType lhs = matrixOf(getLhs()), rhs = matrixOf(getRhs());
  if (failed(verifySameElementType(*this, {lhs, rhs, getMatrixType()})))
    return failure();
  if (lhs.getCols() != rhs.getRows())
    return emitOpError() << "cannot multiply " << lhs << " by " << rhs
                         << ": inner dimensions " << lhs.getCols() << " and "
                         << rhs.getRows() << " differ" << where(*this);
  return verifyResultShape(*this, lhs.withShape(lhs.getRows(), rhs.getCols()),
                           getMatrixType(), "matrix product");
}

LogicalResult TransposeOp::verify() {
  MatrixType in = matrixOf(getOperand());
  return verifyResultShape(*this, in.withShape(in.getCols(), in.getRows()),
                           getMatrixType(), "transpose");
}

LogicalResult CrossOp::verify() {
  MatrixType type = getMatrixType();
  if (type.getNumElements() != 3 || type.isSquare())
    return emitOpError() << "needs 3x1 or 1x3 vectors, got " << type
                         << where(*this);
  return success();
}

LogicalResult DetOp::verify() {
  return verifySquare(*this, matrixOf(getOperand()));
}
LogicalResult TraceOp::verify() {
  return verifySquare(*this, matrixOf(getOperand()));
}
LogicalResult SingularValueSumOp::verify() {
  MatrixType type = matrixOf(getOperand());
  if (failed(verifySquare(*this, type)))
    return failure();
  if (type.getRows() > 3)
    return emitOpError() << "needs a matrix of at most 3x3, got " << type
                         << where(*this);
  return success();
}
LogicalResult InverseOp::verify() {
  return verifySquare(*this, getMatrixType());
}
LogicalResult CofactorOp::verify() {
  return verifySquare(*this, getMatrixType());
}
LogicalResult ProjectOp::verify() {
  return verifySquare(*this, getMatrixType());
}

//===----------------------------------------------------------------------===//
// Extracting and rearranging entries
//===----------------------------------------------------------------------===//

static LogicalResult verifyIndex(Operation *op, StringRef what, int64_t index,
                                 int64_t bound, MatrixType type) {
  if (index >= bound)
    return op->emitOpError() << what << " " << index << " is out of range for "
                             << type << where(op);
  return success();
}

LogicalResult RowOp::verify() {
  MatrixType in = matrixOf(getOperand());
  if (failed(verifyIndex(*this, "row", getIndex(), in.getRows(), in)))
    return failure();
  return verifyResultShape(*this, in.withShape(1, in.getCols()),
                           getMatrixType(), "a row");
}

LogicalResult ColOp::verify() {
  MatrixType in = matrixOf(getOperand());
  if (failed(verifyIndex(*this, "column", getIndex(), in.getCols(), in)))
    return failure();
  return verifyResultShape(*this, in.withShape(in.getRows(), 1),
                           getMatrixType(), "a column");
}

LogicalResult ElementOp::verify() {
  MatrixType in = matrixOf(getOperand());
  if (failed(verifyIndex(*this, "row", getRow(), in.getRows(), in)) ||
      failed(verifyIndex(*this, "column", getCol(), in.getCols(), in)))
    return failure();
  return success();
}

LogicalResult SliceOp::verify() {
  MatrixType in = matrixOf(getOperand()), out = getMatrixType();
  if (failed(verifySameElementType(*this, {in, out})))
    return failure();
  int64_t rowOffset = getRowOffset(), colOffset = getColOffset();
  if (rowOffset + out.getRows() > in.getRows() ||
      colOffset + out.getCols() > in.getCols())
    return emitOpError() << "block of " << out << " at (" << getRowOffset()
                         << ", " << getColOffset() << ") does not fit in " << in
                         << where(*this);
  return success();
}

LogicalResult ResizeOp::verify() {
  MatrixType in = matrixOf(getOperand()), out = getMatrixType();
  if (failed(verifySameElementType(*this, {in, out})))
    return failure();
  if (in.getNumElements() != out.getNumElements())
    return emitOpError() << "cannot resize " << in << " to " << out << ": "
                         << in.getNumElements() << " vs "
                         << out.getNumElements() << " entries" << where(*this);
  return success();
}

LogicalResult ConcatOp::verify() {
  if (getInputs().empty())
    return emitOpError() << "needs at least one operand" << where(*this);
  SmallVector<Type> types(getInputs().getTypes());
  types.push_back(getMatrixType());
  if (failed(verifySameElementType(*this, types)))
    return failure();
  bool vertical = getAxis() == ConcatAxis::vertical;
  MatrixType first = matrixOf(getInputs().front());
  int64_t stacked = 0;
  for (Value input : getInputs()) {
    MatrixType type = matrixOf(input);
    int64_t kept = vertical ? type.getCols() : type.getRows();
    int64_t firstKept = vertical ? first.getCols() : first.getRows();
    if (kept != firstKept)
      return emitOpError() << (vertical ? "vertical" : "horizontal")
                           << " concatenation needs equal "
                           << (vertical ? "column" : "row") << " counts, got "
                           << first << " and " << type << where(*this);
    stacked += vertical ? type.getRows() : type.getCols();
  }
  MatrixType expected = vertical ? first.withShape(stacked, first.getCols())
                                 : first.withShape(first.getRows(), stacked);
  return verifyResultShape(*this, expected, getMatrixType(), "concatenation");
}

//===----------------------------------------------------------------------===//
// YieldOp
//===----------------------------------------------------------------------===//

LogicalResult YieldOp::verify() {
  auto attr = cast<AttrOp>((*this)->getParentOp());
  if (getValue().getType() != attr.getMatrixType())
    return emitOpError() << "yields " << getValue().getType() << " but "
                         << describe(attr) << " is declared "
                         << attr.getMatrixType();
  return success();
}
