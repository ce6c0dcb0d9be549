"""The sensor's offset drift that the noise model takes for noise, said where it is large.

With `--noise-model ar`, the sensor's offset and its slow drift (noise.py's basis) are fitted
beside every model as nuisance terms. A drift as large as the noise or larger is a claim
about the sensor. So where the verdict says the residual is noise (`consistent`,
`parameters_only`), the report gives the size of the drift it took, on the raw angle. A lab
whose sensor holds its offset can then see the motion the drift hides.

An outside probe's case: a sensor drifting by 1.5° over 17 s, and a refit whose raw error
was 1.15 deg against a noise of 0.425, was reported `parameters_only` without a word about
the drift.
"""

from __future__ import annotations

import numpy as np

from hand_service.diagnose.fitting import raw_error
from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.problem import Problem

DRIFT_SAID = 1.0  # a drift of this many times the noise (RMS) or more is said


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x * x))) if x.size else 0.0


SAID_UNDER = ("consistent", "parameters_only")  # the verdicts that call the residual noise


def drift_said(verdict: str, problem: Problem, fit: Fit, masks: tuple[np.ndarray, np.ndarray],
               noise_deg: float) -> list[str]:
    """[drift_sentence] under a verdict of SAID_UNDER where it is not ''; else []. `masks`:
    the fitting samples and the scored ones."""
    said = drift_sentence(problem, fit, *masks, noise_deg) if verdict in SAID_UNDER else ""
    return [said] if said else []


def drift_sentence(problem: Problem, fit: Fit, fitting: np.ndarray, scored: np.ndarray,
                   noise_deg: float) -> str:
    """'' where the noise model's drift under `fit`'s residual, over the `scored` samples and
    about its mean, is below DRIFT_SAID times `noise_deg`; else the sentence that gives it
    beside the raw error (one constant offset fitted on `fitting`, as the report's) and the
    error with the drift taken out."""
    residual = problem.residual(fit.angle_deg)[scored]
    misfit = problem.misfit(fit.angle_deg)[scored]
    drift = residual - misfit
    drift = drift - drift.mean()
    drift_deg = _rms(drift)
    if not (noise_deg > 0.0 and drift_deg >= DRIFT_SAID * noise_deg):
        return ""
    raw_deg = raw_error.raw_rms_deg(problem, fit.angle_deg, fitting, scored)
    misfit_deg = _rms(misfit - misfit.mean())
    return (f"the noise model takes a slow drift of the sensor's offset, {drift_deg:.3g} deg RMS "
            f"({drift_deg / noise_deg:.2g} times the noise), for the sensor's own: with one constant "
            f"offset the refitted model misses the raw angle by {raw_deg:.3g} deg RMS, with the drift "
            f"taken out by {misfit_deg:.3g}; if the sensor holds its offset, that drift is a motion the "
            "model does not make (`--noise-model white` fits without it)")
