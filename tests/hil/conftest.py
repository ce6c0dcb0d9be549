"""Each HIL test gets a rig of its own (channel, mock, hosts), ended when the test ends."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from hand_service.firmware.rig import RIG_PROFILES, Rig


@pytest.fixture(params=sorted(RIG_PROFILES))
def rig(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Rig]:
    with Rig(request.param, tmp_path) as bench_rig:
        yield bench_rig
