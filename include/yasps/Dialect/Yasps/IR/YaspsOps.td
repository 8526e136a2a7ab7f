//===- YaspsOps.td - all yasps operations --------------------*- tablegen -*-===//

#ifndef YASPS_DIALECT_YASPS_IR_YASPSOPS_TD
#define YASPS_DIALECT_YASPS_IR_YASPSOPS_TD

include "yasps/Dialect/Yasps/IR/YaspsAttrs.td"
include "yasps/Dialect/Yasps/IR/YaspsStructureOps.td"
include "yasps/Dialect/Yasps/IR/YaspsExprOps.td"

#endif // YASPS_DIALECT_YASPS_IR_YASPSOPS_TD
