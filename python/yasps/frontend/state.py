"""What the layers above the frontend keep per scene, in one object the
scene owns (``Scene.state``).

The IR emitted for kernels, the plans of factored energies and of the
total energy, the Newton system and the local derivatives of its last
point, the preconditioner's choice, the warnings given once: each is kept
under a :class:`StateKey` that the module keeping it declares, typed by
what it holds. They go with the scene (no module-level table of scenes),
and ``scene.state`` shows what a scene holds.
"""

from __future__ import annotations

from typing import Any, Callable, Dict, Generic, List, Optional, TypeVar

T = TypeVar("T")


class StateKey(Generic[T]):
    """A slot of :class:`SceneState`, declared once by the module that
    keeps what it holds (compared by identity)."""

    def __init__(self, description: str):
        #: what the slot holds, for ``repr(scene.state)``
        self.description = description

    def __repr__(self) -> str:
        return f"StateKey({self.description!r})"


class SceneState:
    """Per-scene state of the layers above the frontend, one value per
    :class:`StateKey`."""

    def __init__(self) -> None:
        self._slots: Dict[StateKey[Any], Any] = {}

    def get(self, key: StateKey[T]) -> Optional[T]:
        """The value under ``key``, None if there is none."""
        return self._slots.get(key)

    def set(self, key: StateKey[T], value: T) -> T:
        """Keeps ``value`` under ``key`` and returns it."""
        self._slots[key] = value
        return value

    def setdefault(self, key: StateKey[T], make: Callable[[], T]) -> T:
        """The value under ``key``, made by ``make()`` and kept if there is
        none."""
        if key not in self._slots:
            self._slots[key] = make()
        return self._slots[key]

    def pop(self, key: StateKey[T]) -> Optional[T]:
        """Removes and returns the value under ``key`` (None if none)."""
        return self._slots.pop(key, None)

    def __contains__(self, key: StateKey[Any]) -> bool:
        return key in self._slots

    def clear(self) -> None:
        """Drops everything: the next use of the scene rebuilds what it
        needs (kernels stay in the compiler's caches)."""
        self._slots.clear()

    def held(self) -> List[str]:
        """What the scene holds, by the descriptions of their keys."""
        return [key.description for key in self._slots]

    def __repr__(self) -> str:
        held = "; ".join(self.held()) or "nothing"
        return f"<yasps scene state: {held}>"
