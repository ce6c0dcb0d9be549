"""The model check: is what the sensors say something the finger's own model can explain?

Beside the control loop, each finger's PRBM (A θ'' + B θ' + k θ = N p, docs/physics.md §1)
is run from the chamber pressure the board measures (or, where it measures none, from
the commanded pressure through the valve's dead time and lag), one exact discrete step
per board sample: between two samples the chamber moves as the model's valve lag moves
it (a first-order approach that ends at the second measurement; a straight line with no
lag). The innovation, the measured angle less the predicted one, stays within a bound
the model itself gives:

    bound = u·(|θ| + |s_k| + |s_B| + |s_A|)        the parameters' uncertainty u on k, B, N
                                                   and A, to first order (s_N = θ)
          + the effects the linear model leaves out   their torque against k
          + 5·σ                                    the noise: the flex sensor's and what the
                                                   prediction makes of the pressure sensor's
          + model_margin_deg                       the rest

where s_X = ∂θ/∂ln X are the sensitivities, run beside the prediction as two more
second-order states (s_k driven by −kθ, s_B by −Bθ'; s_A = −θ − s_k − s_B, since scaling
every parameter alike changes nothing). A stuck or disconnected sensor, a blocked or
broken finger, a pressure sensor that freezes: each leaves an innovation the model
cannot explain. Beyond the bound for model_mismatch_ms: a fault.

The check runs per finger while the supervisor drives the hand (RUNNING, HOLD) in
position and pressure modes. In force mode the finger presses on an object, which the
model does not know: it is not checked, and its prediction starts again from the
measured angle, at rest, when it leaves force mode, as every finger's does on arming (and
so after a fault reset), and after a gap of more than MAX_STEPS samples. At rest: the
control step's velocity estimate is not yet settled just after a handshake, and a finger
that leaves an object or starts a sweep starts from rest. A NaN chamber pressure where
safety.pressure_measured says the board measures one is a fault of its own (pressure_lost).
The arithmetic is one matrix product per finger (model_step.py) and about fifteen numpy
operations per sample; the supervisor runs it after the command went out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hand_service.config.effects import effect_value
from hand_service.config.model import FingerModel
from hand_service.config.profile import Profile
from hand_service.service.model_step import OMEGA, STATE, SUM, THETA, discretize
from hand_service.service.sensor_trend import SensorTrend
from rtcore import MODE_POSITION, MODE_PRESSURE, Hand

# samples the prediction runs through without a measurement (the board holding the command
# sent last): after a longer gap it starts again from the measurement, for what the board did
# meanwhile is not known (commands sent on old samples, a board that caught up in a burst)
MAX_STEPS = 2
MODEL_CATCH_UP = 100  # samples the modelled chamber lives through at most after a gap
NOISE_SIGMAS = 5.0  # the bound allows the innovation's noise this many standard deviations
DRIFT_NOISE_SIGMAS = 3.0  # a drift must have moved the smoothed innovation this far, with the margin
DEG = math.pi / 180.0
P0, P1 = STATE, STATE + 1  # the chamber's columns, after the state's


@dataclass(frozen=True)
class Mismatch:
    """What the check found: `cause` is the name of the supervisor's fault cause."""

    cause: str  # implausible | pressure_lost
    finger: int
    detail: str


