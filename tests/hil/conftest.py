"""Each HIL test gets a rig of its own (channel, mock, hosts), ended when the test ends."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from hand_service.config.profile import load_profile
from hand_service.firmware.rig import RIG_PROFILES, Rig
from tests.hil.tolerant import SAMPLE_AGE_MAX_MS, tolerant_profile


@pytest.fixture(params=sorted(RIG_PROFILES))
def rig(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Rig]:
    with Rig(request.param, tmp_path) as bench_rig:
        yield bench_rig


@pytest.fixture(params=sorted(RIG_PROFILES))
def tolerant_rig(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Rig]:
    """A rig whose profile bounds the sample age at SAMPLE_AGE_MAX_MS (tests/hil/tolerant.py)."""
    profile = load_profile(tolerant_profile(request.param, tmp_path))
    assert profile.safety["sample_age_max_ms"] == SAMPLE_AGE_MAX_MS
    with Rig(request.param, tmp_path, profile) as bench_rig:
        yield bench_rig


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Every fault kind over SLCAN runs with `make test-faults`: make test injects each kind
    on serial and the virtual bus here, and on all three links once in the fault matrix."""
    for item in items:
        where = item.nodeid
        if where.startswith("tests/hil/test_valve_board.py") and "_is_detected[slcan-" in where:
            item.add_marker(pytest.mark.faults)
