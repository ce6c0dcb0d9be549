"""A play between the finger and its sensor (backlash), not dry friction.

A play of width 2·h in the link the sensor reads (a gear's backlash, a slack tendon, a loose
coupling of the encoder) holds the recorded angle still while the finger turns, until the
finger has moved 2·h the other way, and then lets it follow the finger shifted by h. Dry
friction (the library's coulomb_friction) holds the finger itself still until the drive has
turned by twice its torque, and then lets it follow its equilibrium shifted by Tc/k. Where
the finger comes to rest after each change of the command (steps, a staircase) the two leave
the same mark: the angle stops short of the spring's line, on the side it came from. They
differ in the motion: friction takes the finger's energy, so its swings die within a few
cycles and its starts are smooth; a play takes none, so the finger rings on behind it and
the recorded angle turns with a kink where the play is taken up. An outside probe's backlash
on steps was named dry friction, `dominant` (docs/results.md §12.75).

Before dry friction is named, the play is fitted in its place: the final model without the
friction (its other found effects held as fitted), k, B, N and h refitted by output error
from the screen's best width (rival_fit.rival_model), the play operator applied to the
simulated angle (Krasnosel'skii and Pokrovskii, Systems with Hysteresis, 1989:
y = min(max(y_prev, x − h), x + h), from the simulated start). h stands for the friction's
torque: no parameter is charged. The play wins when it beats the named model on the
innovations by more than SIGNIFICANT_BIC, and on the raw angle (each simulated from the
recorded command, an offset each, fitting/raw_error.py) beyond the recording's fluctuation
(fitting/raw_difference.py), its raw error at most RAW_SHARE of the named model's. The last
keeps the friction's name where the library's smooth friction trails a stick-slip one (a
static torque above the kinetic, which holds the finger in a band much as a play does) by a
little: on the independent truth's ramp the play came 16 % closer; on the probe's backlash,
two thirds.

The fit is run only where a play helps at all: the play put on the named model's angle with
the friction taken out (k, B and N as fitted with it), at the widths SCREEN_SHARES of the
range, must fit the innovations better than the named model for one of them. A true
friction's screen stays above the named model's; a backlash's falls to about half of it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.fitting.raw_difference import LossDifference, loss_difference
from hand_service.diagnose.fitting.raw_error import raw_misfit_deg, raw_rms_deg
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.outside_library.material_hysteresis import FRICTION, SIGNIFICANT_BIC
from hand_service.diagnose.outside_library.rival_fit import rival_model
from hand_service.diagnose.residual import stats

RAW_SHARE = 0.5  # the play's raw error at most this share of the named model's (module doc)
SCREEN_SHARES = tuple(np.geomspace(0.002, 0.2, 13))  # the screen's widths h, as shares of the range
WIDTH_BOUNDS = (1e-4, 0.5)  # h's bounds, as shares of that range


def play(angle_deg: np.ndarray, half_width_deg: float) -> np.ndarray:
    """The angle read through a play of ±half_width_deg, centred at the start. Each sample
    clamps the last reading into [x − h, x + h]; clamps compose into clamps, so the readings
    are a prefix scan of intervals (doubling: log2(n) passes of whole arrays)."""
    x = np.asarray(angle_deg, dtype=float)
    low, high = x - half_width_deg, x + half_width_deg
    shift = 1
    while shift < x.size:
        # the clamp up to each sample: its own after the one `shift` samples before
        earlier_low, earlier_high = low[:-shift], high[:-shift]
        later_low, later_high = low[shift:], high[shift:]
        low_now = np.clip(earlier_low, later_low, later_high)
        high[shift:] = np.clip(earlier_high, later_low, later_high)
        low[shift:] = low_now
        shift *= 2
    return np.clip(x[:1], low, high) if x.size else x.copy()


@dataclass(frozen=True)
class Play:
    half_width_deg: float  # h: the play is 2·h wide
    delta_bic: float  # the play against the named model, on the innovations
    play_raw_deg: float  # raw RMS errors, each from the command with an offset
    named_raw_deg: float
    difference: LossDifference  # the play's squared raw error less the named model's

    def to_json(self) -> dict:
        dm = self.difference
        return {"half_width_deg": self.half_width_deg, "delta_bic": self.delta_bic,
                "raw_rmse_deg": self.play_raw_deg, "named_raw_rmse_deg": self.named_raw_deg,
                "difference_t": dm.statistic, "difference_critical_t": dm.critical}

    def sentence(self) -> str:
        dm = self.difference
        return (f"a play of {2.0 * self.half_width_deg:.2g}° between the finger and what the sensor "
                "reads (backlash: the reading holds while the finger turns back within it), fitted in "
                f"place of {FRICTION}, follows the recorded angle closer: raw RMS error "
                f"{self.play_raw_deg:.3g} against {self.named_raw_deg:.3g} deg, each simulated from the "
                f"recorded command with a constant offset alone (t = {dm.statistic:.2f} against "
                f"{dm.critical:.2f}; ΔBIC {self.delta_bic:.0f} on the innovations); backlash is outside "
                "the library")


def play_check(problem: Problem, final: Fit, found: list[str], fitting: np.ndarray,
               scored: np.ndarray) -> Play | None:
    """The play fitted in place of dry friction, when `found` names it; the play when it
    wins (module doc), else None."""
    if FRICTION not in found:
        return None
    span_deg = float(np.ptp(final.angle_deg[problem.fit_mask]))
    if not span_deg > 0.0:
        return None

    # the screen: the play on the named model's angle without the friction (k, B, N as fitted)
    without = problem.simulate(final.without(problem, [FRICTION]))
    screened = [problem.fit_rss(problem.innovations(play(without, share * span_deg)))
                for share in SCREEN_SHARES]
    named_rss = problem.fit_rss(problem.innovations(final.angle_deg))
    if min(screened) >= named_rss:
        return None  # a play does not help at all
    share = float(SCREEN_SHARES[int(np.argmin(screened))])  # the fit's start; x: log(h / h0)
    h0_deg = share * span_deg
    rival = rival_model(problem, final, [FRICTION], np.zeros(1), np.log(np.array(WIDTH_BOUNDS[:1]) / share),
                        np.log(np.array(WIDTH_BOUNDS[1:]) / share), lambda f, x: f,
                        lambda angle, x: play(angle, h0_deg * float(np.exp(x[0]))))
    if not np.all(np.isfinite(rival.angle_deg)):
        return None
    gain = stats.delta_bic(named_rss, rival.rss, problem.n_fit, 0)
    named_raw = raw_rms_deg(problem, final.angle_deg, fitting, scored)
    play_raw = raw_rms_deg(problem, rival.angle_deg, fitting, scored)
    difference = loss_difference(raw_misfit_deg(problem, final.angle_deg, fitting, scored),
                                 raw_misfit_deg(problem, rival.angle_deg, fitting, scored))
    if not (gain > SIGNIFICANT_BIC and difference.b_better and play_raw <= RAW_SHARE * named_raw):
        return None
    return Play(h0_deg * float(np.exp(rival.extra[0])), gain, play_raw, named_raw, difference)
