"""The logarithmic decrement method on one free-oscillation trial (docs/physics.md §2).

A trial: the tip is pushed, held and released; the finger rings down. `extract_decay`
finds the release and cuts out the free decay. Three ways to read it:

- `two_peak` — the paper's recipe: two consecutive sample-exact peaks, δ = ln(x₁/x₂),
  T_d their spacing. At 100 Hz (7–11 samples a cycle) it is off by up to ~15 %.
- `all_peaks` — sub-sample (parabolic) peaks over every cycle above the noise; T_d and
  δ by linear regression of the peak times and log-amplitudes against the cycle index.
- `damped_sine_fit` (the default) — least squares of the exact free response
  x(t) = c + e^(−σt)·(a·cos ω_d t + b·sin ω_d t) to every sample of the decay, seeded by
  `all_peaks`. (c, a, b) enter linearly and are solved inside (variable projection).

Every result is (σ, ω_d): ω_n = √(σ² + ω_d²), ζ = σ/ω_n, δ = 2πσ/ω_d, and with the
inertia A held fixed, k = A·ω_n², B = 2·σ·A.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, signal

from hand_service.errors import UserError

METHODS = ("fit", "peaks", "two-peak")
MIN_CYCLES = 2.0


@dataclass
class FreeDecay:
    """The free oscillation after the release, and what was learned finding it."""

    t_s: np.ndarray
    angle_deg: np.ndarray
    sign: float  # +1 when the finger was held above its rest angle
    rest_deg: float  # median of the record's last quarter
    hold_deg: float  # the held angle, relative to rest, in the held direction
    noise_deg: float  # sensor noise on the hold before the release (0: hold too short to tell)
    start_index: int  # index in the recording of the decay's first sample


@dataclass
class DecayEstimate:
    method: str
    decay_rate_per_s: float  # σ = ζ·ω_n
    damped_freq_rad_per_s: float  # ω_d
    rest_deg: float
    start_s: float
    end_s: float
    peaks_t_s: np.ndarray = field(default_factory=lambda: np.empty(0))
    peaks_deg: np.ndarray = field(default_factory=lambda: np.empty(0))
    coefficients_deg: tuple[float, float, float] | None = None  # (c, a, b) of the fitted curve
    rmse_deg: float | None = None

    @property
    def natural_freq_rad_per_s(self) -> float:
        return math.hypot(self.decay_rate_per_s, self.damped_freq_rad_per_s)

    @property
    def damping_ratio(self) -> float:
        return self.decay_rate_per_s / self.natural_freq_rad_per_s

    @property
    def log_decrement(self) -> float:
        return 2.0 * math.pi * self.decay_rate_per_s / self.damped_freq_rad_per_s

    @property
    def damped_period_s(self) -> float:
        return 2.0 * math.pi / self.damped_freq_rad_per_s

    def stiffness_nm_per_rad(self, inertia_kgm2: float) -> float:
        return inertia_kgm2 * self.natural_freq_rad_per_s**2

    def damping_nms_per_rad(self, inertia_kgm2: float) -> float:
        return 2.0 * self.decay_rate_per_s * inertia_kgm2

    def curve_deg(self, t_s: np.ndarray) -> np.ndarray:
        """The fitted free response (fit method only)."""
        if self.coefficients_deg is None:
            raise ValueError("only the damped-sine fit has a curve")
        c, a, b = self.coefficients_deg
        return c + _basis(np.asarray(t_s) - self.start_s, self.decay_rate_per_s,
                          self.damped_freq_rad_per_s)[:, 1:] @ np.array([a, b])


def _plateau_noise(h: np.ndarray, end: int, floor: float) -> float:
    """σ of the sensor on the hold: the detrended spread of the contiguous samples above
    `floor` before index `end` (0 when the hold is too short to tell)."""
    begin = end
    while begin > 0 and h[begin - 1] > floor and end - begin < 500:
        begin -= 1
    plateau = h[begin:end]
    if plateau.size < 10:
        return 0.0
    index = np.arange(plateau.size)
    trend = np.polyval(np.polyfit(index, plateau, 1), index)
    return float(np.std(plateau - trend, ddof=2))


def extract_decay(t_s: np.ndarray, angle_deg: np.ndarray, source: str = "") -> FreeDecay:
    """Find the release (the end of the hold at the largest excursion) and the decay after it."""
    label = f"{source}: " if source else ""
    n = angle_deg.size
    rest = float(np.median(angle_deg[-max(5, n // 4):]))
    excursion = signal.medfilt(angle_deg - rest, 5)
    peak = int(np.argmax(np.abs(excursion)))
    sign = 1.0 if excursion[peak] >= 0 else -1.0
    h = sign * (angle_deg - rest)
    hold = float(sign * excursion[peak])
    rough_noise = 1.4826 * float(np.median(np.abs(angle_deg - rest - excursion)))  # robust to the decay
    if hold <= 0.0 or hold < 10.0 * rough_noise:
        raise UserError(f"{label}no release found: the angle never leaves its rest level "
                        f"({rest:.3g} deg) by more than the noise")
    threshold = 0.15 * hold
    after = np.flatnonzero(h[peak:] < hold - threshold)
    if after.size == 0:
        raise UserError(f"{label}no release found: the finger stays at {rest + sign * hold:.3g} deg "
                        "to the end of the recording")
    start = peak + int(after[0])
    noise = _plateau_noise(h, start - 1, hold - threshold)
    if hold < 10.0 * noise:
        raise UserError(f"{label}no release found: the largest excursion ({hold:.3g} deg) is within "
                        f"ten times the sensor noise ({noise:.2g} deg)")
    if n - start < 10:
        raise UserError(f"{label}the recording ends {n - start} samples after the release")
    return FreeDecay(t_s=t_s[start:], angle_deg=angle_deg[start:], sign=sign, rest_deg=rest,
                     hold_deg=hold, noise_deg=noise, start_index=start)


def _dominant_freq_rad_per_s(t_s: np.ndarray, x: np.ndarray) -> float:
    dt = float(np.median(np.diff(t_s)))
    size = 16 * int(2 ** math.ceil(math.log2(x.size)))
    spectrum = np.abs(np.fft.rfft(x - np.median(x), size))  # the decay is its own window
    freqs = np.fft.rfftfreq(size, dt)
    spectrum[freqs < 1.0 / (t_s[-1] - t_s[0])] = 0.0  # below one cycle in the window
    return 2.0 * math.pi * float(freqs[int(np.argmax(spectrum))])


def _peak_indices(decay: FreeDecay, h: np.ndarray) -> np.ndarray:
    """Crests of h (the decay toward rest, in the held direction) above the noise, in order,
    up to the first that the noise could have made."""
    omega = _dominant_freq_rad_per_s(decay.t_s, h)
    if omega <= 0.0:
        return np.empty(0, dtype=int)
    dt = float(np.median(np.diff(decay.t_s)))
    distance = max(2, int(0.7 * 2.0 * math.pi / omega / dt))
    floor = max(5.0 * decay.noise_deg, 0.01 * decay.hold_deg)
    peaks, _ = signal.find_peaks(h, distance=distance)
    peaks = peaks[(peaks > 0) & (peaks < h.size - 1)]
    above = np.flatnonzero(h[peaks] < floor)
    return peaks[: above[0]] if above.size else peaks


def _too_few(source: str, found: int, needed: int) -> UserError:
    label = f"{source}: " if source else ""
    return UserError(f"{label}only {found} oscillation peak(s) above the noise after the release; "
                     f"{needed} are needed (push further, or record longer)")


def two_peak(decay: FreeDecay, source: str = "") -> DecayEstimate:
    """The paper's recipe: δ = ln(x₁/x₂) and T_d from two consecutive sample-exact peaks."""
    h = decay.sign * (decay.angle_deg - decay.rest_deg)
    peaks = _peak_indices(decay, h)
    if peaks.size < 2:
        raise _too_few(source, int(peaks.size), 2)
    p1, p2 = int(peaks[0]), int(peaks[1])
    period = float(decay.t_s[p2] - decay.t_s[p1])
    delta = math.log(h[p1] / h[p2])
    return DecayEstimate("two-peak", delta / period, 2.0 * math.pi / period, decay.rest_deg,
                         float(decay.t_s[0]), float(decay.t_s[p2]), decay.t_s[[p1, p2]],
                         decay.angle_deg[[p1, p2]])


