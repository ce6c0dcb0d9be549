"""The simulated hand in C (csrc/rtcore_sim*.c) through cffi.

    sim = Simulator([SimFinger(...), ...], sample_rate_hz=100, substeps=10, seed=1)
    sim.command_kpa[:] = p          # numpy view, mapped once
    sim.step()                      # one sample period
    sim.outputs.sensor_mv           # what the sensors read at the end of it

`simulate()` runs one finger noise-free over a whole command series, for fitting.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field

import numpy as np

from rtcore._rtcore import ffi, lib
from rtcore.config import ConfigError, HasPrbm, Prbm
from rtcore.hand import _fill, error_message, struct_view
from rtcore.pneumatic import PneumaticValves


@dataclass
class SimFinger(HasPrbm):
    """The truth for one simulated finger: its PRBM (the controller's `Prbm`), the valve's
    supply, an optional object and the sensor. Field names are the C names."""

    prbm: Prbm
    supply_min_kpa: float = 0.0
    supply_max_kpa: float = 300.0
    contact_angle_deg: float = 0.0
    contact_stiffness_n_per_m: float = 0.0
    contact_damping_ns_per_m: float = 0.0
    # a loop in the angle (hysteresis in the material): −torque·z, z turning toward the
    # direction of travel within about travel_deg (Dahl's form); 0 means none
    hysteresis_torque_nm: float = 0.0
    hysteresis_travel_deg: float = 0.0
    sensor_gain_deg_per_mv: float = 1.0
    sensor_offset_deg: float = 0.0
    sensor_noise_deg: float = 0.0
    adc_step_mv: float = 0.0
    pressure_noise_kpa: float = 0.0
    pneumatic: PneumaticValves = field(default_factory=PneumaticValves)  # the valve model


@dataclass
class SimOutputs:
    sensor_mv: np.ndarray
    pressure_meas_kpa: np.ndarray
    angle_deg: np.ndarray
    velocity_deg_per_s: np.ndarray
    chamber_pressure_kpa: np.ndarray
    contact_force_n: np.ndarray


def _c_finger(finger: SimFinger) -> object:
    c_finger = ffi.new("rtcore_sim_finger *")
    _fill(c_finger, finger)
    return c_finger


class Simulator:
    """Several fingers stepped together, deterministic for a given seed."""

    def __init__(self, fingers: list[SimFinger], sample_rate_hz: float = 100.0, substeps: int = 10,
                 seed: int = 0) -> None:
        if not 1 <= len(fingers) <= lib.RTCORE_MAX_FINGERS:
            raise ConfigError(f"a simulated hand has 1 to {lib.RTCORE_MAX_FINGERS} fingers")
        self.fingers = fingers
        self.sample_rate_hz = sample_rate_hz
        self._sim = ffi.new("rtcore_sim *")
        config = ffi.new("rtcore_sim_config *")
        config.n_fingers = len(fingers)
        config.sample_rate_hz = sample_rate_hz
        config.substeps = substeps
        config.seed = seed
        for i, finger in enumerate(fingers):
            _fill(config.finger[i], finger)
        code = lib.rtcore_sim_configure(self._sim, config)
        if code != lib.RTCORE_OK:
            raise ConfigError(error_message(code, self._sim.error_finger))
        self._out = ffi.new("rtcore_sim_outputs *")
        self._command = np.zeros(lib.RTCORE_MAX_FINGERS)
        self.command_kpa = self._command[: len(fingers)]
        self.outputs = SimOutputs(**{f.name: struct_view(self._out, f.name, len(fingers))
                                     for f in dataclasses.fields(SimOutputs)})
        command_ptr = ffi.cast("double *", ffi.from_buffer(self._command))
        self._command_ptr = command_ptr
        self.step = functools.partial(lib.rtcore_sim_step, self._sim, command_ptr, self._out)
        self.sample()

    @property
    def c_sim(self) -> object:
        """The rtcore_sim struct (cdata pointer), for a link stepped in C."""
        return self._sim

    @property
    def c_outputs(self) -> object:
        """The rtcore_sim_outputs struct that step() writes."""
        return self._out

    @property
    def c_command(self) -> object:
        """The double * of the command step() holds (command_kpa's memory)."""
        return self._command_ptr

    def sample(self) -> None:
        """Read the sensors without advancing time (the reading before the first tick)."""
        lib.rtcore_sim_sample(self._sim, self._out)

    def set_state(self, finger: int, angle_deg: float, velocity_deg_per_s: float = 0.0,
                  chamber_kpa: float = 0.0) -> None:
        lib.rtcore_sim_set_state(self._sim, finger, angle_deg, velocity_deg_per_s, chamber_kpa)

    @property
    def time_s(self) -> float:
        return float(self._sim.time_s)

    @property
    def n_fingers(self) -> int:
        return len(self.fingers)


def simulate(finger: SimFinger, pressure_cmd_kpa: np.ndarray, sample_rate_hz: float,
             substeps: int = 10, angle0_deg: float = 0.0, velocity0_deg_per_s: float = 0.0,
             chamber0_kpa: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free angle (deg) and chamber pressure (kPa) at every sample; angle[0] is the
    initial angle and angle[k+1] follows command k. `substeps` >= 1 bounds the steps to a
    sample period / substeps; 0 leaves them to the dynamics, several periods long over a
    run of samples that hold one command (csrc/rtcore_sim_span.c)."""
    chamber = np.empty(np.asarray(pressure_cmd_kpa).size)
    angle = _run(finger, pressure_cmd_kpa, sample_rate_hz, substeps, angle0_deg, velocity0_deg_per_s,
                 chamber0_kpa, chamber)
    return angle, chamber


def simulate_angle(finger: SimFinger, pressure_cmd_kpa: np.ndarray, sample_rate_hz: float,
                   substeps: int = 10, angle0_deg: float = 0.0, velocity0_deg_per_s: float = 0.0,
                   chamber0_kpa: float = 0.0) -> np.ndarray:
    """simulate()'s angle alone: the same run, bit for bit, without writing the chamber's
    pressure at every sample (over a run of held samples, one exponential each: a sixth
    of a run at 1 kHz with a valve lag)."""
    return _run(finger, pressure_cmd_kpa, sample_rate_hz, substeps, angle0_deg, velocity0_deg_per_s,
                chamber0_kpa, None)


def _run(finger: SimFinger, pressure_cmd_kpa: np.ndarray, sample_rate_hz: float, substeps: int,
         angle0_deg: float, velocity0_deg_per_s: float, chamber0_kpa: float,
         chamber: np.ndarray | None) -> np.ndarray:
    commands = np.ascontiguousarray(pressure_cmd_kpa, dtype=np.float64)
    n = commands.size
    angle = np.empty(n)
    code = lib.rtcore_sim_run(
        _c_finger(finger), sample_rate_hz, substeps, n,
        ffi.cast("double *", ffi.from_buffer(commands)), angle0_deg, velocity0_deg_per_s, chamber0_kpa,
        ffi.cast("double *", ffi.from_buffer(angle)),
        ffi.NULL if chamber is None else ffi.cast("double *", ffi.from_buffer(chamber)))
    if code != lib.RTCORE_OK:
        raise ConfigError(error_message(code, -1))
    return angle
