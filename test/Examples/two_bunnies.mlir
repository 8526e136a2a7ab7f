// The paper's running example verifies, prints and re-parses to the same IR.
// RUN: yasps-opt %yasps_src_root/examples/ir/two_bunnies.mlir > %t.1.mlir
// RUN: yasps-opt %t.1.mlir > %t.2.mlir
// RUN: diff %t.1.mlir %t.2.mlir
// RUN: FileCheck %s --input-file=%t.1.mlir

// CHECK: yasps.primitive_union @vertices [@bunny_affine::@vertices, @bunny_soft::@vertices]
// CHECK: yasps.primitive @pp(0) dynamic
// CHECK: yasps.join @pp2v(@bunnies::@vertices::@position) : !yasps.mat<2x3xf64>
// CHECK: yasps.energy @bunnies::@pp::@point_point dynamic_instances
// CHECK: yasps.minimize [@bunny_soft::@vertices::@position, @bunny_affine::@affine_body::@affine_matrix, @bunny_affine::@affine_body::@translation]