def _parabolic(t: np.ndarray, h: np.ndarray, i: int) -> tuple[float, float]:
    """Vertex of the parabola through samples i−1, i, i+1 (uniform spacing)."""
    y0, y1, y2 = h[i - 1], h[i], h[i + 1]
    denominator = y0 - 2.0 * y1 + y2
    shift = 0.5 * (y0 - y2) / denominator if denominator < 0 else 0.0
    shift = min(max(shift, -0.5), 0.5)
    dt = 0.5 * (t[i + 1] - t[i - 1])
    return float(t[i] + shift * dt), float(y1 - 0.25 * (y0 - y2) * shift)


def _crests(decay: FreeDecay, h: np.ndarray) -> list[tuple[float, float]]:
    """Sub-sample (time, height) of every crest of h above the noise floor."""
    return [_parabolic(decay.t_s, h, int(i)) for i in _peak_indices(decay, h)]


def all_peaks(decay: FreeDecay, source: str = "") -> DecayEstimate:
    """Sub-sample crests and troughs over every cycle above the noise: T_d and δ by
    regression of their times and log-amplitudes on the half-cycle index."""
    h = decay.sign * (decay.angle_deg - decay.rest_deg)
    extrema = sorted([(t, x, 1.0) for t, x in _crests(decay, h)]
                     + [(t, x, -1.0) for t, x in _crests(decay, -h)])
    kept = 1
    while kept < len(extrema) and extrema[kept][2] != extrema[kept - 1][2]:
        kept += 1  # a crest, a trough, a crest ...: stop where one is missing
    times, heights, kinds = np.array(extrema[:kept]).T if extrema else (np.empty(0),) * 3
    if np.sum(kinds > 0) < 2 or times.size < 3:
        raise _too_few(source, int(np.sum(kinds > 0)), 2)
    index = np.arange(times.size)
    half_period = float(np.polyfit(index, times - times[0], 1)[0])
    # δ from the log-amplitudes, weighted by amplitude (their noise is σ/x)
    slope = np.polyfit(index, np.log(heights), 1, w=heights)[0]
    delta = max(-2.0 * float(slope), 1e-9)
    period = 2.0 * half_period
    return DecayEstimate("peaks", delta / period, 2.0 * math.pi / period, decay.rest_deg,
                         float(decay.t_s[0]), float(times[-1]), times,
                         decay.rest_deg + decay.sign * kinds * heights)


