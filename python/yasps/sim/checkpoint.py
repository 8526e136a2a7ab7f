"""Checkpoints of a time stepper: everything its next step reads, written
to one ``.npz`` file and read back into a stepper of the same scene
structure, so that a run stopped and resumed continues bit for bit as the
uninterrupted one.

What a step reads: every stored value of the scene (targets, predictions,
materials, the contact's stiffness and friction pairs: any constant a
script may have changed), the instance counts and connectivities of its
dynamic primitives (collision and friction pairs), the stepper's
velocities and time (prescribed motion reads it), the contact's
adaptive-stiffness state and the choice of preconditioner
(``config.preconditioner = "auto"``). Caches that only
save work (derivatives at a point, the last step's broad phase) are not
saved: a step starts without them (``ImplicitEuler.step``), resumed or
not, so that their absence changes no bit.

The file is ``path`` with ``.npz`` added where it lacks it (as NumPy's
``savez`` names files), on writing and on reading alike, so that
``save("state")`` and ``restore("state")`` meet. A save writes beside the
file and renames over it, so that a run killed while saving leaves the
previous checkpoint whole.
"""

from __future__ import annotations

import os
import zipfile
from os import PathLike
from pathlib import Path
from typing import Any, Dict, Iterator, List, Tuple, Union

import numpy as np

from ..frontend import introspect
from ..frontend.attribute import STORED_KINDS
from ..frontend.errors import CheckpointError, SceneError
from ..frontend.scene import Entity, Primitive
from ..solve import preconditioner_choice

#: The format of the file, checked on reading.
VERSION = 1
#: The suffix of a checkpoint file, added where a path lacks it.
SUFFIX = ".npz"


def _entities(scene) -> Iterator[Tuple[str, Entity]]:
    """The scene, its meshes and their primitives, each with a path."""
    yield "", scene
    for mesh_name, mesh in scene.meshes.items():
        yield mesh_name, mesh
        for name, primitive in mesh.primitives.items():
            if isinstance(primitive, Primitive):
                yield f"{mesh_name}/{name}", primitive


def structure(scene) -> List[str]:
    """The scene's stored attributes (with their shapes), connectivities
    and static primitives' instance counts, by path: what a checkpoint's
    reader must have."""
    out = []
    for path, entity in _entities(scene):
        if isinstance(entity, Primitive):
            if not entity.isDynamic:
                out.append(f"instances:{path}:{entity.numInstances}")
            out += [f"conn:{path}:{name}:{conn.arity}"
                    for name, conn in entity.connectivities.items()]
        out += [f"value:{path}:{name}:{attr.shape[0]}x{attr.shape[1]}"
                for name, attr in entity.attributes.items()
                if attr.kind in STORED_KINDS]
    return sorted(out)


def scene_state(scene) -> Dict[str, np.ndarray]:
    """Every stored value, dynamic instance count and connectivity of
    ``scene`` by a key naming it (those without values left out), and its
    ``structure``."""
    state: Dict[str, np.ndarray] = {"structure": np.array(structure(scene))}
    for path, entity in _entities(scene):
        if isinstance(entity, Primitive):
            if entity.isDynamic:
                state[f"count:{path}"] = np.array(entity.numInstances)
            for name, conn in entity.connectivities.items():
                if introspect.stored_indices(conn) is not None:
                    state[f"conn:{path}:{name}"] = conn.indices
        for name, attr in entity.attributes.items():
            if attr.kind in STORED_KINDS and \
                    introspect.stored_values(attr) is not None:
                state[f"value:{path}:{name}"] = attr.value
    return state


def check_structure(scene, state: Dict[str, np.ndarray]) -> None:
    """Raises SceneError naming a difference where ``scene`` has another
    structure than the one ``state`` was taken from."""
    mine, saved = structure(scene), [str(k) for k in state["structure"]]
    if mine != saved:
        missing = sorted(set(mine) - set(saved))
        extra = sorted(set(saved) - set(mine))
        what = (f"it has {missing[0]}, which the file lacks" if missing else
                f"the file has {extra[0]}, which it lacks" if extra else
                "their entities come in another order")
        raise SceneError(f"restore: the scene '{scene.name}' is not the one "
                         f"saved: {what}")


def restore_scene_state(scene, state: Dict[str, np.ndarray]) -> None:
    """Writes ``state`` (as :func:`scene_state` gave it) into ``scene``,
    which must have the same structure; changes only what differs, so
    that nothing derived from the rest is rebuilt."""
    check_structure(scene, state)
    for path, entity in _entities(scene):
        if not isinstance(entity, Primitive):
            continue
        key = f"count:{path}"
        if entity.isDynamic and key in state and \
                int(state[key]) != entity.numInstances:
            entity.updateNumInstances(int(state[key]))
        for name, conn in entity.connectivities.items():
            key = f"conn:{path}:{name}"
            if key in state and (
                    introspect.stored_indices(conn) is None
                    or not np.array_equal(conn.indices, state[key])):
                conn.updateConnectivity(state[key])
    for path, entity in _entities(scene):
        for name, attr in entity.attributes.items():
            key = f"value:{path}:{name}"
            if key not in state:
                continue
            value = state[key]
            if introspect.stored_values(attr) is None or \
                    attr.value.shape != value.shape or \
                    not np.array_equal(attr.value, value):
                attr.updateValue(value)


def checkpoint_path(path: Union[str, PathLike]) -> Path:
    """The file a checkpoint named ``path`` lives in: ``path`` with
    ``.npz`` added where it does not end so."""
    path = Path(os.fspath(path))
    return path if path.name.endswith(SUFFIX) else \
        path.with_name(path.name + SUFFIX)


