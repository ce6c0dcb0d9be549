"""Checks of command-line values that argparse's types cannot express (a range, a finite
number), each a one-line UserError naming the flag. Called from the commands' main()."""

from __future__ import annotations

import math

from hand_service.errors import UserError

PORT_MAX = 65535


def seed(value: int | None, flag: str = "--seed") -> None:
    """A simulator seed: the range of a profile's simulation.seed."""
    if value is None:
        return
    from hand_service.config.profile import SIMULATION_SECTION

    key = SIMULATION_SECTION.by_name()["seed"]
    if not key.min <= value <= key.max:  # type: ignore[operator]
        raise UserError(f"{flag} must be a whole number from {key.min:g} to {int(key.max)}, not {value}")


def tcp_port(value: int | None, flag: str = "--tcp-port", allow_any: bool = False) -> None:
    """A TCP port on the loopback; 0 (any free port) only where a server may pick one."""
    low = 0 if allow_any else 1
    if value is not None and not low <= value <= PORT_MAX:
        extra = " (0: any free port)" if allow_any else ""
        raise UserError(f"{flag} must be {low} to {PORT_MAX}{extra}, not {value}")


def positive(value: float | None, flag: str, unit: str = "s") -> None:
    """A finite, positive amount (a duration, say); None is allowed (not given)."""
    if value is not None and not (0.0 < value < math.inf):
        raise UserError(f"{flag} must be a positive number of {unit}, not {value:g}")
