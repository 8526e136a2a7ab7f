"""Emission of yasps IR from a scene (docs/dialect.md), and the symbol paths
by which IR and kernels name the scene's objects."""

from .emit import KernelIR, emit_scene, kernel_ir, mat_type, text_and_locations
from .symbols import entity_path, resolve, symbol_path

__all__ = ["KernelIR", "emit_scene", "kernel_ir", "mat_type", "text_and_locations", "entity_path", "resolve", "symbol_path"]