def save(stepper, path: Union[str, PathLike]) -> Path:
    """Writes ``stepper``'s state (an ImplicitEuler) to
    :func:`checkpoint_path` of ``path``, atomically: into a file beside it,
    flushed to disk, then renamed over it. Returns the file written."""
    target = checkpoint_path(path)
    arrays = stepper_state(stepper)
    partial = target.with_name(f"{target.name}.{os.getpid()}.partial")
    try:
        with open(partial, "wb") as out:
            np.savez(out, **arrays)
            out.flush()
            os.fsync(out.fileno())
        os.replace(partial, target)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
    _sync_folder(target.parent)
    return target


def _sync_folder(folder: Path) -> None:
    """Flushes ``folder``'s entries (the rename) to disk where the system
    allows opening a folder."""
    try:
        descriptor = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(descriptor)
    except OSError:
        pass
    finally:
        os.close(descriptor)


def stepper_state(stepper) -> Dict[str, Any]:
    """What the next step of ``stepper`` (an ImplicitEuler) reads, as
    arrays by name: :func:`save` writes them, :func:`restore_stepper_state`
    reads them back."""
    # Any: np.savez's keywords also include allow_pickle, a bool.
    arrays: Dict[str, Any] = {
        f"scene|{k}": v for k, v in scene_state(stepper.scene).items()}
    arrays["version"] = np.array(VERSION)
    arrays["dt"] = np.array(stepper.dt)
    arrays["time"] = np.array(stepper.time)
    for k, v in enumerate(stepper.velocities):
        arrays[f"velocity|{k}"] = v
    for k, inertia in enumerate(stepper.world):
        arrays[f"world_velocity|{k}"] = inertia.velocity
    adaptive = getattr(stepper.contact, "adaptive", None)
    if adaptive is not None:
        arrays["adaptive"] = np.array([
            np.nan if adaptive.kappa is None else adaptive.kappa,
            adaptive.max_kappa,
            np.nan if adaptive.previous is None else adaptive.previous])
    choice = preconditioner_choice.state(stepper.scene)
    if choice is not None:
        arrays["preconditioner_choice"] = choice
    return arrays


def restore(stepper, path: Union[str, PathLike]) -> None:
    """Reads a state :func:`save` wrote into ``stepper``, an ImplicitEuler
    of the same scene structure and time step: from ``path`` where that is
    a file, else from :func:`checkpoint_path` of it (CheckpointError where
    neither is, or the file is not one :func:`save` wrote)."""
    given = Path(os.fspath(path))
    found = given if given.is_file() else checkpoint_path(given)
    if not found.is_file():
        also = "" if found == given else f" nor {found}"
        raise CheckpointError(f"restore: no checkpoint at {given}{also}")
    try:
        with np.load(found) as data:
            arrays = {k: data[k] for k in data.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as error:
        raise CheckpointError(
            f"restore: {found} cannot be read as a checkpoint (cut short, "
            f"or not written by save: {error})") from error
    restore_stepper_state(stepper, arrays, str(found))


def restore_stepper_state(stepper, arrays: Dict[str, Any],
                          path: str = "the state") -> None:
    """Writes ``arrays`` (:func:`stepper_state`'s, or a file's) into
    ``stepper``; ``path`` names them in errors."""
    if int(arrays.get("version", -1)) != VERSION:
        raise SceneError(f"restore: {path} is not a yasps checkpoint of "
                         f"format {VERSION}")
    check_structure(stepper.scene, {
        "structure": arrays.get("scene|structure", np.array([]))})
    if float(arrays["dt"]) != stepper.dt:
        raise SceneError(f"restore: {path} was saved with dt = "
                         f"{float(arrays['dt'])}, the stepper has "
                         f"dt = {stepper.dt}")
    velocities = [arrays[f"velocity|{k}"]
                  for k in range(len(stepper.targets))
                  if f"velocity|{k}" in arrays]
    if len(velocities) != len(stepper.targets) or any(
            v.shape != t.value.shape
            for v, t in zip(velocities, stepper.targets)):
        raise SceneError(f"restore: {path} holds velocities of other targets "
                         f"than the stepper's")
    world = [arrays[f"world_velocity|{k}"] for k in range(len(stepper.world))
             if f"world_velocity|{k}" in arrays]
    if len(world) != len(stepper.world) or \
            any(f"world_velocity|{len(world)}" == k for k in arrays) or any(
            v.shape != w.velocity.shape for v, w in zip(world, stepper.world)):
        raise SceneError(f"restore: {path} holds world velocities of other "
                         f"world inertias than the stepper's")
    adaptive = getattr(stepper.contact, "adaptive", None)
    if (adaptive is None) != ("adaptive" not in arrays):
        raise SceneError(f"restore: {path} and the stepper differ in whether "
                         f"the contact's stiffness is adaptive")
    restore_scene_state(stepper.scene, {
        k[len("scene|"):]: v for k, v in arrays.items()
        if k.startswith("scene|")})
    stepper.velocities = [v.copy() for v in velocities]
    for inertia, v in zip(stepper.world, world):
        inertia.velocity = v.copy()
    stepper.time = float(arrays["time"])
    preconditioner_choice.restore(stepper.scene,
                                  arrays.get("preconditioner_choice"))
    if adaptive is not None:
        kappa, max_kappa, previous = (float(x) for x in arrays["adaptive"])
        adaptive.kappa = None if np.isnan(kappa) else kappa
        adaptive.max_kappa = max_kappa
        adaptive.previous = None if np.isnan(previous) else previous
