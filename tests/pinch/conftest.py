from __future__ import annotations

import pytest

from hand_service.config.profile import Profile, load_profile


@pytest.fixture(scope="session")
def truth() -> Profile:
    """sim.yaml's hand; in these quick tests the controller knows it exactly."""
    return load_profile(None)
