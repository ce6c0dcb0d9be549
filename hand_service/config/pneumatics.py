"""The simulated hand's valve model: `simulation.valve_model` and `simulation.pneumatics`.

`first_order` (the default) is the valve of every finger's effects: a first-order lag behind
a dead time. `pneumatic` runs each finger's chamber as the valve board's physics instead
(csrc/rtcore_pneumatic.h over board/plant/pneumatics.c and board/core/regulator.c): a supply,
ISO 6358 orifices, a polytropic chamber that grows with the bend angle and on/off valves with
switching delays, driven by the board's PWM pressure regulator. The lag and dead time are then
emergent; the finger's valve_lag and dead_time stay what the controller's feedforward assumes.
The defaults are the host firmware's plant and regulator (rtcore/pneumatic.py).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from hand_service.config.schema import Key, Section, expect_mapping, fail, validate
from rtcore.pneumatic import VALVE_MODELS, PneumaticValves

_D = PneumaticValves()

VALVE_MODEL_KEYS = (
    Key("valve_model", "the simulated valve: `first_order` (each finger's valve_lag and dead_time) or "
        "`pneumatic` (the valve board's chamber physics and regulator, see Pneumatics)", "choice",
        default="first_order", choices=tuple(VALVE_MODELS)),
    Key("pneumatics", "the pneumatic valve model's parameters (see Pneumatics)", "mapping", default=None),
)


def _valve_keys(side: str, default_conductance: float) -> tuple[Key, ...]:
    return (
        Key(f"{side}_conductance_dm3_per_s_bar", f"{side} valve's ISO 6358 sonic conductance C", "float",
            "dm³/(s·bar)", default_conductance, 0.0, 1000.0, True),
        Key(f"{side}_critical_ratio", f"{side} valve's ISO 6358 critical pressure ratio b", "float", "",
            getattr(_D, f"{side}_critical_ratio"), 0.0, 0.99),
        Key(f"{side}_open_delay_s", f"{side} valve's delay from the command to open", "float", "s",
            getattr(_D, f"{side}_open_delay_s"), 0.0, 1.0),
        Key(f"{side}_close_delay_s", f"{side} valve's delay from the command to shut", "float", "s",
            getattr(_D, f"{side}_close_delay_s"), 0.0, 1.0),
    )


PNEUMATICS_SECTION = Section(
    "Pneumatics", "`simulation.pneumatics:` — the chamber, its valves and the board's regulator, used "
    "with `valve_model: pneumatic` (docs/physics.md, the pneumatic valve). Every finger gets the same; "
    "each chamber grows by its finger's pressure gain N per radian.", (
        Key("supply_kpa", "supply pressure (gauge)", "float", "kPa", _D.supply_kpa, 0.0, 10000.0, True),
        Key("atmosphere_kpa", "atmospheric pressure (absolute)", "float", "kPa", _D.atmosphere_kpa, 1.0,
            1000.0),
        Key("temperature_k", "air temperature, supply and chamber", "float", "K", _D.temperature_k, 1.0,
            1000.0),
        Key("polytropic_index", "n: 1 isothermal, 1.4 adiabatic", "float", "", _D.polytropic_index, 1.0,
            1.4),
        Key("dead_volume_ml", "the chamber and its tubing at angle 0", "float", "mL", _D.dead_volume_ml,
            0.0, 1e6, True),
        *_valve_keys("inlet", _D.inlet_conductance_dm3_per_s_bar),
        *_valve_keys("exhaust", _D.exhaust_conductance_dm3_per_s_bar),
        Key("regulator_period_us", "the board's pressure loop period (>= 500 Hz)", "int", "µs",
            _D.regulator_period_us, 1, 2000),
        Key("pwm_period_us", "the valves' PWM period", "int", "µs", _D.pwm_period_us, 1, 1000000),
        Key("min_pulse_us", "the shortest valve pulse the regulator gives", "int", "µs", _D.min_pulse_us,
            0, 1000000),
        Key("deadband_kpa", "no valve moves while the error is within it", "float", "kPa", _D.deadband_kpa,
            0.0, 1000.0),
        Key("gain_permille_per_kpa", "PWM duty per kPa of error", "float", "‰/kPa",
            _D.gain_permille_per_kpa, 0.0, 1e6, True),
        Key("vent_below_kpa", "a command at or below it vents the chamber", "float", "kPa",
            _D.vent_below_kpa, -1000.0, 1000.0),
        Key("step_us", "integration step; divides both periods", "int", "µs", _D.step_us, 1, 100),
    ))


def check_pneumatics(simulation: dict[str, Any], source: str | Path, block: Any) -> None:
    """Replace simulation["pneumatics"] (None or the file's mapping) by its checked values."""
    given = simulation["pneumatics"]
    context = "simulation.pneumatics"
    mapping = {} if given is None else expect_mapping(given, source, block, "pneumatics", context)
    values = validate(mapping, PNEUMATICS_SECTION, source, context)
    for period in ("regulator_period_us", "pwm_period_us"):
        if values[period] % values["step_us"]:
            raise fail(source, mapping, period, f"{context}.{period} = {values[period]} must be a whole "
                       f"number of step_us ({values['step_us']})")
    if values["min_pulse_us"] > values["pwm_period_us"]:
        raise fail(source, mapping, "min_pulse_us", f"{context}.min_pulse_us must not exceed pwm_period_us")
    simulation["pneumatics"] = values


def valves_for(simulation: dict[str, Any]) -> PneumaticValves:
    """The C simulator's valve model of a checked `simulation:` section."""
    return PneumaticValves(valve_model=VALVE_MODELS[simulation.get("valve_model", "first_order")],
                           **(simulation.get("pneumatics") or {}))


__all__ = ["PNEUMATICS_SECTION", "VALVE_MODEL_KEYS", "check_pneumatics", "valves_for"]
