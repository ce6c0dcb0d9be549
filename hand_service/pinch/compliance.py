"""Impedance mode in closed loop: its compliance under a slow push, and its stability.

One finger of a profile, the truth's PRBM with its valve lag and dead time (the finger and
the lag stepped by rtcore's finger simulator, rtcore.motion, the wall's force held over
each substep as an external torque), in closed loop with the C step in impedance mode
about an angle reference. The controller's
finger model is the truth's, or a lab's measured one (`controller`, as the pinch run
uses: hand_service.identification.measured_hand), so the force estimate is not exact by
construction.

`slow_push`: a stiff contact (a wall on the force point) comes down on the finger slowly,
from beyond the reference (80°) to 60° inside it over 40 s; the measured stiffness is the
slope of the true contact force against the true angle (N per deg), by least squares,
once the wall is inside the reference by ONSET_DEG and by enough for K times the depth to
reach ONSET_FORCE_N (near first contact the force is as small as the estimate's noise,
about 0.14 N from 0.5 kPa of pressure noise, and a contact that only pushes rectifies
that noise into a mean force, which flattens the slope at a small K).

`free_step`: no contact; the reference steps by STEP_DEG and the finger must settle on it
(the finger's largest swing from the new reference over the last second).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

import rtcore
from hand_service.config.effects import effect_value
from hand_service.config.profile import Profile
from hand_service.identification.span import Span, span_lever
from hand_service.identification.tare import apply_tare, tare_gain
from hand_service.pinch.mismatch import NONE, Hysteresis, Mismatch, ValveLag
from rtcore.motion import FingerMotions
from rtcore.sim import SimFinger

WALL_STIFFNESS_N_PER_M = 5000.0
SUBSTEPS = 10
ONSET_DEG = 5.0
ONSET_FORCE_N = 0.25
STEP_DEG = 10.0
TARE_HOLD_S = 4.0  # the free hold before contact: settled after 3 s, averaged over the last
TARE_MEAN_S = 1.0
TARE_ROUNDS = 2  # at least; then until the tare's hold met TARE_REST_SHARE, at most TARE_MAX_ROUNDS
# An N off by e_N renders K off by 2 e_N / share, and reads F = e_N N p / r on the free hold,
# where N p = k θ: the hold's mean estimate over K is the rest's offset from the reference, and
# that offset over the reference angle (both in degrees) is the N error's share of K
TARE_REST_SHARE = 0.01
TARE_MAX_ROUNDS = 10
SPAN_LOAD_DEG = 5.0  # the span's load: the K it is made at times this (index at K_max: 0.62 N, 63 g)
SPAN_SWEEP_DEG = 5.0  # the reference's swing about the working angle: ten times the loop's half-width
SPAN_PERIOD_S = 4.0  # one sweep; the first is settling, the next SPAN_PERIODS are averaged
SPAN_PERIODS = 2


@dataclass
class PushResult:
    set_stiffness_n_per_deg: float
    measured_stiffness_n_per_deg: float
    angle_deg: np.ndarray  # true angle, one per control tick in contact
    force_n: np.ndarray  # true contact force, likewise

    @property
    def error_ratio(self) -> float:
        return self.measured_stiffness_n_per_deg / self.set_stiffness_n_per_deg - 1.0


def miscalibrated(controller: Profile, error_pct: float) -> Profile:
    """The controller's profile with k up and N down by error_pct %: a calibration error in
    the direction that biases the force estimate most. At equilibrium N·p = k·θ + r·F, so
    the estimate is F·(1 − e) − 2·e·k·θ/r and the measured stiffness (K − 4·e·K_max)/(1 − e)
    (K_max = 0.5·k/(r·180/π), hand_service.api.impedance)."""
    scale = error_pct / 100.0
    fingers = [dataclasses.replace(f, model=dataclasses.replace(
        f.model, stiffness_nm_per_rad=f.model.stiffness_nm_per_rad * (1.0 + scale),
        pressure_gain_nm_per_kpa=f.model.pressure_gain_nm_per_kpa * (1.0 - scale)))
        for f in controller.fingers]
    return dataclasses.replace(controller, fingers=fingers)


@dataclass
class Loop:
    """Per control tick: the true angle, the true contact force, the chamber pressure; the
    controller's force estimate and the chamber pressure it made it from."""

    angle_deg: np.ndarray
    force_n: np.ndarray
    chamber_kpa: np.ndarray
    estimate_n: np.ndarray
    estimate_kpa: np.ndarray


