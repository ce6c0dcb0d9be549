"""The simulated angles a recording keeps: diagnose simulates the same finger more than
once, and the simulator is deterministic, so a finger's key (every field's repr) finds
its angles again, bit for bit."""

from __future__ import annotations

import dataclasses
import operator
import threading
from collections.abc import Hashable

import numpy as np

from hand_service.diagnose.model.lru import ByteBudgetLru

SIMULATION_CACHE_BYTES = 64 * 2**20  # the simulated angles a recording keeps (SimulationCache)


def _leaf_paths(obj: object, prefix: str = "") -> list[str]:
    """The dotted names of every field of a (nested) dataclass that is not a dataclass."""
    return [path for f in dataclasses.fields(obj)  # type: ignore[arg-type]
            for path in (_leaf_paths(getattr(obj, f.name), f"{prefix}{f.name}.")
                         if dataclasses.is_dataclass(getattr(obj, f.name)) else [prefix + f.name])]


_LEAVES: dict[type, operator.attrgetter] = {}  # per finger type: all its leaves at once


def finger_key(obj: object) -> tuple[str, ...]:
    """Every field of a (nested) dataclass, each by its repr, which tells every two floats
    apart (0.0 from −0.0 too): two fingers with the same key simulate the same, bit for bit."""
    leaves = _LEAVES.get(type(obj)) or _LEAVES.setdefault(type(obj), operator.attrgetter(*_leaf_paths(obj)))
    values = leaves(obj)
    return tuple(map(repr, values if isinstance(values, tuple) else (values,)))


class SimulationCache:
    """The angles of a recording's recent simulations, by the finger simulated: diagnose
    simulates the same finger more than once (a fit's solution, a Jacobian's columns at a
    point another fit reached, the refit's point again in a second split), and the simulator
    is deterministic, so the angles are the same, bit for bit. The least recently used go
    first, past SIMULATION_CACHE_BYTES; each caller gets its own copy. Thread-safe: the
    effects are fitted side by side (search/forward_selection.py)."""

    def __init__(self, budget_bytes: int = SIMULATION_CACHE_BYTES) -> None:
        self._angles: ByteBudgetLru[np.ndarray] = ByteBudgetLru(budget_bytes)
        self._lock = threading.Lock()
        self._command: np.ndarray | None = None

    def serves(self, command_kpa: np.ndarray) -> bool:
        """Is this the cache of runs on `command_kpa` (the first command asked binds it)? A
        copy of a problem with another command array simulates without it."""
        with self._lock:
            if self._command is None:
                self._command = command_kpa
            return self._command is command_kpa

    def get(self, key: Hashable) -> np.ndarray | None:
        angle = self._angles.get(key)
        return None if angle is None else angle.copy()

    def put(self, key: Hashable, angle_deg: np.ndarray) -> None:
        stored = angle_deg.copy()
        self._angles.put(key, stored, stored.nbytes)

    @property
    def hits(self) -> int:
        return self._angles.hits

    @property
    def misses(self) -> int:
        return self._angles.misses

    def __len__(self) -> int:
        return len(self._angles)
