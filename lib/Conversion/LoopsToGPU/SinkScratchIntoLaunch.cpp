//===- SinkScratchIntoLaunch.cpp - per-thread kernel scratch on GPUs ------===//
//
// Loop kernels keep the scratch buffers of their dense linear algebra in
// the function's entry block (one set per CPU thread, reused instance after
// instance). Once the instance loop is a gpu.launch, each buffer belongs in
// the launch body, so that every GPU thread gets its own and outlining does
// not pass a host buffer to the kernel.
//
//===----------------------------------------------------------------------===//

#include "yasps/Conversion/Passes.h"

#include "mlir/Dialect/GPU/IR/GPUDialect.h"

namespace mlir::yasps {
#define GEN_PASS_DEF_YASPSSINKSCRATCHINTOLAUNCH
#include "yasps/Conversion/Passes.h.inc"
} // namespace mlir::yasps

using namespace mlir;

namespace {
struct SinkScratchIntoLaunchPass
    : public mlir::yasps::impl::YaspsSinkScratchIntoLaunchBase<
          SinkScratchIntoLaunchPass> {
  void runOnOperation() override {
    WalkResult result = getOperation().walk([](memref::AllocaOp alloca) {
      // The one launch that uses the buffer; scratch outside launches
      // (already in a kernel, or host code) stays where it is.
      gpu::LaunchOp launch;
      for (Operation *user : alloca->getUsers()) {
        auto owner = user->getParentOfType<gpu::LaunchOp>();
        if (!owner || (launch && owner != launch)) {
          if (alloca->getParentOfType<gpu::LaunchOp>())
            return WalkResult::advance();
          alloca.emitError("kernel scratch buffer is used outside one "
                           "gpu.launch; cannot give it to GPU threads");
          return WalkResult::interrupt();
        }
        launch = owner;
      }
      if (!launch || launch->isAncestor(alloca))
        return WalkResult::advance();
      Block &body = launch.getBody().front();
      alloca->moveBefore(&body, body.begin());
      return WalkResult::advance();
    });
    if (result.wasInterrupted())
      signalPassFailure();
  }
};
} // namespace
