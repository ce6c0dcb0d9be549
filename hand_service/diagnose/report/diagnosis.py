"""What `diagnose` found, as the command, the JSON (docs/formats.md) and the report read it."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hand_service.config.model import FingerModel
from hand_service.diagnose.fitting import raw_error
from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.problem import PLAIN, Problem
from hand_service.diagnose.outside_library.checks import Outside
from hand_service.diagnose.report.verdict import FoundEffect
from hand_service.diagnose.residual import stats
from hand_service.diagnose.search.forward_selection import Candidate, Selection
from hand_service.diagnose.search.rival_check import Rival


@dataclass
class Diagnosis:
    verdict: str
    model: FingerModel
    refit: Fit
    final: Fit
    problem: Problem
    nominal_angle_deg: np.ndarray
    effects: list[FoundEffect]
    windows: list[tuple[float, float, float]]
    rmse_deg: dict[str, float]  # held out, a constant offset each, no drift (raw_error.py)
    warnings: list[str]
    selection: Selection
    noise_deg: float
    whiteness: dict[str, stats.Whiteness]
    input_xcorr: stats.CrossCorrelation
    seconds: float = 0.0
    notes: list[str] = field(default_factory=list)
    partial_effects: list[FoundEffect] = field(default_factory=list)  # significant, yet not explaining
    explained_share: float = 0.0  # of the refitted model's mismatch, by the effects found
    structure_left: str = ""  # what says the final model still misses something ('' if nothing)
    outside: Outside = field(default_factory=Outside)  # physics outside the library a name stood for
    raw: raw_error.RawErrors | None = None  # every model against the raw angle, no drift
    rival: Rival | None = None  # a rival the search did not try that follows the raw angle as well

    @property
    def grade(self) -> str | None:
        """For missing_physics: "complete" when the augmented model leaves no structure and no
        rival the search did not try follows the raw angle as well; else "dominant"."""
        if self.verdict != "missing_physics":
            return None
        return "dominant" if self.structure_left else "complete"

    @property
    def noise_label(self) -> str:
        """What noise_deg is called where it is printed: the sensor's noise where the final
        model's residual passed as noise; where structure is left, the noise model took some of
        it, and its spread is not the sensor's noise (an outside probe's slew-limited chamber:
        2.75 deg against a true 0.1)."""
        return "the noise model's spread (structure is left: not all of it noise)" if self.structure_left \
            else "noise"

    def refit_model(self, with_effects: bool = True) -> FingerModel:
        """The refitted model; with the found effects added to its `effects` block."""
        source = self.final if with_effects and self.effects else self.refit
        changes = {name: float(getattr(source.finger.prbm, name)) for name in PLAIN}
        effects = dict(self.model.effects)
        if with_effects:
            for found in self.effects:
                effects[found.name] = {**effects.get(found.name, {}), **found.params}
        return self.model.with_changes(**changes, effects=effects)

    def to_json(self) -> dict:
        source = self.final if self.effects else self.refit
        refit = {"inertia_kgm2": self.model.inertia_kgm2,
                 **{name: float(getattr(source.finger.prbm, name)) for name in
                    ("damping_nms_per_rad", "stiffness_nm_per_rad", "pressure_gain_nm_per_kpa")}}
        # what the data alone say: a parameter the prior held shows as unknown (null)
        stds = dict(zip([p.label for p in source.params], source.std(with_prior=False), strict=True))
        round1 = self.selection.rounds[0].candidates if self.selection.rounds else []
        return {
            "verdict": self.verdict,
            "refit": refit,
            "effects": [e.to_json() for e in self.effects],
            "windows": [[round(max(0.0, a), 3), round(b, 3)] for a, b, _ in self.windows],
            "rmse_deg": self.rmse_deg,
            **(self.raw.to_json() if self.raw else {}),
            "warnings": self.warnings,
            "refit_std": {k: float(stds[k]) for k in PLAIN if k in stds},
            "noise_deg": self.noise_deg,
            "noise_model": {"ar": [float(a) for a in self.problem.noise.ar],
                            "innovation_std_deg": self.problem.noise.innovation_std_deg,
                            "drift_terms": (0 if self.problem.noise.basis is None
                                            else int(self.problem.noise.basis.shape[1]) - 1)},
            "sample_rate_hz": self.problem.rate_hz,
            "samples": {"fit": int(self.problem.fit_mask.sum()),
                        "held_out": int(self.problem.held_mask.sum())},
            "whiteness": {k: {"ljung_box_q": w.q, "lags": w.lags, "p_value": w.p_value}
                          for k, w in self.whiteness.items()},
            "input_cross_correlation": {"worst_lag_s": self.input_xcorr.worst[0],
                                        "worst_rho": self.input_xcorr.worst[1],
                                        "band_99": self.input_xcorr.band},
            "candidates": [candidate_json(c) for c in round1],
            "partial_effects": [e.to_json() for e in self.partial_effects],
            "grade": self.grade,
            "explained_share": self.explained_share,
            "structure_left": self.structure_left,
            **self.outside.to_json(),
            "rival": None if self.rival is None else self.rival.to_json(),
            "notes": self.notes,
            "seconds": self.seconds,
        }


def candidate_json(c: Candidate) -> dict:
    return {"name": c.name, "estimate": c.estimate, "std": c.std, "delta_bic": c.delta_bic,
            "heldout_z": c.z_heldout, "signature_corr": c.signature_corr, "separability": c.separability,
            "significant": c.significant}
