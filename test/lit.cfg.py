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
     ToolSubst("mlir-tblgen", unresolved="fatal")],
    tool_dirs)
