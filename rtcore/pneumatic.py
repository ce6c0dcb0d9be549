"""The simulator's valve model (csrc/rtcore_pneumatic.h): the first-order lag and dead time
of the finger's effects, or the valve board's pneumatics.

The defaults are the host firmware's plant and regulator (board/plant/plant.c
plant_default_pneumatics, board/core/board.c board_default_config), so a pneumatic
simulated finger is the finger the host build plays; docs/physics.md gives each number's
source. Field names are the C names.
"""

from __future__ import annotations

from dataclasses import dataclass

VALVE_FIRST_ORDER = 0  # RTCORE_VALVE_FIRST_ORDER
VALVE_PNEUMATIC = 1  # RTCORE_VALVE_PNEUMATIC
VALVE_MODELS = {"first_order": VALVE_FIRST_ORDER, "pneumatic": VALVE_PNEUMATIC}


@dataclass
class PneumaticValves:
    """A chamber between a supply and the atmosphere through an inlet and an exhaust on/off
    valve, driven by the board's PWM pressure regulator. Ignored with valve_model 0."""

    valve_model: int = VALVE_FIRST_ORDER
    supply_kpa: float = 350.0
    atmosphere_kpa: float = 101.325
    temperature_k: float = 293.15
    polytropic_index: float = 1.2
    dead_volume_ml: float = 10.0
    inlet_conductance_dm3_per_s_bar: float = 0.05
    inlet_critical_ratio: float = 0.3
    inlet_open_delay_s: float = 0.002
    inlet_close_delay_s: float = 0.0015
    exhaust_conductance_dm3_per_s_bar: float = 0.07
    exhaust_critical_ratio: float = 0.3
    exhaust_open_delay_s: float = 0.002
    exhaust_close_delay_s: float = 0.0015
    regulator_period_us: int = 1000
    pwm_period_us: int = 10000
    min_pulse_us: int = 3000
    deadband_kpa: float = 1.0
    gain_permille_per_kpa: float = 60.0
    vent_below_kpa: float = 0.5
    step_us: int = 50


def pneumatic_valves(**overrides: float) -> PneumaticValves:
    """The board's pneumatics (valve_model pneumatic), with `overrides` by field name."""
    return PneumaticValves(**{"valve_model": VALVE_PNEUMATIC, **overrides})
