"""pytest-benchmark cases for the control step (run for real by `make bench`; in `make test`
--benchmark-disable runs each once, as a smoke test)."""

from __future__ import annotations

import pytest

import rtcore
from hand_service.config.profile import load_profile


@pytest.fixture(scope="module")
def config() -> rtcore.HandConfig:
    return load_profile().hand_config()


def _position(hand: rtcore.Hand | rtcore.ReferenceHand) -> rtcore.Hand | rtcore.ReferenceHand:
    hand.inputs.mode[:] = rtcore.MODE_POSITION
    hand.inputs.sensor_mv[:] = 900.0
    hand.inputs.angle_ref_deg[:] = 45.0
    return hand


def test_c_step_five_fingers(benchmark, config: rtcore.HandConfig) -> None:
    hand = _position(rtcore.Hand(config))
    benchmark(hand.step)
    assert hand.outputs.pressure_cmd_kpa.max() > 0.0


def test_python_reference_step_five_fingers(benchmark, config: rtcore.HandConfig) -> None:
    hand = _position(rtcore.ReferenceHand(config))
    benchmark(hand.step)
    assert hand.outputs.pressure_cmd_kpa.max() > 0.0
