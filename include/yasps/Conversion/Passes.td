//===- Passes.td - yasps conversion passes -------------------*- tablegen -*-===//

#ifndef YASPS_CONVERSION_PASSES_TD
#define YASPS_CONVERSION_PASSES_TD

include "mlir/Pass/PassBase.td"

def YaspsLowerToLoops : Pass<"yasps-lower-to-loops", "::mlir::ModuleOp"> {
  let summary = "Generate per-instance loop kernels that evaluate attributes";
  let description = [{
    For every requested attribute of the scene, adds a function

    ```mlir
    func.func @yasps_eval_<mesh>__<primitive>__<attr>(
        %begin: index, %end: index, %out: memref<?xf64>, %arg: memref<?x...>...)
    ```

    that evaluates the attribute on the instances `[begin, end)` of its owner
    and stores them in `out` (column-major per instance, instance after
    instance). The body is one `scf.parallel` loop over instances; small
    matrices are scalarised into `arith`/`math` ops; stored attributes are
    loaded from one buffer each (scene- and mesh-level ones at instance 0, a
    broadcast); a JOIN gathers through its connectivity's int32 buffer and
    evaluates its source at the gathered instances; a UNION decodes the union
    index with the union's prefix offsets (an i64 buffer) and evaluates the
    member's attribute. Computed attributes are evaluated where they are used:
    nothing intermediate is stored (paper section 4.3, Fig. 6 and 9).

    The function's `yasps.kernel_args` lists what each buffer argument holds
    (`#yasps.kernel_arg<kind @symbol>`, kind `out`, `attr`, `conn`,
    `offsets` or `dof_offsets`, with the symbol it belongs to); the runtime
    binds buffers by it. `yasps.kernel_shape` is the [rows, cols] of
    each instance's value in `out`. Instance counts are not compiled in: a
    dynamic primitive changes size without a new kernel.

    Kernels compute in the element type of the IR (`f64` or `f32`); with
    `storage=` (attribute buffers) and `out-storage=` (the output), float
    buffers hold that type instead, converted at every load and store (f32
    arithmetic on f64 data).
  }];
  let options = [
    ListOption<"attributes", "attributes", "std::string",
               "Scene-relative paths of the attributes to evaluate "
               "(e.g. @mesh::@prim::@attr); empty means every energy">,
    Option<"sceneName", "scene", "std::string", /*default=*/"\"\"",
           "The scene to compile (default: the module's only scene)">,
    Option<"lanes", "lanes", "int64_t", /*default=*/"1",
           "Instances evaluated together in SIMD lanes: the arithmetic on "
           "vector<lanes x f64> values (1: one instance at a time, as GPU "
           "threads do; CPU kernels use the host's vector width)">,
    Option<"projectionLanes", "projection-lanes", "int64_t",
           /*default=*/"0",
           "Lanes of kernels that PSD-project a matrix of at most 9x9 "
           "(0: `lanes`). The eigensolver is a chain of dependent square "
           "roots and divisions; two vectors of problems per step overlap "
           "two chains (the CPU compiler's default: twice the host's "
           "width)">,
    Option<"storage", "storage", "std::string", /*default=*/"\"\"",
           "Float type of the attribute and output buffers: empty (each "
           "buffer has its attribute's element type), `f32` or `f64`. Where "
           "it differs from the attribute's type, loads extend or truncate "
           "to the type the IR computes in and stores convert back: the "
           "runtime keeps f64 buffers while kernels compute in f32">,
    Option<"outStorage_", "out-storage", "std::string", /*default=*/"\"\"",
           "Float type of the output buffer, as `storage` for attribute "
           "buffers (empty: the attribute's type)">
  ];
  let dependentDialects = [
    "::mlir::arith::ArithDialect", "::mlir::func::FuncDialect",
    "::mlir::math::MathDialect", "::mlir::memref::MemRefDialect",
    "::mlir::scf::SCFDialect", "::mlir::vector::VectorDialect"
  ];
}