def closed_loop(truth: Profile, finger: str, stiffness_n_per_deg: float, damping_n_s_per_deg: float,
                duration_s: float, reference_deg: Callable[[float], float],
                wall_deg: Callable[[float], float | None], seed: int | tuple[int, int] = 1,
                controller: Profile | None = None, push_n: Callable[[float], float] | None = None,
                mismatch: Mismatch = NONE) -> Loop:
    """The truth's finger under the C step in impedance mode, the controller's model from
    `controller` (default: the truth's); wall_deg(t) is where the wall stands, held over each
    tick (None at t = 0: no wall in this run). The wall is the simulator's contact. push_n(t)
    (N, opening the finger; may pull) acts on the force point as well, held over each tick,
    and adds to the recorded force. With a mismatch (hand_service.pinch.mismatch) the finger
    is the pinch's mismatched plant: the stiffening and hysteresis torques, the push acting
    at the drifting contact lever, the bowed sensor and the board's valves in place of the
    profile's lag and dead time (the wall, the simulator's contact, stays at the model's r)."""
    f = truth.finger(finger)
    lab = controller or truth
    config = lab.finger(finger).rtcore_config(lab.control)
    hand = rtcore.Hand(rtcore.HandConfig([config], sample_rate_hz=truth.control.rate_hz))
    m = f.model
    rate_hz = truth.control.rate_hz
    dt_s = 1.0 / (rate_hz * SUBSTEPS)
    board = mismatch.valves
    tau_s = max(effect_value(m.effects, "valve_lag"), 1e-4) if board is None else 0.0
    delay = round(effect_value(m.effects, "dead_time") / dt_s) if board is None else 0
    pipe = np.zeros(delay + 1)
    valves = None if board is None else ValveLag(board, np.array([board.fill_tau_of(finger)]), dt_s)
    hysteresis = Hysteresis(np.radians(mismatch.hysteresis_deg), (1,))
    stiffness = np.array([m.stiffness_nm_per_rad])
    rng = np.random.default_rng(seed)
    noise_deg = float(truth.simulation["sensor_noise_deg"])
    noise_kpa = float(truth.simulation["pressure_noise_kpa"])
    hand.inputs.mode[0] = rtcore.MODE_IMPEDANCE
    hand.inputs.impedance_stiffness_n_per_deg[0] = stiffness_n_per_deg
    hand.inputs.impedance_damping_n_s_per_deg[0] = damping_n_s_per_deg
    ticks = round(duration_s * rate_hz)
    # the plain PRBM and the lag; the dead time is the pipe's (with the board's valves: theirs)
    prbm = dataclasses.replace(m.prbm("the impedance loop"), effects=rtcore.Effects(valve_lag_tau_s=tau_s))
    walled = wall_deg(0.0) is not None
    motion = FingerMotions([SimFinger(prbm, contact_angle_deg=wall_deg(0.0) or 0.0,
                                      contact_stiffness_n_per_m=WALL_STIFFNESS_N_PER_M if walled else 0.0)])
    angle = chamber = 0.0
    out = Loop(*(np.zeros(ticks) for _ in range(5)))
    for tick in range(ticks):
        t_s = tick / rate_hz
        wall = wall_deg(t_s) if walled else None
        if wall is not None:
            motion.move_contact(0, wall)
        hand.inputs.angle_ref_deg[0] = reference_deg(t_s)
        angle_deg = float(mismatch.sensed_deg(np.degrees(angle))) + noise_deg * rng.standard_normal()
        hand.inputs.sensor_mv[0] = (angle_deg - f.sensor_offset_deg) / f.sensor_gain_deg_per_mv
        hand.inputs.pressure_meas_kpa[0] = chamber + noise_kpa * rng.standard_normal()
        hand.step()
        out.estimate_n[tick] = hand.outputs.force_normal_n[0]
        out.estimate_kpa[tick] = hand.outputs.chamber_pressure_kpa[0]
        command = float(hand.outputs.pressure_cmd_kpa[0])
        push = 0.0 if push_n is None else push_n(t_s)
        for k in range(SUBSTEPS):
            pipe[(tick * SUBSTEPS + k) % pipe.size] = command
            delayed = np.array([pipe[(tick * SUBSTEPS + k - delay) % pipe.size]])
            if valves is not None:
                delayed = valves.step(delayed)
            bend = motion.angle_rad[:1].copy()
            torque = (-mismatch.contact_lever_m(np.array([m.lever_arm_m]), bend) * push
                      - mismatch.stiffening_torque_nm(stiffness, bend, motion.chamber_kpa[:1]))
            if mismatch.hysteresis_deg > 0.0:
                torque = torque - hysteresis.torque_nm(stiffness, bend)
            motion.advance(delayed, torque, dt_s)
        angle, chamber = float(motion.angle_rad[0]), float(motion.chamber_kpa[0])
        depth_m = 0.0 if wall is None else m.lever_arm_m * (angle - np.radians(wall))
        force = max(WALL_STIFFNESS_N_PER_M * depth_m, 0.0) + push
        out.angle_deg[tick], out.force_n[tick], out.chamber_kpa[tick] = np.degrees(angle), force, chamber
    return out


