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
from hand_service.diagnose.residual.noise_bound import misfit_std

DRIFT_SAID = 1.0  # a drift of this many times the noise (RMS) or more is said
SAID_UNDER = ("consistent", "parameters_only")  # the verdicts that call the residual noise


def drift_said(verdict: str, problem: Problem, fit: Fit, masks: tuple[np.ndarray, np.ndarray],
               noise_deg: float) -> list[str]:
    """[] unless the verdict is one of SAID_UNDER and the noise model's drift under `fit`'s
    residual, over the scored samples and about its mean, is DRIFT_SAID times `noise_deg` or
    more; else the sentence that gives it beside the raw error (one constant offset fitted on
    the fitting samples, as the report's) and the error with the drift taken out. `masks`:
    the fitting samples and the scored ones."""
    fitting, scored = masks
    if verdict not in SAID_UNDER or not noise_deg > 0.0:
        return []
    misfit = problem.misfit(fit.angle_deg)
    drift_deg = misfit_std(problem.residual(fit.angle_deg) - misfit, scored)
    if not drift_deg >= DRIFT_SAID * noise_deg:
        return []
    raw_deg = raw_error.raw_rms_deg(problem, fit.angle_deg, fitting, scored)
    return [f"the noise model takes a slow drift of the sensor's offset, {drift_deg:.3g} deg RMS "
            f"({drift_deg / noise_deg:.2g} times the noise), for the sensor's own: with one constant "
            f"offset the refitted model misses the raw angle by {raw_deg:.3g} deg RMS, with the drift "
            f"taken out by {misfit_std(misfit, scored):.3g}; if the sensor holds its offset, that drift is "
            "a motion the model does not make (`--noise-model white` fits without it)"]
