"""The force estimate's span: a known load at the pad must read as itself.

The tare (hand_service.identification.tare) zeroes the estimate where the force is known to
be 0. What it leaves is a scale: after it the estimate reads s·F, with s = (1 + e_k) for a
k off by e_k (the tared N/k is the finger's own, so N and k are off together) times
r_contact / r, the lever the pad's force truly acts on over the model's (a contact point
that moves with the bend: at 80° the pinch's mismatched plant has it 14 % out). Neither a
free hold nor `calibrate gain` can see s; a known load can. The span is the second point
of the estimate's two-point calibration, made as a lab makes it with a weight hung from the
pad: the finger in impedance mode, at the K it will render, sweeps its reference slowly
about the working angle, once unloaded and once with the load, and the mean estimates'
difference over whole sweeps is s·load. The sweep, wider than the silicone's loop,
averages that joint friction out (its torque has the opposite sign on the closing and the
opening leg); the inertia and damping
average out over whole periods. The model's lever arm becomes r·s, so the estimate
(a torque over r) reads the load as itself, and the impedance law renders K at the pad.
On a real hand the lab records the two sweeps (whole periods, the measured chamber pressure
in every sample) and runs `hand-service calibrate span FREE.csv LOADED.csv --load-n L`
(span_from_recordings), after the tare.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from hand_service.config.model import FingerModel
from hand_service.config.profile import Profile
from hand_service.identification.tare import recorded_estimate_n
from hand_service.recording import Recording

MIN_LOAD_N = 0.05  # below this the sensor's noise over a few sweeps is a large part of the load
# A recording's sweeps must be whole to this share of a period: a part sweep's leftover
# biases the mean estimate by the loop's torque over the leftover's share of the record
WHOLE_PERIODS_TOLERANCE = 0.05
SEARCH_POINTS = 201  # the sinusoid's frequency searched on this grid over one spectral bin each side
SPAN_RANGE = (0.5, 2.0)  # a span outside this is not a scale the model can be off by: refused


@dataclass(frozen=True)
class Span:
    """One finger's span: the mean estimates unloaded and loaded, the load, and the lever
    arm before and after."""

    finger: str
    unloaded_n: float
    loaded_n: float
    load_n: float
    lever_before_m: float

    @property
    def scale(self) -> float:
        """The estimate's reading per newton of true load (1: the estimate right)."""
        return (self.loaded_n - self.unloaded_n) / self.load_n

    @property
    def lever_after_m(self) -> float:
        return self.lever_before_m * self.scale


def span_lever(finger: str, lever_arm_m: float, unloaded_estimate_n: np.ndarray,
               loaded_estimate_n: np.ndarray, load_n: float) -> Span:
    """The span from the estimates (N, made with a model of this lever arm) over whole
    sweeps unloaded and with load_n (N, at the pad, opening the finger) hung on."""
    unloaded = np.asarray(unloaded_estimate_n, dtype=float)
    loaded = np.asarray(loaded_estimate_n, dtype=float)
    if unloaded.size == 0 or loaded.size == 0:
        raise ValueError("the span needs estimates from both sweeps")
    if not (np.all(np.isfinite(unloaded)) and np.all(np.isfinite(loaded))):
        raise ValueError("the span's sweeps have a non-finite estimate")
    if not load_n >= MIN_LOAD_N:
        raise ValueError(f"the span's load {load_n:g} N is under {MIN_LOAD_N:g} N: too small to read")
    span = Span(finger, float(np.mean(unloaded)), float(np.mean(loaded)), float(load_n), lever_arm_m)
    low, high = SPAN_RANGE
    if not low <= span.scale <= high:
        raise ValueError(f"{finger}: the estimate read {span.scale:.3f} N per N of load, outside "
                         f"{low:g} to {high:g}: the load or the sweeps are not what the span assumes")
    return span


def _residual(t_s: np.ndarray, centred: np.ndarray, frequency_hz: float) -> float:
    """The sum of squares the least-squares sinusoid at this frequency (with an offset) leaves."""
    omega = 2.0 * np.pi * frequency_hz
    basis = np.column_stack([np.ones_like(t_s), np.sin(omega * t_s), np.cos(omega * t_s)])
    fit = np.linalg.lstsq(basis, centred, rcond=None)[0]
    return float(np.sum((centred - basis @ fit) ** 2))


def sweep_periods(t_s: np.ndarray, angle_deg: np.ndarray) -> tuple[float, float]:
    """How many periods of its sweep a recording holds, and the sweep's period (s): the
    period of the angle's largest sinusoid (the least-squares fit's, searched over a bin
    each side of the spectrum's peak), the record's length its samples over the rate."""
    t = np.asarray(t_s, dtype=float) - float(t_s[0])
    centred = np.asarray(angle_deg, dtype=float) - float(np.mean(angle_deg))
    if t.size < 8:
        return 0.0, math.inf
    dt_s = float(np.median(np.diff(t)))
    length_s = t.size * dt_s
    padded = 8 * t.size
    spectrum = np.abs(np.fft.rfft(centred, padded))
    peak_hz = (1 + int(np.argmax(spectrum[1:]))) / (padded * dt_s)
    bin_hz = 1.0 / length_s
    grid = np.linspace(max(peak_hz - bin_hz, 0.25 * bin_hz), peak_hz + bin_hz, SEARCH_POINTS)
    frequency_hz = float(grid[int(np.argmin([_residual(t, centred, f) for f in grid]))])
    return length_s * frequency_hz, 1.0 / frequency_hz


def check_whole_periods(recording: Recording) -> None:
    """Refuse a recording whose sweeps are not whole (WHOLE_PERIODS_TOLERANCE): its mean
    estimate would keep a part sweep's share of the loop and the inertia."""
    periods, period_s = sweep_periods(recording.t_s, recording.angle_deg)
    if periods < 1.0 - WHOLE_PERIODS_TOLERANCE or abs(periods - round(periods)) > WHOLE_PERIODS_TOLERANCE:
        raise ValueError(f"{recording.path}: the sweep covers {periods:.2f} periods of {period_s:.3g} s, not "
                         f"a whole number: record whole sweeps (a part sweep biases the span)")


def span_from_recordings(free: Recording, loaded: Recording, load_n: float, model: FingerModel, finger: str,
                         with_loop: bool = False) -> Span:
    """The span from two recorded sweeps, free and with load_n hung on the pad, each over
    whole periods (check_whole_periods): the controller's static estimate made again from
    each (tare.recorded_estimate_n)."""
    for recording in (free, loaded):
        check_whole_periods(recording)
    return span_lever(finger, model.prbm("the span").lever_arm_m, recorded_estimate_n(free, model, with_loop),
                      recorded_estimate_n(loaded, model, with_loop), load_n)


def apply_span(profile: Profile, span: Span) -> Profile:
    """The profile with that finger's lever arm the span's."""
    fingers = [dataclasses.replace(f, model=f.model.with_changes(lever_arm_m=span.lever_after_m))
               if f.name == span.finger else f for f in profile.fingers]
    return dataclasses.replace(profile, fingers=fingers)
