"""The effects by name: the project's (builtin.py) and those a lab's package declares in the
`hand_service.effects` entry point group, each entry an `Effect` or a callable returning
one or a sequence of them:

    # the lab's pyproject.toml
    [project.entry-points."hand_service.effects"]
    end_stop = "lab_effects:END_STOP"

Discovered once, on first use (`refresh` looks again). A lab's effect may not reuse a
project name; two with one name are refused, naming both.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from importlib.metadata import EntryPoint, entry_points

from hand_service.effects.base import Effect
from hand_service.effects.builtin import BUILTIN
from hand_service.errors import UserError

ENTRY_POINT_GROUP = "hand_service.effects"

_registered: dict[str, Effect] = {}
_origin: dict[str, str] = {}
_discovered = False


def register(effect: Effect, origin: str = "") -> Effect:
    """Add `effect` under its name; UserError if the name is taken by another effect."""
    if not isinstance(effect, Effect):
        raise UserError(f"{origin or 'an effect'}: {effect!r} is not a hand_service.effects.Effect")
    taken = _registered.get(effect.name)
    if taken is not None and taken != effect:
        raise UserError(f"effect '{effect.name}' from {origin or 'a caller'} clashes with the one from "
                        f"{_origin[effect.name]}")
    _registered[effect.name] = effect
    _origin[effect.name] = origin or "a caller"
    return effect


def _loaded(entry: EntryPoint) -> Iterable[Effect]:
    origin = f"entry point {entry.name} = {entry.value}"
    try:
        value = entry.load()
    except Exception as exc:  # a lab's package that cannot import is said, not swallowed
        raise UserError(f"{origin}: cannot load it: {exc}") from exc
    if isinstance(value, Callable) and not isinstance(value, Effect):  # type: ignore[arg-type]
        value = value()
    effects = [value] if isinstance(value, Effect) else list(value)
    for effect in effects:
        register(effect, origin)
    return effects


def _discover() -> None:
    global _discovered
    if _discovered:
        return
    for effect in BUILTIN:
        register(effect, "hand_service")
    _discovered = True  # set before the entry points: one that fails is not loaded twice
    for entry in sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
        _loaded(entry)


def refresh() -> None:
    """Forget what was discovered and look again (a package installed since)."""
    global _discovered
    _registered.clear()
    _origin.clear()
    _discovered = False
    _discover()


def library() -> tuple[Effect, ...]:
    """Every effect: the project's in their order, then the labs' by name."""
    _discover()
    return tuple(_registered.values())


def by_name() -> dict[str, Effect]:
    """The registry itself (read it; `register` adds to it)."""
    _discover()
    return _registered


def origin(name: str) -> str:
    _discover()
    return _origin[name]
