# -*- Python -*-
"""lit configuration that runs the runtime's GoogleTest binaries."""

import os

import lit.formats

config.name = "YASPS-Unit"
config.suffixes = []
config.test_exec_root = os.path.join(config.yasps_obj_root, "runtime", "test")
config.test_source_root = config.test_exec_root
config.test_format = lit.formats.GoogleTest(".", "Tests")
