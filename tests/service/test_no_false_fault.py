"""No false FAULT on trajectories a lab would write: piecewise-linear CSVs, as
docs/examples/wave.csv is, played on a simulated hand that the host's model gets a little
wrong (k, N within half the stated model uncertainty, B within it) through a sensor the lab
calibrated a little off. The README's wave once faulted `implausible` this way on a model
that was exact; the fault matrix's clean minutes play only the paper's cosine."""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hand_service.config.profile import Profile, load_profile
from hand_service.service.states import Event, State
from hand_service.service.trajectory_csv import read_trajectory
from tests.service.test_plausibility import TruthRig

SETTLE_TICKS = 150  # after the trajectory ends: the hand comes to rest, still checked


@dataclasses.dataclass(frozen=True)
class Lab:
    """What the host believes against the hand it drives."""

    stiffness_scale: float
    gain_scale: float
    damping_scale: float
    sensor_gain_scale: float
    sensor_offset_deg: float
    seed: int


def knots() -> st.SearchStrategy[list[tuple[float, list[float]]]]:
    """(duration of the segment in s, the five fingers' angles in deg at its end)."""
    angles = st.lists(st.floats(0.0, 120.0), min_size=5, max_size=5)
    return st.lists(st.tuples(st.floats(0.3, 2.0), angles), min_size=2, max_size=6)


def labs(uncertainty: float) -> st.SearchStrategy[Lab]:
    half = uncertainty / 2
    return st.builds(Lab, st.floats(1 - half, 1 + half), st.floats(1 - half, 1 + half),
                     st.floats(1 - uncertainty, 1 + uncertainty), st.floats(0.995, 1.005),
                     st.floats(-1.0, 1.0), st.integers(0, 2**16))


def write_csv(path: Path, profile: Profile, segments: list[tuple[float, list[float]]]) -> float:
    names = profile.finger_names
    lines = ["t," + ",".join(f"angle_ref_deg_{n}" for n in names), "0.0," + ",".join("0" for _ in names)]
    t_s = 0.0
    for duration_s, angles in segments:
        t_s += duration_s
        lines.append(f"{t_s:.3f}," + ",".join(f"{a:.2f}" for a in angles))
    path.write_text("\n".join(lines) + "\n")
    return t_s


def host_and_truth(lab: Lab) -> tuple[Profile, Profile]:
    truth = load_profile(None)
    fingers = []
    for f in truth.fingers:
        model = dataclasses.replace(
            f.model, stiffness_nm_per_rad=f.model.stiffness_nm_per_rad * lab.stiffness_scale,
            pressure_gain_nm_per_kpa=f.model.pressure_gain_nm_per_kpa * lab.gain_scale,
            damping_nms_per_rad=f.model.damping_nms_per_rad * lab.damping_scale)
        sensor_gain = f.sensor_gain_deg_per_mv * lab.sensor_gain_scale
        fingers.append(dataclasses.replace(f, model=model, sensor_gain_deg_per_mv=sensor_gain,
                                           sensor_offset_deg=f.sensor_offset_deg + lab.sensor_offset_deg))
    return dataclasses.replace(truth, fingers=fingers), truth


UNCERTAINTY = load_profile(None).safety["model_uncertainty_percent"] / 100.0


def played(segments: list[tuple[float, list[float]]], lab: Lab) -> TruthRig:
    """The trajectory played to its end and SETTLE_TICKS beyond, the host's model `lab`'s."""
    host, truth = host_and_truth(lab)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "lab.csv"
        duration_s = write_csv(path, host, segments)
        trajectory = read_trajectory(path, host)
    rig = TruthRig(host, truth, seed=lab.seed)
    rig.tick()
    rig.sup.set_trajectory(trajectory)
    rig.sup.fire(Event.ARM)
    rig.sup.fire(Event.START)
    rig.tick(round(duration_s * 100) + SETTLE_TICKS)
    return rig


# The examples are drawn the same way in every run (derandomize), so that make test judges
# the same trajectories each time; a false fault found by a random draw is kept below.
@settings(max_examples=20, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(segments=knots(), lab=labs(UNCERTAINTY))
def test_a_lab_s_trajectory_on_a_hand_the_model_gets_a_little_wrong_never_faults(
        segments: list[tuple[float, list[float]]], lab: Lab) -> None:
    rig = played(segments, lab)
    assert rig.sup.state is State.HOLD, (rig.sup.faults.faults, segments, lab)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_fast_move_of_the_middle_finger_on_opposite_k_and_n_errors_is_no_drift(seed: int) -> None:
    """Found by a random draw of the test above: the middle finger (ζ 0.06) to 76° in 0.5 s,
    the host's k 3.125 % high and N 3.125 % low (each half of the stated uncertainty). The
    prediction rang on the pressure sensor's noise, the fit cancelled the ringing with θ and
    read the slow move that followed as a trend (+4.4 deg/s judged against 2.5: a FAULT).
    Fitted on low-passed signals the trend, less its doubt, stays under half the limit."""
    rig = played([(0.5, [0.0, 0.0, 76.0, 0.0, 0.0]), (1.0, [0.0, 0.0, 83.0, 0.0, 0.0])],
                 Lab(1.03125, 0.96875, 1.0, 1.0, 0.0, seed))
    assert rig.sup.state is State.HOLD, rig.sup.faults.faults
    trend = rig.sup.model_check.trend
    assert trend.worst_judged_deg_per_s.max() < 0.5 * trend.limit_deg_per_s, trend.worst_judged_deg_per_s
