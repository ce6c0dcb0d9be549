"""The control block is typed: one ControlSettings field per documented key."""

from __future__ import annotations

import dataclasses

import pytest

from hand_service.config.control import CONTROL_SECTION, ControlSettings
from hand_service.config.profile import load_profile


def test_one_field_per_key_of_the_section() -> None:
    assert [f.name for f in dataclasses.fields(ControlSettings)] == [k.name for k in CONTROL_SECTION.keys]


def test_a_profile_reads_its_control_block_into_the_dataclass() -> None:
    control = load_profile(None).control
    assert isinstance(control, ControlSettings)
    assert control.rate_hz == 100.0 and control.feedforward == "dynamic"
    faster = control.with_rate(200.0)
    assert faster.rate_hz == 200.0 and control.rate_hz == 100.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        control.rate_hz = 50.0  # type: ignore[misc]
