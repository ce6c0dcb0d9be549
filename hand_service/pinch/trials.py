"""Pinch trials in closed loop with the daemon's C control step, many at once.

A trial: the person holds the object between the fingertips; the fingers close under
their controller (force mode on the Moore-Penrose estimate, or one constant pressure);
after CLOSING_S the person lets go; the trial succeeds when the object is still held,
neither broken nor slipped out, HOLD_S later. Every finger of every trial is one finger
of an 8-finger rtcore.Hand, so a thousand trials step in a few hundred C calls a tick.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

import rtcore
from hand_service.config.effects import effect_value
from hand_service.config.profile import FingerProfile, Profile
from hand_service.pinch.mismatch import NONE, Mismatch
from hand_service.pinch.objects import PinchObject, Placements
from hand_service.pinch.plant import HELD, RELEASE_S, FingerArrays, ObjectArrays, PinchPlant

PAIRS = (("thumb", "index"), ("thumb", "middle"), ("thumb", "ring"), ("thumb", "little"))
CONTROLLERS = ("force", "pressure")
CLOSING_S = 2.0
HOLD_S = 5.0
SUBSTEPS = 10
DESIGN_ANGLE_RAD = 0.6  # both fingers touch a DESIGN_WIDTH_M object at 34 deg
DESIGN_WIDTH_M = 0.025
CLOSING_RATE_KPA_PER_S = 200.0  # both controllers close at most this fast (docs/replicate.md)


@dataclass
class Cell:
    """n trials of one finger pair, object and controller, each with its own setpoint
    (N for force control, kPa for constant pressure) and placement."""

    pair: tuple[str, str]
    obj: PinchObject
    controller: str
    setpoints: np.ndarray
    placements: Placements

    @property
    def n(self) -> int:
        return len(self.setpoints)


@dataclass
class Traces:
    """Per recorded trial and tick: time, true and estimated normal force, slip."""

    t_s: np.ndarray
    normal_n: np.ndarray
    estimate_n: np.ndarray
    slip_m: np.ndarray
    pressure_kpa: np.ndarray


@dataclass
class BatchResult:
    outcome: np.ndarray  # per trial: plant.HELD, BROKEN, SLIPPED or DROPPED
    held_force_n: np.ndarray  # mean true normal force over the hold (NaN if not held)
    peak_force_n: np.ndarray
    cell_of_trial: np.ndarray
    traces: dict[int, Traces] = field(default_factory=dict)
    # per finger (n, 2): the force estimate's squared error against the true normal force
    # summed over the controller's ticks in contact, and those ticks
    estimate_sq_error_n2: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    contact_ticks: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    def estimate_rmse_n(self, trials: np.ndarray | None = None) -> float:
        """The force estimate's RMS error against the plant's true normal force, over every
        finger's ticks in contact (of the trials selected)."""
        pick = slice(None) if trials is None else trials
        ticks = float(self.contact_ticks[pick].sum())
        return math.sqrt(float(self.estimate_sq_error_n2[pick].sum()) / ticks) if ticks else float("nan")

    def successes(self, cell: int) -> tuple[int, int]:
        mine = self.cell_of_trial == cell
        return int(np.count_nonzero(self.outcome[mine] == HELD)), int(np.count_nonzero(mine))


def pair_gap_m(lever_arm_m: np.ndarray) -> np.ndarray:
    """The tips' distance at rest along the pinch axis, for a finger pair's lever arms."""
    return lever_arm_m.sum(axis=-1) * DESIGN_ANGLE_RAD + DESIGN_WIDTH_M


def finger_arrays(truth: Profile, pairs: list[tuple[str, str]]) -> FingerArrays:
    by_name = {f.name: f for f in truth.fingers}

    def take(get: object) -> np.ndarray:
        return np.array([[get(by_name[a]), get(by_name[b])] for a, b in pairs], dtype=float)  # type: ignore[operator]

    def model(name: str) -> object:
        return lambda f: getattr(f.model, name)

    return FingerArrays(
        take(model("inertia_kgm2")), take(model("damping_nms_per_rad")),
        take(model("stiffness_nm_per_rad")), take(model("pressure_gain_nm_per_kpa")),
        take(model("lever_arm_m")),
        take(lambda f: max(effect_value(f.model.effects, "valve_lag"), 1e-4)),
        take(lambda f: effect_value(f.model.effects, "dead_time")),
        take(lambda f: f.model.length_m),
        np.array([[a, b] for a, b in pairs]),
    )


def finger_config(profile: Profile, finger: FingerProfile) -> rtcore.FingerConfig:
    config = finger.rtcore_config(profile.control)
    return config.replace(pressure_rate_max_kpa_per_s=min(config.pressure_rate_max_kpa_per_s,
                                                          CLOSING_RATE_KPA_PER_S))