def YaspsStripScenes : Pass<"yasps-strip-scenes", "::mlir::ModuleOp"> {
  let summary = "Erase the scene description once kernels are generated";
  let description = [{
    Removes every `yasps.scene` op, leaving the generated kernel functions in
    upstream dialects only, ready for lowering to LLVM or GPU code.
  }];
}

def YaspsCountOps : Pass<"yasps-count-ops", "::mlir::ModuleOp"> {
  let summary = "Annotate generated kernels with their arithmetic op counts";
  let description = [{
    Attaches `yasps.op_counts` to every kernel function made by
    `yasps-lower-to-loops`: how many floating-point multiplications,
    additions (and subtractions), divisions and math-library calls its body
    contains, counted statically (an op inside a loop counts once). Run it
    after `canonicalize` and `cse` to measure the code that is compiled; the
    CPU compiler does. (MLIR's pass statistics would be the usual channel,
    but they are compiled out of Debian's LLVM build.)
  }];
}

def YaspsSinkScratchIntoLaunch
    : Pass<"yasps-sink-scratch-into-launch", "::mlir::ModuleOp"> {
  let summary = "Give every GPU thread its own kernel scratch buffers";
  let description = [{
    Loop kernels allocate the scratch buffers of dense linear algebra (the
    eigen-decomposition of `yasps.project`) once, in the function's entry
    block, because a CPU thread runs its instances one after another. On a
    GPU every instance is a thread of its own: after
    `convert-parallel-loops-to-gpu`, this pass moves each such
    `memref.alloca` that is used only inside one `gpu.launch` to the start
    of the launch's body, where `gpu-kernel-outlining` keeps it (private,
    per-thread memory) instead of passing a host buffer to the kernel.
    An alloca used outside the launch, or in two launches, is an error.
  }];
}

def YaspsPreciseGpuSqrt
    : Pass<"yasps-precise-gpu-sqrt", "::mlir::gpu::GPUModuleOp"> {
  let summary = "Correctly rounded f32 square roots in GPU kernels";
  let description = [{
    Replaces each scalar f32 `math.sqrt` in a GPU module by the correctly
    rounded PTX instruction `sqrt.rn.f32` (`llvm.inline_asm`). Run before
    `convert-gpu-to-nvvm`, whose libdevice lowering (`__nv_sqrtf`, also for
    `llvm.intr.sqrt`) is `sqrt.approx.f32` unless `__CUDA_PREC_SQRT` is
    reflected: f32 kernels would differ from the CPU's IEEE square roots.
    f64 square roots are left to libdevice, which rounds them correctly.
  }];
  let dependentDialects = ["::mlir::LLVM::LLVMDialect"];
}

def YaspsNVVMToHost : Pass<"yasps-nvvm-to-host", "::mlir::gpu::GPUModuleOp"> {
  let summary = "Make NVVM-level GPU kernels callable on the host";
  let description = [{
    Rewrites a GPU module at the NVVM level (after `convert-gpu-to-nvvm`,
    the IR that NVPTX code generation and ptxas turn into a cubin) into LLVM
    dialect code that the host can run, for the stand-in driver's host
    images (`yasps/Runtime/Gpu/HostImage.h`):

    - each kernel `@k` becomes `@k__body`, internal, with one more argument,
      a pointer to the thread's `ThreadContext`, from which it reads what
      it read from `%tid`, `%ntid`, `%ctaid` and `%nctaid`;
    - a new `@k(ptr params, ptr thread)` loads each parameter through
      cuLaunchKernel's array of pointers and calls `@k__body`;
    - libdevice calls (`__nv_exp`, ...) call the host's math library, and
      the correctly rounded `sqrt.rn.f32` of `yasps-precise-gpu-sqrt`
      becomes `llvm.intr.sqrt`, which is correctly rounded on the host too.

    Anything else the host cannot run (barriers, shared memory, other NVVM
    operations or inline assembly, a libdevice function without a C
    counterpart) is an error: generated kernels have none.
  }];
  let dependentDialects = ["::mlir::LLVM::LLVMDialect"];
}

#endif // YASPS_CONVERSION_PASSES_TD
