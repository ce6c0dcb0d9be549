"""The control loop's settings (a profile's `control:` block), typed.

CONTROL_SECTION validates the block and documents it (docs/profiles.md); ControlSettings
holds the validated values, one field per key, so the code reads `control.rate_hz`, never
a string key.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from hand_service.config.rates import RATE_MAX_HZ, RATE_MIN_HZ
from hand_service.config.schema import Key, Section

CONTROL_SECTION = Section("Control", "`control:` — the control loop.", (
    Key("rate_hz", "control rate", "float", "Hz", 100.0, RATE_MIN_HZ, RATE_MAX_HZ),
    Key("filter_order", "Butterworth order on the angle", "int", "", 2, 2, 4, choices=("2", "4")),
    Key("filter_cutoff_hz", "Butterworth cutoff; keep above the fingers' 9–14 Hz, and below half "
        "rate_hz", "float", "Hz",
        25.0, 0.0, None, True),
    Key("velocity_cutoff_hz", "low-pass on the velocity and acceleration estimates", "float", "Hz",
        25.0, 0.0, None, True),
    Key("derivative_cutoff_hz", "low-pass on the PID's derivative term", "float", "Hz", 10.0, 0.0,
        None, True),
    Key("feedforward", "model inversion in position mode", "choice",
        default="dynamic", choices=("none", "quasi_static", "dynamic")),
    Key("force_estimate", "static: (J^T)+(Np − kθ); dynamic adds −Bθ' − Aθ''", "choice",
        default="static", choices=("static", "dynamic")),
    Key("force_estimate_hysteresis", "the force estimate and force feedforward carry the model's "
        "hysteresis loop, driven by the filtered angle (force and impedance modes); only where "
        "the finger has the loop: one it lacks is positive feedback", "bool", default=False),
    Key("integrator_limit_kpa", "bound on the PID and force-PI integrators", "float", "kPa", 50.0,
        0.0),
))


@dataclass(frozen=True)
class ControlSettings:
    """The validated `control:` block (CONTROL_SECTION documents each key and its range)."""

    rate_hz: float
    filter_order: int
    filter_cutoff_hz: float
    velocity_cutoff_hz: float
    derivative_cutoff_hz: float
    feedforward: str  # none | quasi_static | dynamic
    force_estimate: str  # static | dynamic
    force_estimate_hysteresis: bool
    integrator_limit_kpa: float

    @classmethod
    def from_values(cls, values: dict[str, Any]) -> ControlSettings:
        """From the section's validated values (every key present, defaults filled)."""
        return cls(**{f.name: values[f.name] for f in dataclasses.fields(cls)})

    def with_rate(self, rate_hz: float) -> ControlSettings:
        return dataclasses.replace(self, rate_hz=rate_hz)

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def cutoff_problem(control: ControlSettings, rate_hz: float) -> str | None:
    """Why the control step cannot filter at rate_hz, or None. Every finger's Butterworth
    filter (control.filter_cutoff_hz) must lie below the Nyquist frequency: the C core
    refuses it otherwise (rtcore_butter_design)."""
    cutoff = control.filter_cutoff_hz
    if cutoff < 0.5 * rate_hz:
        return None
    return (f"control.filter_cutoff_hz = {cutoff:g} Hz must be below half the control rate "
            f"({0.5 * rate_hz:g} Hz at {rate_hz:g} Hz): lower the cutoff or raise the rate")


__all__ = ["CONTROL_SECTION", "ControlSettings", "cutoff_problem"]