def _hands(controller: Profile, pairs: list[tuple[str, str]]) -> list[tuple[rtcore.Hand, int]]:
    by_name = {f.name: finger_config(controller, f) for f in controller.fingers}
    flat = [by_name[name] for pair in pairs for name in pair]
    hands = []
    for start in range(0, len(flat), rtcore.MAX_FINGERS):
        chunk = flat[start:start + rtcore.MAX_FINGERS]
        config = rtcore.HandConfig(chunk, sample_rate_hz=controller.control.rate_hz)
        hands.append((rtcore.Hand(config), start))
    return hands


def run_cells(truth: Profile, controller: Profile, cells: list[Cell], seed: int,
              record: tuple[int, ...] = (), mismatch: Mismatch = NONE,
              release_s: float = RELEASE_S) -> BatchResult:
    """Run every trial of every cell together; record traces of the trials in `record`; the
    person's hand opens over release_s (0: at once)."""
    pairs = [c.pair for c in cells for _ in range(c.n)]
    n = len(pairs)
    rng = np.random.default_rng(seed)
    rate_hz = controller.control.rate_hz
    fingers = finger_arrays(truth, pairs)
    objects = ObjectArrays.build([c.obj for c in cells], [c.placements for c in cells])
    plant = PinchPlant(fingers, objects, pair_gap_m(fingers.lever_arm_m), 1.0 / (rate_hz * SUBSTEPS),
                       mismatch, release_s)
    hands = _hands(controller, pairs)
    by_name = {f.name: f for f in truth.fingers}
    sensor_gain = np.array([[by_name[a].sensor_gain_deg_per_mv, by_name[b].sensor_gain_deg_per_mv]
                            for a, b in pairs]).ravel()
    sensor_offset = np.array([[by_name[a].sensor_offset_deg, by_name[b].sensor_offset_deg]
                              for a, b in pairs]).ravel()
    mode = np.concatenate([np.full(2 * c.n, rtcore.MODE_FORCE if c.controller == "force"
                                   else rtcore.MODE_PRESSURE, dtype=np.int32) for c in cells])
    setpoint = np.repeat(np.concatenate([c.setpoints for c in cells]), 2)
    for hand, start in hands:
        k = hand.config.n_fingers
        hand.inputs.mode[:] = mode[start:start + k]
        hand.inputs.force_ref_n[:] = np.where(mode[start:start + k] == rtcore.MODE_FORCE,
                                              setpoint[start:start + k], 0.0)
        hand.inputs.pressure_ref_kpa[:] = np.where(mode[start:start + k] == rtcore.MODE_PRESSURE,
                                                   setpoint[start:start + k], 0.0)
    noise_deg = float(truth.simulation["sensor_noise_deg"])
    noise_kpa = float(truth.simulation["pressure_noise_kpa"])
    ticks = round((CLOSING_S + HOLD_S) * rate_hz)
    release_tick = round(CLOSING_S * rate_hz)
    command = np.zeros(2 * n)
    estimate = np.zeros(2 * n)
    held_sum = np.zeros(n)
    sq_error, contact = np.zeros((n, 2)), np.zeros((n, 2))
    traces = {i: np.zeros((ticks, 5)) for i in record}
    for tick in range(ticks):
        if tick == release_tick:
            plant.release()
        angle_deg = (mismatch.sensed_deg(np.degrees(plant.angle_rad).ravel())
                     + noise_deg * rng.standard_normal(2 * n))
        sensor_mv = (angle_deg - sensor_offset) / sensor_gain
        pressure_kpa = plant.chamber_kpa.ravel() + noise_kpa * rng.standard_normal(2 * n)
        for hand, start in hands:
            k = hand.config.n_fingers
            hand.inputs.sensor_mv[:] = sensor_mv[start:start + k]
            hand.inputs.pressure_meas_kpa[:] = pressure_kpa[start:start + k]
            hand.step()
            command[start:start + k] = hand.outputs.pressure_cmd_kpa
            estimate[start:start + k] = hand.outputs.force_normal_n
        touching = plant.normal_n > 0.0
        sq_error += np.where(touching, (estimate.reshape(n, 2) - plant.normal_n) ** 2, 0.0)
        contact += touching
        for _ in range(SUBSTEPS):
            plant.advance(command.reshape(n, 2))
        if tick >= release_tick:
            held_sum += plant.normal_n.mean(axis=1)
        for i, rows in traces.items():
            rows[tick] = (tick / rate_hz, plant.normal_n[i].mean(), estimate[2 * i:2 * i + 2].mean(),
                          plant.slip_m[i], command[2 * i:2 * i + 2].mean())
    held = plant.outcome == HELD
    cell_of_trial = np.concatenate([np.full(c.n, k) for k, c in enumerate(cells)])
    return BatchResult(plant.outcome.copy(), np.where(held, held_sum / max(ticks - release_tick, 1), np.nan),
                       plant.peak_normal_n.copy(), cell_of_trial,
                       {i: Traces(*rows.T) for i, rows in traces.items()}, sq_error, contact)