def _basis(t: np.ndarray, sigma: float, omega: float) -> np.ndarray:
    envelope = np.exp(-sigma * t)
    return np.column_stack([np.ones_like(t), envelope * np.cos(omega * t), envelope * np.sin(omega * t)])


def _solve(t: np.ndarray, x: np.ndarray, sigma: float, omega: float) -> tuple[np.ndarray, np.ndarray]:
    basis = _basis(t, sigma, omega)
    coefficients = np.linalg.lstsq(basis, x, rcond=None)[0]
    return coefficients, basis @ coefficients - x


def _fit_window(t: np.ndarray, x: np.ndarray, sigma0: float,
                omega0: float) -> tuple[float, float, np.ndarray]:
    result = optimize.least_squares(
        lambda p: _solve(t, x, p[0], p[1])[1], x0=[max(sigma0, 1e-3), omega0],
        bounds=([0.0, 0.3 * omega0], [np.inf, 3.0 * omega0]), x_scale=[max(sigma0, 0.1), omega0],
        xtol=1e-12, ftol=1e-12, gtol=1e-12)
    sigma, omega = (float(v) for v in result.x)
    coefficients, _ = _solve(t, x, sigma, omega)
    return sigma, omega, coefficients


def damped_sine_fit(decay: FreeDecay, source: str = "") -> DecayEstimate:
    """Least squares of the exact free response over the decay, seeded by `all_peaks`.

    The window ends where the fitted envelope sinks into the noise: past that the data
    hold no information on the decay, only on slow drifts that would bias the rest level.
    """
    try:
        seed = all_peaks(decay, source)
        sigma0, omega0 = seed.decay_rate_per_s, seed.damped_freq_rad_per_s
    except UserError:
        seed = None
        omega0 = _dominant_freq_rad_per_s(decay.t_s, decay.angle_deg)
        sigma0 = 0.05 * omega0
        if omega0 <= 0.0:
            raise UserError(f"{source + ': ' if source else ''}no oscillation after the release at "
                            f"t = {decay.t_s[0]:.3g} s") from None
    t = decay.t_s - decay.t_s[0]
    x = decay.angle_deg
    sigma, omega, coefficients = _fit_window(t, x, sigma0, omega0)
    for _ in range(2):
        _, residual = _solve(t, x, sigma, omega)
        noise = float(np.sqrt(np.mean(residual**2)))
        amplitude = math.hypot(coefficients[1], coefficients[2])
        if sigma <= 0.0 or noise <= 0.0 or amplitude <= noise:
            break
        end = min(t[-1], math.log(amplitude / noise) / sigma)
        keep = t <= end
        if keep.all() or keep.sum() < 10:
            break
        t, x = t[keep], x[keep]
        sigma, omega, coefficients = _fit_window(t, x, sigma, omega)
    cycles = t[-1] * omega / (2.0 * math.pi)
    if cycles < MIN_CYCLES:
        raise UserError(f"{source + ': ' if source else ''}the free decay after the release lasts "
                        f"{cycles:.1f} cycles above the noise; at least {MIN_CYCLES:g} are needed")
    _, residual = _solve(t, x, sigma, omega)
    return DecayEstimate("fit", sigma, omega, float(coefficients[0]), float(decay.t_s[0]),
                         float(decay.t_s[0] + t[-1]),
                         seed.peaks_t_s if seed else np.empty(0), seed.peaks_deg if seed else np.empty(0),
                         (float(coefficients[0]), float(coefficients[1]), float(coefficients[2])),
                         float(np.sqrt(np.mean(residual**2))))


ESTIMATORS = {"fit": damped_sine_fit, "peaks": all_peaks, "two-peak": two_peak}


def estimate(decay: FreeDecay, method: str = "fit", source: str = "") -> DecayEstimate:
    if method not in ESTIMATORS:
        raise UserError(f"unknown method '{method}' (one of {', '.join(METHODS)})")
    return ESTIMATORS[method](decay, source)


__all__ = ["ESTIMATORS", "METHODS", "DecayEstimate", "FreeDecay", "all_peaks", "damped_sine_fit",
           "estimate", "extract_decay", "two_peak"]
