"""The input test in a closed loop: a controller answers the sensor's noise in the command
of the same sample, which is no evidence against the model when the command is held from its
sample on (stats.input_independence, `first_lag`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hand_service.diagnose.residual import stats
from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.battery import diagnose_in_process


def test_a_loop_answering_the_noise_fails_lag_0_only() -> None:
    rng = np.random.default_rng(3)
    n = 4000
    noise = rng.normal(size=n)  # the innovations of a right model
    reference = np.repeat(rng.uniform(0.0, 50.0, n // 200), 200)
    command = reference - 0.5 * noise  # a proportional loop on the measured angle, same sample
    with_lag0 = stats.input_independence(noise, command, 25, first_lag=0)
    without = stats.input_independence(noise, command, 25, first_lag=1)
    assert with_lag0.p_value < 1e-6 and with_lag0.lags == 26
    assert without.p_value > 1e-3 and without.lags == 25
    # a residual that does follow the past command still fails without lag 0
    follows = noise + 0.2 * np.concatenate(([0.0, 0.0], command[:-2] - command.mean()))
    assert stats.input_independence(follows, command, 25, first_lag=1).p_value < 1e-6


def test_a_dead_zone_recorded_under_a_pi_loop_is_named(tmp_path: Path) -> None:
    """A PI loop on the angle, 500 Hz, a concealed dead zone (0.86 kPa): the loop's answer
    to the sensor at lag 0 (z ≈ −13) made the refit and the augmented model fail the input
    test, and the verdict was `unexplained`; from lag 1 on the input test passes and the
    dead zone is named, its threshold within 20 %."""
    spec = cs.CaseSpec("pressure_deadzone", "pi_steps", 0, "concealed", "ringing", 500.0, 0.8609165416137365)
    case = cs.build(spec)
    # concealed: 0.4-1.5 x the noise above a free plain refit (the battery scores it as
    # unobservable, its threshold seldom crossed; diagnose naming the truth is right there too)
    assert 0.4 <= case.visibility <= 1.5
    result = diagnose_in_process(*cs.write(case, tmp_path), tmp_path)
    assert [e["name"] for e in result["effects"]] == ["pressure_deadzone"], result["warnings"]
    found = result["effects"][0]["params"]["threshold_kpa"]
    assert abs(found / case.library_equivalent["threshold_kpa"] - 1.0) < 0.2
