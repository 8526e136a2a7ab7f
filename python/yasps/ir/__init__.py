"""Emission of yasps IR from a scene (docs/dialect.md), and the symbol paths
by which IR and kernels name the scene's objects."""

from .emit import emit_scene, kernel_ir, mat_type
from .symbols import entity_path, resolve, symbol_path

__all__ = ["emit_scene", "kernel_ir", "mat_type", "entity_path", "resolve", "symbol_path"]
