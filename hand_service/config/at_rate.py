"""The profile at another control rate (`run --rate`, `bench --rate`)."""

from __future__ import annotations

import copy

from hand_service.config.control import cutoff_problem
from hand_service.config.profile import Profile
from hand_service.config.rates import RATE_MAX_HZ, RATE_MIN_HZ
from hand_service.errors import UserError


def with_rate(profile: Profile, rate_hz: float | None) -> Profile:
    """The profile at another control rate (a copy); the simulated hand follows it. The rate
    must lie in the supported range and above twice the filter cutoff. A board
    on a bus samples on its own clock at the rate its profile states, and the control step,
    its filters and its safety counts must run at that rate: another is refused."""
    if rate_hz is None or rate_hz == profile.control.rate_hz:
        return profile
    if not RATE_MIN_HZ <= rate_hz <= RATE_MAX_HZ:
        raise UserError(f"--rate must be between {RATE_MIN_HZ:g} and {RATE_MAX_HZ:g} Hz, not {rate_hz:g}")
    problem = cutoff_problem(profile.control, rate_hz)
    if problem is not None:
        where_set = profile.lines.get("control.filter_cutoff_hz", str(profile.path))
        raise UserError(f"--rate {rate_hz:g} Hz: {problem} (cutoff set at {where_set})")
    if profile.transport["kind"] != "sim":
        raise UserError(
            f"--rate {rate_hz:g} Hz: the firmware behind profile '{profile.name}' samples at "
            f"{profile.control.rate_hz:g} Hz on its own clock (control.rate_hz, {profile.path}); "
            f"the rate a firmware samples at is a property of the firmware, and the control tick "
            f"must match it. --rate is for the simulated hand (transport sim); for a board that "
            f"samples at another rate, set control.rate_hz in its profile")
    changed = copy.copy(profile)
    changed.control = profile.control.with_rate(float(rate_hz))
    return changed
