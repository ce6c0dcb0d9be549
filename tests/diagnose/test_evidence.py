"""Evidence sentences say what this recording shows: no free swings where there were none."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np

from hand_service.diagnose.fitting.raw_error import RawErrors
from hand_service.diagnose.report.evidence import Context, _coulomb, _hysteresis

RATE_HZ = 100.0
T = np.arange(int(10 * RATE_HZ)) / RATE_HZ


def _context(pressure_kpa: np.ndarray, velocity_deg_per_s: np.ndarray) -> Context:
    problem = SimpleNamespace(pressure_kpa=pressure_kpa, rate_hz=RATE_HZ)
    return Context(problem, np.zeros_like(T), velocity_deg_per_s, 0.57, 0.003, 0.01)  # type: ignore[arg-type]


def test_steps_without_free_swings_are_not_said_to_have_them() -> None:
    steps = np.repeat([10.0, 60.0, 20.0, 80.0], T.size // 4)
    velocity = np.where(np.abs(np.diff(steps, prepend=steps[0])) > 0, 300.0, 0.0)  # moves, then rests
    text = _coulomb(_context(steps, velocity))
    assert "free swings" not in text and "nearly still" in text and "0.01 N·m" in text


def test_a_release_is_a_free_swing() -> None:
    velocity = 200.0 * np.exp(-T) * np.sin(2 * np.pi * 9.5 * T)  # ringing at rest pressure
    text = _coulomb(_context(np.zeros(T.size), velocity))
    assert "free swings would lose about 4 deg" in text and "the model's figure" in text


def test_an_unidentifiable_value_is_said_so_never_plus_minus_inf(capsys) -> None:
    """The evidence sentence, the report's tables and the command's parameter table."""
    from hand_service.commands.diagnose import print_summary
    from hand_service.diagnose.report.evidence import estimate, sentence, uncertainty

    assert uncertainty(0.00213, "s") == "± 0.0021 s" and estimate(0.0312, 0.0021, "s") == "0.0312 ± 0.0021 s"
    assert estimate(0.1061, 0.00043, "1") == "0.1061 ± 0.00043"  # a gain: no unit "1" printed after it
    for std in (np.inf, np.nan):
        assert uncertainty(std) == "not identifiable"
        assert estimate(0.0312, std, "s") == "0.0312 s (not identifiable)"
    context = _context(np.zeros(T.size), np.zeros(T.size))
    errors = RawErrors(dict.fromkeys(("before", "after"), 0.0), {"before": 0.5, "after": 0.4},
                       {"before": 0.5, "after": 0.4})
    text = sentence("valve_lag", context, np.inf, 12.0, 3.0, errors)
    assert "(not identifiable)" in text and "inf" not in text.replace("information", "")
    model = SimpleNamespace(stiffness_nm_per_rad=0.57, damping_nms_per_rad=0.003,
                            pressure_gain_nm_per_kpa=0.009)
    refit = {"stiffness_nm_per_rad": 0.571, "damping_nms_per_rad": 0.0031, "pressure_gain_nm_per_kpa": 0.0091}
    result = SimpleNamespace(model=model, effects=[], noise_deg=0.3, noise_label="noise", seconds=1.5,
                             to_json=lambda: {
        "verdict": "insufficient_excitation", "refit": refit, "rmse_deg": dict.fromkeys(
            ("nominal", "refit", "augmented"), 0.4), "windows": [], "warnings": [],
        "refit_std": {"stiffness_nm_per_rad": np.inf, "damping_nms_per_rad": 1e-4}})
    print_summary(result, screen=False)
    out = capsys.readouterr().out
    assert "inf" not in out and "not identifiable" in out.splitlines()[2]
    assert out.splitlines()[3].endswith("± 0.0001") and "(the fits took 1.5 s)" in out


def test_a_window_from_the_start_prints_without_a_minus_zero(capsys) -> None:
    """A window starting at −0.0 s (rounded from a tiny negative time) was printed
    "-0.00-0.44"; and a refit known worse than its value says it is unknown."""
    from hand_service.commands.diagnose import print_summary

    model = SimpleNamespace(stiffness_nm_per_rad=0.57, damping_nms_per_rad=0.003,
                            pressure_gain_nm_per_kpa=0.009)
    refit = {"stiffness_nm_per_rad": 0.42, "damping_nms_per_rad": 0.0031, "pressure_gain_nm_per_kpa": 0.0091}
    result = SimpleNamespace(model=model, effects=[], noise_deg=0.3, noise_label="noise", seconds=1.5,
                             to_json=lambda: {
        "verdict": "unexplained", "refit": refit,
        "rmse_deg": dict.fromkeys(("nominal", "refit", "augmented"), 0.4),
        "windows": [[-0.0, 0.44], [1.2, 1.5]], "warnings": [],
        "refit_std": {"stiffness_nm_per_rad": 15.0, "damping_nms_per_rad": 1e-4}})
    print_summary(result, screen=False)
    out = capsys.readouterr().out
    assert "windows (s): 0.00 to 0.44, 1.20 to 1.50" in out, out
    assert "± 15 (unknown: over 100 % of the value)" in out, out


def test_a_loop_turning_within_a_hair_of_the_range_is_said_to_be_a_friction_too() -> None:
    """Dahl's loop named on an over-damped finger whose dry friction sticks: turning within
    0.64° of 78°, the sentence says it may be a friction, and how the library's fared."""
    angle = np.linspace(0.0, 78.0, T.size)
    context = _context(angle, np.zeros(T.size))
    context.problem.measured_deg = angle
    sticking = replace(context, value=0.0065, shape={"travel_deg": 0.64},
                       round_bic={"hysteresis": 191.0, "coulomb_friction": -33.0})
    text = _hysteresis(sticking)
    assert "0.82 % of the 78 deg recorded" in text and "may be such a friction" in text, text
    assert "gained ΔBIC -33 against the loop's 191" in text
    material = _hysteresis(replace(sticking, shape={"travel_deg": 3.0}))
    assert "friction" not in material and "3 deg of travel" in material, material
