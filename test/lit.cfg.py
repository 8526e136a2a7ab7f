# -*- Python -*-
"""lit configuration of the yasps compiler tests (FileCheck over yasps-opt)."""

import os

import lit.formats
from lit.llvm import llvm_config
from lit.llvm.subst import ToolSubst

config.name = "YASPS"
config.test_format = lit.formats.ShTest(not llvm_config.use_lit_shell)
config.suffixes = [".mlir", ".test"]
config.test_source_root = os.path.dirname(__file__)
config.test_exec_root = os.path.join(config.yasps_obj_root, "test")
config.excludes = ["CMakeLists.txt", "lit.cfg.py", "lit.site.cfg.py", "Unit",
                   "Inputs"]

config.substitutions.append(("%PATH%", config.environment["PATH"]))
config.substitutions.append(("%yasps_src_root", config.yasps_src_root))
# %python_ext: Python that can import the build's extension modules. Python
# is not built with AddressSanitizer, so in the sanitizer build it loads the
# ASan runtime first (only where needed: with it preloaded, the sanitized
# tools it might start refuse to run). CPython frees little at exit by
# design, so leak checks are for the C++ tools only.
python_ext = config.python_executable
if config.yasps_asan_runtime:
    # allow_user_poisoning=0: LLVM's BumpPtrAllocator poisons the slabs it
    # allocates in our instrumented code, and the uninstrumented libMLIR
    # then allocates from them without unpoisoning, which ASan would report
    # as use-after-poison in MLIR's own storage uniquer.
    asan = "allow_user_poisoning=0:halt_on_error=1"
    user = os.environ.get("ASAN_OPTIONS")
    config.environment["ASAN_OPTIONS"] = f"{asan}:{user}" if user else asan
    python_ext = (f"env LD_PRELOAD={config.yasps_asan_runtime} "
                  f"ASAN_OPTIONS={asan}:detect_leaks=0 {python_ext}")
config.substitutions.append(("%python_ext", python_ext))
config.substitutions.append(("%python", config.python_executable))
config.substitutions.append(("%llvm_include_dir", config.llvm_include_dir))
# Where the build puts the Python extension modules.
config.substitutions.append(
    ("%yasps_python_dir", os.path.join(config.yasps_obj_root, "python", "yasps")))

llvm_config.with_system_environment(["HOME", "INCLUDE", "LIB", "TMP", "TEMP"])
llvm_config.use_default_substitutions()

tool_dirs = [os.path.join(config.yasps_obj_root, "bin"), config.llvm_tools_dir]
llvm_config.add_tool_substitutions(
    [ToolSubst("yasps-opt", unresolved="fatal"),
     ToolSubst("mlir-tblgen", unresolved="fatal"),
     ToolSubst("not", unresolved="fatal")],
    tool_dirs)
