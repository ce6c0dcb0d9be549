"""The recordings labs make, as commands (kPa) at the sample rate, held between samples.

| class | what | duration |
|---|---|---|
| free_release | bent by hand to ±35–80 % of full scale, let go at t = 0, 0 kPa throughout | 6 s |
| vent_release | hold a pressure 2–3.5 s, vent to 0 kPa 2–3.5 s, again at other pressures | 30 s |
| ramp | quasi-static triangles 0 → top → 0 of 6–10 s | 30 s |
| slow_sine | one raised sine 0 → P → 0 at 0.15–0.3 × the finger's corner frequency | 30 s |
| steps | a random staircase, holds 0.8–2.5 s, a vent about every third step | 30 s |
| chirp | a raised logarithmic chirp 0.1 Hz → 2 × the corner, amplitude 0.3·P | 30 s |
| prbs | a pseudo-random binary sequence (9-bit LFSR) between a low and a high pressure | 30 s |
| multisine | 12 log-spaced tones 0.1 Hz → 1.5 × the corner, Schroeder phases, on P/2 | 30 s |
| pi_steps | closed loop: a PI on the measured angle tracking angle steps | 30 s |
| ffpid_cosine | closed loop: model feedforward + PID tracking the paper's 0.75 s raised cosine | 30 s |

P is the case's top pressure (0.8–1.1 × the family's full scale). In the closed loops the
recorded command is what the loop put out (computed from the noisy, quantised measurement,
clipped to 0–150 kPa, held between samples); the feedforward uses the lab's nominal model.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from tests.diagnose.truth.linear import LinearModel
from tests.diagnose.truth.plant import DEG, Family

CLASSES = (
    "free_release",
    "vent_release",
    "ramp",
    "slow_sine",
    "steps",
    "chirp",
    "prbs",
    "multisine",
    "pi_steps",
    "ffpid_cosine",
)
CLOSED_LOOP = ("pi_steps", "ffpid_cosine")


@dataclass
class Plan:
    kind: str
    rate_hz: float
    n: int
    top_kpa: float
    command: np.ndarray | None = None
    controller: Callable[[], Callable[[int, float], float]] | None = None  # a fresh loop per run
    theta0_deg: float = 0.0
    reference_deg: np.ndarray | None = None


def _raised_ramp_in(n: int, rate_hz: float, seconds: float = 1.0) -> np.ndarray:
    m = min(n, int(seconds * rate_hz))
    w = np.ones(n)
    w[:m] = 0.5 * (1.0 - np.cos(np.pi * np.arange(m) / m))
    return w


def _segments(
    rng: np.random.Generator,
    rate_hz: float,
    n: int,
    hold_s: tuple[float, float],
    level: Callable[[int], float],
) -> np.ndarray:
    out = np.zeros(n)
    i, j = int(0.5 * rate_hz), 0  # half a second at rest first
    while i < n:
        m = int(rng.uniform(*hold_s) * rate_hz)
        out[i : i + m] = level(j)
        i, j = i + m, j + 1
    return out


def _lfsr9(rng: np.random.Generator, count: int) -> np.ndarray:
    state = int(rng.integers(1, 512))
    bits = np.empty(count, dtype=bool)
    for i in range(count):
        bit = ((state >> 8) ^ (state >> 4)) & 1  # x^9 + x^5 + 1, maximal length 511
        state = ((state << 1) | bit) & 0x1FF
        bits[i] = bool(bit)
    return bits


def make(
    kind: str,
    rng: np.random.Generator,
    rate_hz: float,
    family: Family,
    nominal: LinearModel,
    duration_s: float = 30.0,
) -> Plan:
    """The plan of one recording; `nominal` is the lab's model (closed-loop gains, feedforward)."""
    top = family.full_scale_kpa * float(rng.uniform(0.8, 1.1))
    corner = family.corner_hz
    cap = family.pressure_cap_kpa
    if kind == "free_release":
        n = int(6.0 * rate_hz)
        sign = 1.0 if rng.uniform() < 0.75 else -1.0
        return Plan(
            kind,
            rate_hz,
            n,
            0.0,
            command=np.zeros(n),
            theta0_deg=sign * float(rng.uniform(0.35, 0.8)) * family.full_scale_deg,
        )
    n = int(duration_s * rate_hz)
    t = np.arange(n) / rate_hz
    if kind == "vent_release":
        pressures = rng.uniform(0.3, 1.0, 64) * top
        cmd = _segments(rng, rate_hz, n, (2.0, 3.5), lambda j: pressures[j // 2] if j % 2 == 0 else 0.0)
    elif kind == "ramp":
        cmd = np.zeros(n)
        i = int(0.5 * rate_hz)
        while i < n:
            period = rng.uniform(6.0, 10.0)
            peak = rng.uniform(0.6, 1.0) * top
            m = int(period * rate_hz)
            tri = 1.0 - np.abs(np.linspace(-1.0, 1.0, m))
            cmd[i : i + m] = (peak * tri)[: max(0, min(m, n - i))]
            i += m + int(0.5 * rate_hz)
    elif kind == "slow_sine":
        f = float(rng.uniform(0.15, 0.3)) * corner
        cmd = 0.5 * top * (1.0 - np.cos(2.0 * np.pi * f * t))
    elif kind == "steps":
        levels = rng.uniform(0.0, 1.0, 128) * top
        vent = rng.uniform(size=128) < 0.33
        cmd = _segments(rng, rate_hz, n, (0.8, 2.5), lambda j: 0.0 if vent[j] else levels[j])
    elif kind == "chirp":
        f0, f1 = 0.1, min(2.0 * corner, 0.4 * rate_hz)
        phase = (
            2.0
            * np.pi
            * f0
            * duration_s
            / math.log(f1 / f0)
            * (np.exp(t / duration_s * math.log(f1 / f0)) - 1.0)
        )
        cmd = 0.5 * top * (1.0 - 0.6 * np.cos(phase)) * _raised_ramp_in(n, rate_hz)
        cmd[0] = 0.0
    elif kind == "prbs":
        bit_s = max(2.0 / rate_hz, float(rng.uniform(0.3, 0.8)) / corner)
        per_bit = max(2, round(bit_s * rate_hz))
        bits = np.repeat(_lfsr9(rng, n // per_bit + 2), per_bit)[:n]
        low, high = rng.uniform(0.1, 0.3) * top, rng.uniform(0.6, 0.9) * top
        cmd = np.where(bits, high, low)
        cmd[: int(0.5 * rate_hz)] = 0.0
    elif kind == "multisine":
        freqs = np.geomspace(0.1, min(1.5 * corner, 0.4 * rate_hz), 12)
        phases = -np.pi * np.arange(1, 13) * np.arange(12) / 12.0  # Schroeder
        wave = np.sum(np.sin(2.0 * np.pi * freqs[:, None] * t[None, :] + phases[:, None]), axis=0)
        wave /= np.max(np.abs(wave))
        cmd = (0.5 * top + 0.45 * top * wave) * _raised_ramp_in(n, rate_hz, 2.0)
        cmd[0] = 0.0
    elif kind == "pi_steps":
        fs = family.full_scale_deg
        levels = rng.uniform(0.1, 0.8, 128) * fs
        zero = rng.uniform(size=128) < 0.3
        ref = _segments(rng, rate_hz, n, (1.5, 3.5), lambda j: 0.0 if zero[j] else levels[j])
        return Plan(
            kind, rate_hz, n, top, controller=lambda: _pi(ref, rate_hz, nominal, cap), reference_deg=ref
        )
    elif kind == "ffpid_cosine":
        amp = float(rng.uniform(0.6, 1.0)) * family.full_scale_deg
        w = 2.0 * np.pi / 0.75
        ref = 0.5 * amp * (1.0 - np.cos(w * t))
        return Plan(
            kind,
            rate_hz,
            n,
            top,
            controller=lambda: _ff_pid(amp, w, rate_hz, nominal, cap),
            reference_deg=ref,
        )
    else:
        raise ValueError(f"unknown excitation {kind!r}")
    return Plan(kind, rate_hz, n, top, command=np.clip(cmd, 0.0, cap))


def _dc_gain_deg_per_kpa(nominal: LinearModel) -> float:
    return nominal.gain_nm_per_kpa / nominal.stiffness_nm_per_rad / DEG


def _pi(ref: np.ndarray, rate_hz: float, nominal: LinearModel, cap: float) -> Callable[[int, float], float]:
    """A PI on the measured angle: an integral bandwidth of 0.8 Hz, a proportional loop gain
    of 0.3, conditional integration against windup."""
    g = _dc_gain_deg_per_kpa(nominal)
    kp, ki, period = 0.3 / g, 2.0 * np.pi * 0.8 / g, 1.0 / rate_hz
    state = {"i": 0.0}

    def step(i: int, measured_deg: float) -> float:
        e = ref[i] - measured_deg
        u = kp * e + state["i"]
        if (u < cap or e < 0) and (u > 0 or e > 0):
            state["i"] += ki * e * period
        return min(max(kp * e + state["i"], 0.0), cap)

    return step


def _ff_pid(
    amp_deg: float, w: float, rate_hz: float, nominal: LinearModel, cap: float
) -> Callable[[int, float], float]:
    """Model-inversion feedforward (A·r'' + B·r' + k·r)/N of the lab's nominal model plus a PI
    (kp for a loop gain of 0.3, ki = 10/s·kp, no derivative, as the project's default) on the
    measured angle low-passed at 20 Hz."""
    g = _dc_gain_deg_per_kpa(nominal)
    kp = 0.3 / g
    ki = 10.0 * kp
    period = 1.0 / rate_hz
    alpha = math.exp(-2.0 * math.pi * 20.0 * period)
    a, b, k, n = (
        nominal.inertia_kgm2,
        nominal.damping_nms_per_rad,
        nominal.stiffness_nm_per_rad,
        nominal.gain_nm_per_kpa,
    )
    half = 0.5 * amp_deg * DEG
    state = {"i": 0.0, "y": None}

    def step(i: int, measured_deg: float) -> float:
        t = i * period
        r = half * (1.0 - math.cos(w * t))
        rd = half * w * math.sin(w * t)
        rdd = half * w * w * math.cos(w * t)
        ff = (a * rdd + b * rd + k * r) / n
        y = measured_deg if state["y"] is None else alpha * state["y"] + (1.0 - alpha) * measured_deg
        state["y"] = y
        e = r / DEG - y
        u = ff + kp * e + state["i"]
        if (u < cap or e < 0) and (u > 0 or e > 0):
            state["i"] += ki * e * period
        return min(max(ff + kp * e + state["i"], 0.0), cap)

    return step
