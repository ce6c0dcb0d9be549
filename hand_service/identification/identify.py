"""`identify`: k and B of one finger from free-oscillation trials, by the LDM.

Each trial is read, its release found and its free decay read by the chosen method
(hand_service.identification.ldm). The inertia A is held at the model's value (docs/physics.md §1), so
k = A·ω_n² and B = 2·ζ·ω_n·A. The damped-sine fit runs on every trial whatever the
method, because the decrement-drift check (hand_service.identification.decrement_drift) needs it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import signal

from hand_service.config.model import FingerModel
from hand_service.errors import UserError
from hand_service.identification import ldm
from hand_service.identification.decrement_drift import (
    CycleAmplitudes,
    Drift,
    cycle_amplitudes,
    decrement_drift,
)
from hand_service.recording import Recording, check_finger, read_recording

NOISE_RATIO_WARNING = 2.0  # fit residual over the sensor noise beyond which the decay is no damped sine
PRESSURE_CHANGE_WARNING_KPA = 2.0


@dataclass
class TrialResult:
    file: str
    decay: ldm.FreeDecay
    estimate: ldm.DecayEstimate  # by the chosen method
    fit: ldm.DecayEstimate  # the damped-sine fit (drift check, release time, plot)
    cycles: CycleAmplitudes
    inertia_kgm2: float
    recording: Recording

    @property
    def stiffness_nm_per_rad(self) -> float:
        return self.estimate.stiffness_nm_per_rad(self.inertia_kgm2)

    @property
    def damping_nms_per_rad(self) -> float:
        return self.estimate.damping_nms_per_rad(self.inertia_kgm2)

    @property
    def release_s(self) -> float:
        """The last crest (in the held direction) of the fitted free response before the
        decay window: where a finger released from rest starts."""
        period = self.fit.damped_period_s
        t = np.linspace(self.fit.start_s - 1.2 * period, self.fit.start_s, 2401)
        h = self.decay.sign * self.fit.curve_deg(t)
        crests = np.flatnonzero((h[1:-1] >= h[:-2]) & (h[1:-1] > h[2:])) + 1
        return float(t[crests[-1]]) if crests.size else float(t[-1])

    def to_json(self) -> dict[str, Any]:
        e = self.estimate
        return {"file": self.file, "stiffness_nm_per_rad": self.stiffness_nm_per_rad,
                "damping_nms_per_rad": self.damping_nms_per_rad, "damping_ratio": e.damping_ratio,
                "natural_freq_hz": e.natural_freq_rad_per_s / (2 * math.pi),
                "damped_freq_hz": e.damped_freq_rad_per_s / (2 * math.pi), "log_decrement": e.log_decrement,
                "release_s": self.release_s, "hold_deg": self.decay.hold_deg, "rest_deg": e.rest_deg,
                "window_s": [e.start_s, e.end_s], "fit_rmse_deg": self.fit.rmse_deg,
                "noise_deg": self.decay.noise_deg}


@dataclass
class IdentifyResult:
    method: str
    inertia_kgm2: float
    finger: str | None
    trials: list[TrialResult]
    drift: Drift | None
    warnings: list[str] = field(default_factory=list)

    def _values(self, name: str) -> np.ndarray:
        return np.array([t.to_json()[name] for t in self.trials])

    def mean(self, name: str) -> float:
        return float(np.mean(self._values(name)))

    def std(self, name: str) -> float:
        values = self._values(name)
        return float(np.std(values, ddof=1)) if values.size > 1 else 0.0

    @property
    def stiffness_nm_per_rad(self) -> float:
        return self.mean("stiffness_nm_per_rad")

    @property
    def damping_nms_per_rad(self) -> float:
        return self.mean("damping_nms_per_rad")

    def to_json(self) -> dict[str, Any]:
        """docs/formats.md's keys (means over the trials, sample standard deviations), then extras."""
        data: dict[str, Any] = {name: self.mean(name) for name in (
            "stiffness_nm_per_rad", "damping_nms_per_rad", "damping_ratio", "natural_freq_hz",
            "damped_freq_hz", "log_decrement")}
        data["stiffness_std_nm_per_rad"] = self.std("stiffness_nm_per_rad")
        data["damping_std_nms_per_rad"] = self.std("damping_nms_per_rad")
        data["trials"] = [t.to_json() for t in self.trials]
        data.update({"method": self.method, "inertia_kgm2": self.inertia_kgm2, "finger": self.finger,
                     "decrement_drift": self.drift.to_json() if self.drift else None,
                     "warnings": list(self.warnings)})
        return data

    def table(self) -> str:
        """Markdown: one row per trial, then mean ± std."""
        rows = ["| trial | k (N·m/rad) | B (N·m·s/rad) | ζ | f_n (Hz) | δ |", "|---|---|---|---|---|---|"]
        for t in self.trials:
            j = t.to_json()
            rows.append(f"| {Path(t.file).name} | {j['stiffness_nm_per_rad']:.5g} "
                        f"| {j['damping_nms_per_rad']:.4g} | {j['damping_ratio']:.4f} "
                        f"| {j['natural_freq_hz']:.3f} | {j['log_decrement']:.4f} |")
        rows.append(f"| **mean ± std** | {self.stiffness_nm_per_rad:.5g} "
                    f"± {self.std('stiffness_nm_per_rad'):.2g} "
                    f"| {self.damping_nms_per_rad:.4g} ± {self.std('damping_nms_per_rad'):.2g} "
                    f"| {self.mean('damping_ratio'):.4f} | {self.mean('natural_freq_hz'):.3f} "
                    f"| {self.mean('log_decrement'):.4f} |")
        return "\n".join(rows)