class ModelCheck:
    def __init__(self, profile: Profile, rate_hz: float | None = None) -> None:
        safety = profile.safety
        rate_hz = float(rate_hz or profile.control.rate_hz)
        self.period_s = dt = 1.0 / rate_hz
        models = [f.model for f in profile.fingers]
        n = len(models)
        self.stiffness = np.array([m.stiffness_nm_per_rad for m in models], dtype=float)
        self.gain = np.array([m.pressure_gain_nm_per_kpa for m in models], dtype=float)
        steps = [discretize(m, dt) for m in models]
        self.map = np.array([s.state_map(m.stiffness_nm_per_rad, m.damping_nms_per_rad)  # type: ignore[arg-type]
                             for s, m in zip(steps, models, strict=True)])
        self.alpha = np.array([s.alpha for s in steps])
        self.uncertainty = safety["model_uncertainty_percent"] / 100.0
        self.margin_rad = safety["model_margin_deg"] * DEG
        self.persist_samples = max(1, math.ceil(safety["model_mismatch_ms"] / 1e3 * rate_hz - 1e-9))
        self._innovation_deg = np.zeros(n)
        self.pressure_measured = bool(safety["pressure_measured"])
        self._effects(models)
        self.noise_rad = np.array([s.noise_rad(safety["angle_noise_deg"] * DEG, safety["pressure_noise_kpa"])
                                   for s in steps])
        # the bound's part that never changes
        self.floor_rad = self.static_rad + NOISE_SIGMAS * self.noise_rad + self.margin_rad
        # a trend judged only where the sensor has left the model by more than its noise makes
        level_deg = (DRIFT_NOISE_SIGMAS * self.noise_rad + self.margin_rad) / DEG
        natural_rad_per_s = np.array([m.natural_freq_rad_per_s for m in models])
        self.trend = SensorTrend(n, dt, float(safety["sensor_drift_max_deg_per_s"]), self.persist_samples,
                                 level_deg, natural_rad_per_s, self._slow_noise_deg(safety))
        self.dead_samples = np.array([round(effect_value(m.effects, "dead_time") * rate_hz)
                                      for m in models])
        self._commands = np.zeros((int(self.dead_samples.max()) + 1, n))  # newest first
        self._columns = np.arange(n)
        # per finger: the prediction, its sensitivities and their sum, their rates (rad, rad/s),
        # then the chamber over the step being taken [p0, p1] (kPa): p1 is the chamber at the
        # sample checked last
        self.state = np.zeros((n, STATE + 2))
        self._column = self.state[:, :, None]  # views, made once: the step writes through them
        self._next = np.zeros((n, STATE, 1))
        self._moved, self._new = self.state[:, :STATE], self._next[:, :, 0]
        self._sensitive = self.state[:, :SUM + 1]  # θ, s_k, s_B, Σ = −s_A
        self._theta = self.state[:, THETA]
        self._weights = np.full(SUM + 1, self.uncertainty)
        self._abs = np.zeros((n, SUM + 1))
        self._ratio = np.zeros(n)
        self.armed = np.zeros(n, dtype=bool)  # the prediction runs from a measurement
        self._steady = False  # armed is what the modes check: no finger starts
        self.run = np.zeros(n, dtype=np.int64)  # samples in a row beyond the bound
        self._running = False  # some finger is beyond it
        self._held_kpa = np.zeros(n)  # the command sent after the last sample, which the board holds
        self.worst_ratio = np.zeros(n)  # the largest |innovation| / bound seen (checked samples)
        self.worst_innovation_deg = np.zeros(n)
        self.worst_bound_deg = np.zeros(n)
        self._worst_floor = 0.0  # the smallest of worst_ratio, of the fingers checked so far
        self.samples = 0  # checked finger-samples, for the statistics
        self.sequence: int | None = None  # the board sequence of the sample checked last
        self.newest: int | None = None  # the newest sample's, where the tick runs in Python
        self._modes = b""
        self._checked = np.zeros(n, dtype=bool)
        self._n_checked = 0
        self._unchecked_mask: np.ndarray | None = None  # 0 where a finger is not checked

    def _effects(self, models: list[FingerModel]) -> None:
        """The effects a linear model leaves out, as the angle (rad) their torque is worth
        against the stiffness: a static part, and terms that grow with θ or θ'."""
        k = self.stiffness
        value = np.array([[effect_value(m.effects, name) for m in models] for name in
                          ("coulomb_friction", "pressure_deadzone", "gravity", "cubic_stiffness",
                           "asymmetric_stiffness", "quadratic_damping")])
        coulomb, deadzone, gravity, cubic, ratio, drag = value
        self.static_rad = (coulomb + self.gain * deadzone) / k
        self.gravity_rad = np.abs(gravity) / k
        self.cubic_per_rad2 = np.abs(cubic) / k
        self.asymmetry = np.abs(ratio - 1.0)
        self.drag_s2 = drag / k
        self.live_effects = bool(np.any(value[2:4]) or np.any(self.asymmetry) or np.any(drag))

    def _slow_noise_deg(self, safety: dict) -> np.ndarray:
        """The innovation's noise as a trend meets it: its white-equivalent density at low
        frequency (deg), the flex sensor's and the pressure sensor's through the static gain
        N/k (the prediction's ringing on that noise is far above a trend's band)."""
        pressure_deg = self.gain / self.stiffness * safety["pressure_noise_kpa"] / DEG
        return np.hypot(safety["angle_noise_deg"], pressure_deg)

    @property
    def predicted_deg(self) -> np.ndarray:
        return self.state[:, THETA] / DEG

    @property
    def last_kpa(self) -> np.ndarray:
        """The chamber at the sample checked last (measured, or modelled where none is)."""
        return self.state[:, P1]

    def reset(self) -> None:
        """Every finger's prediction starts again from its next measurement (a handshake)."""
        self.armed[:] = False
        self._steady = False
        self.run[:] = 0
        self._running = False
        self.sequence = self.newest = None

    def sample(self, sequence: int | None, active: bool, hand: Hand,
               command_kpa: np.ndarray) -> Mismatch | None:
        """The supervisor's tick is done: check its sample if it is new (its board sample
        count differs from the last one checked; None: `newest`, which a tick in Python
        sets). `hand`: the control step, whose inputs and outputs hold the sample and what
        the step made of it."""
        sequence = self.newest if sequence is None else sequence
        last, self.sequence = self.sequence, sequence
        if sequence is None or sequence == last:
            return None
        steps = 1 if last is None else sequence - last if sequence > last else MAX_STEPS + 1
        inputs, outputs = hand.inputs, hand.outputs
        return self.observe(steps, active, inputs.mode, outputs.angle_deg, inputs.pressure_meas_kpa,
                            command_kpa)

    def _checked_modes(self, mode: np.ndarray) -> np.ndarray:
        raw = mode.tobytes()
        if raw != self._modes:  # the modes change seldom: compare them as bytes
            self._modes = raw
            self._checked = (mode == MODE_POSITION) | (mode == MODE_PRESSURE)
            self._n_checked = int(self._checked.sum())
            self._unchecked_mask = None if self._checked.all() else self._checked.astype(float)
            self._steady = False
        return self._checked

    def observe(self, steps: int, active: bool, mode: np.ndarray, angle_deg: np.ndarray,
                pressure_kpa: np.ndarray, command_kpa: np.ndarray) -> Mismatch | None:
        """A new board sample, `steps` sample periods after the one before. `active`: the
        supervisor drives the hand (RUNNING, HOLD); `mode`, the fingers' rtcore modes;
        `command_kpa`, the command just sent (it acts from this sample on)."""
        nan = None
        if math.isnan(pressure_kpa.sum()):
            nan = np.isnan(pressure_kpa)
            if self.pressure_measured:
                i = int(np.flatnonzero(nan)[0])
                return Mismatch("pressure_lost", i, "the board reports no chamber pressure (NaN) where "
                                "it measures one (safety.pressure_measured)")
        checked = self._checked_modes(mode) if active and steps <= MAX_STEPS else None
        if checked is None or not self._n_checked:
            self.armed[:] = False
            self._steady = False
            if self._running:
                self.run[:] = 0
                self._running = False
            self._chamber(steps, pressure_kpa, nan, command_kpa, predict=False)
            return None
        if self._steady and steps == 1 and nan is None:  # the common sample: its own short path
            level = self._next_sample(angle_deg, pressure_kpa, command_kpa)
            return level or self._trend(1, angle_deg, checked)
        start = None
        if not self._steady:
            start = checked & ~self.armed
            self.state[start, :STATE] = 0.0
            self.state[start, THETA] = self.state[start, SUM] = angle_deg[start] * DEG
            # the restarted prediction moves the innovation by what the model's error had made
            # of it before: a step the trend's past would read as a trend
            self.trend.restart(start)
            self.armed[:] = checked
            self._steady = True
        self._chamber(steps, pressure_kpa, nan, command_kpa, predict=True)
        return self._compare(start, angle_deg, nan, steps) or self._trend(steps, angle_deg, checked)

    def _trend(self, steps: int, angle_deg: np.ndarray, checked: np.ndarray) -> Mismatch | None:
        """The innovation's trend (sensor_trend.py): a sensor drifting from the model."""
        innovation = self._innovation_deg
        np.multiply(self._theta, 1.0 / DEG, out=innovation)
        np.subtract(angle_deg, innovation, out=innovation)
        trend = self.trend
        i = trend.sample(steps, innovation, self.state[:, :SUM], self.state[:, OMEGA], checked)
        if i is None:
            return None
        return Mismatch("implausible", i, (
            f"the sensor drifts from the model at {trend.trend_deg_per_s[i]:+.1f} deg/s for "
            f"{trend.run[i] * self.period_s * 1e3:.0f} ms (sensor_drift_max_deg_per_s "
            f"{trend.limit_deg_per_s:g}; it reads {angle_deg[i]:.1f} deg, the model predicts "
            f"{self._theta[i] / DEG:.1f} deg): a drifting or loosening flex sensor"))

    def _next_sample(self, angle_deg: np.ndarray, pressure_kpa: np.ndarray,
                     command_kpa: np.ndarray) -> Mismatch | None:
        """What _chamber and _compare do for one step on measured pressures, in as few numpy
        calls as they take (each costs microseconds on a cache the tick left cold)."""
        state = self.state
        state[:, P0] = state[:, P1]
        state[:, P1] = pressure_kpa
        np.matmul(self.map, self._column, out=self._next)
        self._moved[...] = self._new
        self._held_kpa[:] = command_kpa
        if self.live_effects or not self.pressure_measured:
            return self._compare(None, angle_deg, None, 1)
        np.abs(self._sensitive, out=self._abs)
        bound = self._abs @ self._weights
        bound += self.floor_rad
        ratio = self._ratio
        np.multiply(angle_deg, DEG, out=ratio)
        ratio -= self._theta
        np.abs(ratio, out=ratio)
        ratio /= bound
        if self._unchecked_mask is not None:
            ratio *= self._unchecked_mask
        self.samples += self._n_checked
        largest = ratio.max()
        if largest <= min(1.0, self._worst_floor) and not self._running:  # no worse, none beyond
            return None
        return self._judge(ratio, bound, angle_deg, None, 1)

    def _chamber(self, steps: int, pressure_kpa: np.ndarray, nan: np.ndarray | None,
                 command_kpa: np.ndarray, predict: bool) -> None:
        """The chamber from the last sample to this one (measured, or where none is, modelled),
        and the prediction through it. Samples that never came in between (lost, or passed
        while the host was late) follow the command the board held through the valve's lag."""
        state = self.state
        if not predict:  # only where the chamber is: the measurement, or the model's (a while)
            steps = 1 if nan is None else min(steps, MODEL_CATCH_UP)
        for j in range(steps, 0, -1):
            state[:, P0] = state[:, P1]
            if j > 1:
                state[:, P1] = self._held_kpa + (state[:, P0] - self._held_kpa) * self.alpha
            elif nan is not None:
                state[:, P1] = np.where(nan, self._valve(state[:, P0]), pressure_kpa)
            else:
                state[:, P1] = pressure_kpa
            if predict:
                np.matmul(self.map, self._column, out=self._next)
                self._moved[...] = self._new
        self._held_kpa[:] = command_kpa
        if not self.pressure_measured:
            self._commands = np.roll(self._commands, 1, axis=0)
            self._commands[0] = command_kpa

    def _valve(self, chamber_kpa: np.ndarray) -> np.ndarray:
        """The modelled chamber one sample on: the commands, dead_samples late, through the
        valve's first-order lag."""
        late = self._commands[self.dead_samples, self._columns]
        return late + (chamber_kpa - late) * self.alpha

    def bound_rad(self, nan: np.ndarray | None = None) -> np.ndarray:
        """The bound on the innovation (rad) for the prediction as it stands; `nan`: the
        fingers whose chamber is modelled, not measured."""
        np.abs(self._sensitive, out=self._abs)  # u·(|θ| + |s_k| + |s_B| + |s_A|)
        bound = self._abs @ self._weights
        bound += self.floor_rad
        if self.live_effects:
            theta, omega = self.state[:, THETA], self.state[:, OMEGA]
            bound += (self.gravity_rad * (1.0 - np.cos(theta)) + self.cubic_per_rad2 * np.abs(theta) ** 3
                      + self.asymmetry * np.maximum(-theta, 0.0) + self.drag_s2 * omega * omega)
        if nan is not None:  # the valve known to u too: u·τ·|ṗ| = u·|p_in − p| of pressure
            late = self._commands[self.dead_samples, self._columns]
            bound += np.where(nan, self.uncertainty * self.gain / self.stiffness
                              * np.abs(late - self.last_kpa), 0.0)
        return bound

    def _compare(self, start: np.ndarray | None, angle_deg: np.ndarray, nan: np.ndarray | None,
                 steps: int) -> Mismatch | None:
        bound = self.bound_rad(nan)
        ratio = self._ratio
        np.multiply(angle_deg, DEG, out=ratio)
        ratio -= self._theta
        np.abs(ratio, out=ratio)
        ratio /= bound
        judged = self._n_checked
        if self._unchecked_mask is not None:
            ratio *= self._unchecked_mask
        if start is not None and start.any():  # a finger just started: nothing to judge yet
            ratio[start] = 0.0
            judged -= int(start.sum())
        self.samples += judged
        return self._judge(ratio, bound, angle_deg, nan, steps)

    def _judge(self, ratio: np.ndarray, bound: np.ndarray, angle_deg: np.ndarray,
               nan: np.ndarray | None, steps: int) -> Mismatch | None:
        """Keep the worst ratio seen; count the samples beyond the bound in a row; a fault
        once a finger's run reaches model_mismatch_ms."""
        largest = ratio.max()
        if largest > self._worst_floor:
            better = ratio > self.worst_ratio
            self.worst_ratio[better] = ratio[better]
            self.worst_innovation_deg[better] = (angle_deg[better] * DEG - self._theta[better]) / DEG
            self.worst_bound_deg[better] = bound[better] / DEG
            seen = self.worst_ratio[self.worst_ratio > 0.0]  # fingers never checked stay out of it
            self._worst_floor = float(seen.min()) if seen.size else 0.0
        if not largest > 1.0:
            if self._running:
                self.run[:] = 0
                self._running = False
            return None
        self.run = np.where(ratio > 1.0, self.run + steps, 0)
        self._running = True
        if not (self.run >= self.persist_samples).any():
            return None
        i = int(np.argmax(self.run))
        source = "modelled" if nan is not None and nan[i] else "measured"
        return Mismatch("implausible", i, (
            f"the sensor reads {angle_deg[i]:.1f} deg where the model predicts "
            f"{self.state[i, THETA] / DEG:.1f} deg from the {source} chamber pressure "
            f"{self.last_kpa[i]:.1f} kPa, outside ±{bound[i] / DEG:.1f} deg for "
            f"{self.run[i] * self.period_s * 1e3:.0f} ms (model_mismatch_ms "
            f"{self.persist_samples * self.period_s * 1e3:.0f}): a stuck or disconnected "
            "sensor, a blocked finger, or a model that no longer fits"))
