"""The checks that a named effect is not standing in for physics outside the library: a
cubic spring or gravity for a contact or an end stop (contact_onset.py), a valve lag or a
dead time for a loop that does not grow with the rate (rate_independent_loop.py), dry
friction for a loop in the angle, hysteresis in the material (material_hysteresis.py), or for
a play between the finger and its sensor, backlash (sensor_play.py).
Each is run on the final model when it names its effect; any that wins turns the answer
into "outside the library"."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.outside_library.contact_onset import SMOOTH_STATIC, Onset, onset_check
from hand_service.diagnose.outside_library.material_hysteresis import Hysteresis, hysteresis_check
from hand_service.diagnose.outside_library.rate_independent_loop import Loop, loop_check
from hand_service.diagnose.outside_library.sensor_play import Play, play_check


@dataclass(frozen=True)
class Outside:
    onset: Onset | None = None  # a torque that switches on at an angle
    loop: Loop | None = None  # a lag that does not grow with the rate
    hysteresis: Hysteresis | None = None  # a loop in the angle, in dry friction's place
    play: Play | None = None  # a play before the sensor, in dry friction's place

    def sentences(self, names: list[str]) -> list[str]:
        """What each check that won says, for the warnings."""
        said = [self.onset and self.onset.sentence([n for n in names if n in SMOOTH_STATIC]),
                self.loop and self.loop.sentence(), self.hysteresis and self.hysteresis.sentence(),
                self.play and self.play.sentence()]
        return [s for s in said if s]

    def to_json(self) -> dict:
        return {"onset": None if self.onset is None else self.onset.to_json(),
                "loop": None if self.loop is None else self.loop.to_json(),
                "hysteresis": None if self.hysteresis is None else self.hysteresis.to_json(),
                "play": None if self.play is None else self.play.to_json()}


def outside_checks(problem: Problem, final: Fit, names: list[str],
                   masks: tuple[np.ndarray, np.ndarray]) -> Outside:
    """Every check whose effect `names` holds, on the final model; `masks` the fitting and
    the scored samples of the raw angle (fitting/raw_error.py)."""
    return Outside(onset_check(problem, final, names), loop_check(problem, final, names),
                   hysteresis_check(problem, final, names), play_check(problem, final, names, *masks))