HOLD_BEFORE_LAST_COMMAND_S = 1.0  # how much of the hold to keep before the last command change
COMMAND_TOLERANCE_KPA = 0.5
SETTLED_CHAMBER_KPA = 2.0  # a vented chamber reads within this of its final pressure


def free_span_start(recording: Recording) -> int:
    """The first sample from which the release can be sought. A free decay can only follow
    the last change of the commanded pressure (in a push-and-release trial it never
    changes; in a daemon recording the finger is vented and rings down after it), so the
    search starts a hold's length before that change."""
    pressure = recording.pressure_kpa
    changed = np.flatnonzero(np.abs(pressure - pressure[-1]) > COMMAND_TOLERANCE_KPA)
    if changed.size == 0:
        return 0
    last_change_s = recording.t_s[changed[-1]]
    return int(np.searchsorted(recording.t_s, last_change_s - HOLD_BEFORE_LAST_COMMAND_S))


def after_the_chamber_empties(recording: Recording, decay: ldm.FreeDecay) -> ldm.FreeDecay:
    """A release by venting is not free until the chamber has emptied through the valve's
    lag and dead time (~0.1 s, a cycle of the finger). When the recording has the measured
    chamber pressure, the decay starts where it has settled at its final level."""
    measured = recording.columns.get("pressure_meas_kpa")
    if measured is None or not np.all(np.isfinite(measured[decay.start_index:])):
        return decay  # not reported (NaN before the first frame is fine, during the decay not)
    after = signal.medfilt(measured[decay.start_index:], 5)  # robust to single noisy readings
    final = float(np.median(after[after.size // 2:]))
    settled = np.flatnonzero(np.abs(after - final) <= SETTLED_CHAMBER_KPA)
    skip = int(settled[0]) if settled.size else 0
    if skip == 0 or skip >= after.size - 10:
        return decay
    return dataclasses.replace(decay, t_s=decay.t_s[skip:], angle_deg=decay.angle_deg[skip:],
                               start_index=decay.start_index + skip)


def identify_trial(recording: Recording, inertia_kgm2: float, method: str = "fit") -> TrialResult:
    source = str(recording.path)
    first = free_span_start(recording)
    decay = ldm.extract_decay(recording.t_s[first:], recording.angle_deg[first:], source)
    decay.start_index += first  # an index into the whole recording
    decay = after_the_chamber_empties(recording, decay)
    fit = ldm.damped_sine_fit(decay, source)
    estimate = fit if method == "fit" else ldm.estimate(decay, method, source)
    return TrialResult(source, decay, estimate, fit, cycle_amplitudes(decay, fit), inertia_kgm2, recording)


def _warnings(trials: list[TrialResult]) -> list[str]:
    """One line per kind of trouble, naming the trials it concerns."""
    pumped, missed = [], []
    for trial in trials:
        name = Path(trial.file).name
        pressure = trial.recording.pressure_kpa[trial.decay.start_index:]
        if pressure.size and float(np.ptp(pressure)) > PRESSURE_CHANGE_WARNING_KPA:
            pumped.append(f"{name} ({np.ptp(pressure):.1f} kPa)")
        noise, rmse = trial.decay.noise_deg, trial.fit.rmse_deg
        if rmse is not None and noise > 0 and rmse > NOISE_RATIO_WARNING * noise:
            missed.append(f"{name} ({rmse:.2f} deg, {rmse / noise:.1f}x)")
    warnings = []
    if pumped:
        warnings.append(f"the pressure changes during the decay in {len(pumped)} of {len(trials)} trial(s): "
                        f"{', '.join(pumped)}; the LDM assumes a free oscillation at constant pressure")
    if missed:
        warnings.append(f"the damped sine misses the data by more than {NOISE_RATIO_WARNING:g}x the sensor "
                        f"noise in {len(missed)} of {len(trials)} trial(s): {', '.join(missed)}; the decay "
                        "is not a plain damped sine (asymmetric or nonlinear stiffness? run "
                        "`hand-service diagnose`)")
    return warnings


def identify_recordings(paths: list[Path], model: FingerModel, finger: str | None = None,
                        method: str = "fit") -> IdentifyResult:
    if method not in ldm.METHODS:
        raise UserError(f"unknown method '{method}' (one of {', '.join(ldm.METHODS)})")
    if not paths:
        raise UserError("give at least one trial recording")
    trials = []
    for path in paths:
        recording = read_recording(path, finger)
        check_finger(recording, finger or model.finger)
        trials.append(identify_trial(recording, model.inertia_kgm2, method))
    warnings = _warnings(trials)
    drift = decrement_drift([t.cycles for t in trials])
    note = drift.warning(float(np.mean([t.fit.stiffness_nm_per_rad(model.inertia_kgm2) for t in trials]))) \
        if drift else None
    if note:
        warnings.append(note)
    return IdentifyResult(method, model.inertia_kgm2, finger or model.finger, trials, drift, warnings)


__all__ = ["IdentifyResult", "TrialResult", "identify_recordings", "identify_trial"]