def free_tare(truth: Profile, controller: Profile, finger: str, stiffness_n_per_deg: float,
              reference_deg: float, seed: int = 1, mismatch: Mismatch = NONE,
              rounds: int = TARE_ROUNDS) -> Profile:
    """The controller with its force estimate tared (hand_service.identification.tare) on
    the free finger: impedance mode holds the reference with no contact for TARE_HOLD_S, and
    the estimate over its last TARE_MEAN_S fixes N; at least rounds times, each from the
    last's N (the tared finger rests nearer its reference, where the next tare is made), and
    on until a hold's mean estimate over K, the rest's offset, is within TARE_REST_SHARE of
    the reference angle (at a small K the rest sits far off and each round gains less)."""
    ticks = round(TARE_MEAN_S * truth.control.rate_hz)
    for n in range(max(rounds, TARE_MAX_ROUNDS)):
        loop = closed_loop(truth, finger, stiffness_n_per_deg, 0.0, TARE_HOLD_S, lambda _: reference_deg,
                           lambda _: None, seed + n, controller, mismatch=mismatch)
        tare = tare_gain(controller.finger(finger).model, finger, loop.estimate_n[-ticks:],
                         loop.estimate_kpa[-ticks:])
        controller = apply_tare(controller, tare)
        rest_deg = abs(tare.estimate_n) / stiffness_n_per_deg
        if n + 1 >= rounds and rest_deg <= TARE_REST_SHARE * abs(reference_deg):
            break
    return controller


def loaded_span(truth: Profile, controller: Profile, finger: str, stiffness_n_per_deg: float,
                load_n: float, reference_deg: float, seed: int = 1, mismatch: Mismatch = NONE) -> Span:
    """The estimate's span (hand_service.identification.span) as a lab makes it: impedance
    mode at this K sweeps its reference ±SPAN_SWEEP_DEG about reference_deg, once free and
    once with load_n hung on the pad (the probe's constant push, opening the finger); the
    estimates over the last SPAN_PERIODS whole sweeps give the span. The loaded sweep's
    noise is a draw of its own (the seed with 1 beside it), as two recordings' are: one
    shared draw would cancel in the difference and flatter the span's precision."""
    rate_hz = truth.control.rate_hz
    duration_s = (1 + SPAN_PERIODS) * SPAN_PERIOD_S
    last = round(SPAN_PERIODS * SPAN_PERIOD_S * rate_hz)

    def sweep(t_s: float) -> float:
        return reference_deg + SPAN_SWEEP_DEG * float(np.sin(2.0 * np.pi * t_s / SPAN_PERIOD_S))

    estimates = [closed_loop(truth, finger, stiffness_n_per_deg, 0.0, duration_s, sweep, lambda _: None, draw,
                             controller, push_n=lambda _, f=force: f, mismatch=mismatch).estimate_n[-last:]
                 for force, draw in ((0.0, seed), (load_n, (seed, 1)))]
    lever_m = controller.finger(finger).model.lever_arm_m
    return span_lever(finger, lever_m, estimates[0], estimates[1], load_n)


def slow_push(profile: Profile, finger: str, stiffness_n_per_deg: float, damping_n_s_per_deg: float,
              reference_deg: float = 80.0, push_deg: float = 60.0, push_s: float = 40.0,
              seed: int = 1, controller: Profile | None = None) -> PushResult:
    settle_s = 2.0
    onset_deg = max(ONSET_DEG, ONSET_FORCE_N / stiffness_n_per_deg) if stiffness_n_per_deg > 0 else ONSET_DEG
    wall_start_deg = reference_deg + 3.0

    def wall(t_s: float) -> float:
        progress = min(max((t_s - settle_s) / push_s, 0.0), 1.0)
        return wall_start_deg - (push_deg + 3.0) * progress

    loop = closed_loop(profile, finger, stiffness_n_per_deg, damping_n_s_per_deg, settle_s + push_s + 1.0,
                       lambda _: reference_deg, wall, seed, controller)
    walls = np.array([wall(k / profile.control.rate_hz) for k in range(loop.angle_deg.size)])
    inside = (walls < reference_deg - onset_deg) & (loop.force_n > 0.0)
    a, fo = loop.angle_deg[inside], loop.force_n[inside]
    if a.size < 10:
        raise ValueError("the wall never pressed on the finger")
    slope = -np.polyfit(a, fo, 1)[0]  # force rises as the angle falls below the reference
    return PushResult(stiffness_n_per_deg, float(slope), a, fo)


def free_step(profile: Profile, finger: str, stiffness_n_per_deg: float, damping_n_s_per_deg: float,
              reference_deg: float = 40.0, seed: int = 1, controller: Profile | None = None) -> float:
    """The largest |angle - reference| over the last of 4 s after a STEP_DEG reference step at 1 s
    (deg): a loop that settles leaves the sensor noise's share; an unstable one swings or runs off."""
    loop = closed_loop(profile, finger, stiffness_n_per_deg, damping_n_s_per_deg, 5.0,
                       lambda t: reference_deg + (STEP_DEG if t >= 1.0 else 0.0), lambda _: None, seed,
                       controller)
    last = loop.angle_deg[-round(profile.control.rate_hz):]
    return float(np.max(np.abs(last - (reference_deg + STEP_DEG))))
