"""Pressure commands that can reveal the library's effects (the generator's inputs).

Every excitation is a command series at the recording's rate, scaled to the finger: the
full pressure `full_kpa` bends it to about 80 degrees at rest. Vents (command 0) after an
inflation make the finger swing back past zero, which asymmetric stiffness needs; steps
of many sizes ring at many amplitudes, which friction and drag need; slow ramps show the
quasi-static curve (stiffening, gravity, dead zone); chirps and steps show delays.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

REST_S = 0.5  # every excitation starts at rest, vented


def steps(full_kpa: float, duration_s: float, rate_hz: float, rng: np.random.Generator) -> np.ndarray:
    """A random staircase: holds of 0.8-2 s at levels in [0, full], a vent every few steps."""
    n = round(duration_s * rate_hz)
    command = np.zeros(n)
    k = round(REST_S * rate_hz)
    while k < n:
        hold = max(1, round(rng.uniform(0.8, 2.0) * rate_hz))  # a sample at least (slow rates)
        level = 0.0 if rng.random() < 0.3 else rng.uniform(0.1, 1.0) * full_kpa
        command[k:k + hold] = level
        k += hold
    return command


def sweep(full_kpa: float, duration_s: float, rate_hz: float, rng: np.random.Generator) -> np.ndarray:
    """Slow ramps up and down, a logarithmic chirp (0.3 -> 15 Hz) about half pressure, then
    inflate-and-vent swings of random size; the three parts share the duration."""
    n = round(duration_s * rate_hz)
    t = np.arange(n) / rate_hz
    command = np.zeros(n)
    body = duration_s - REST_S
    ramp_end = REST_S + 0.35 * body
    chirp_end = ramp_end + 0.35 * body
    # ramps: two triangles 0 -> full -> 0, with a random top
    ramp = (t >= REST_S) & (t < ramp_end)
    phase = (t[ramp] - REST_S) / (ramp_end - REST_S) * 2.0
    top = rng.uniform(0.8, 1.0) * full_kpa
    command[ramp] = top * (1.0 - np.abs(2.0 * (phase % 1.0) - 1.0))
    # chirp
    chirp = (t >= ramp_end) & (t < chirp_end)
    tc = t[chirp] - ramp_end
    span = chirp_end - ramp_end
    f0, f1 = 0.3, 15.0
    rate = np.log(f1 / f0) / span
    phi = 2.0 * np.pi * f0 * (np.exp(rate * tc) - 1.0) / rate
    command[chirp] = 0.5 * full_kpa * (1.0 - np.cos(phi))
    # inflate-and-vent swings
    k = np.searchsorted(t, chirp_end)
    while k < n:
        up = max(1, round(rng.uniform(0.6, 1.2) * rate_hz))
        down = max(1, round(rng.uniform(0.6, 1.2) * rate_hz))
        command[k:k + up] = rng.uniform(0.3, 1.0) * full_kpa
        k += up + down
    return command


def sine(full_kpa: float, duration_s: float, rate_hz: float, rng: np.random.Generator) -> np.ndarray:
    """One slow sine, 0 -> full -> 0 at 1 Hz: too poor to separate a lag from a gain."""
    t = np.arange(round(duration_s * rate_hz)) / rate_hz
    return 0.5 * full_kpa * (1.0 - np.cos(2.0 * np.pi * 1.0 * t))


Excitation = Callable[[float, float, float, np.random.Generator], np.ndarray]
EXCITATIONS: dict[str, Excitation] = {"steps": steps, "sweep": sweep, "sine": sine}

# One excitation per effect for the quick tests and the table in docs/results.md §10 (the battery runs
# both steps and sweep for every effect): both reveal every effect.
REPRESENTATIVE: dict[str, str] = {
    "valve_lag": "sweep", "dead_time": "steps", "coulomb_friction": "steps", "cubic_stiffness": "sweep",
    "gravity": "steps", "asymmetric_stiffness": "steps", "quadratic_damping": "steps",
    "pressure_deadzone": "sweep"}
