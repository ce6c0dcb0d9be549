from __future__ import annotations

import numpy as np
import pytest

from hand_service.config.profile import Profile, load_profile
from hand_service.service.recorder import Recorder
from hand_service.service.states import Event, State
from hand_service.service.supervisor import Supervisor
from tests.service.fakes import FaultyTransport


class SpyRecorder(Recorder):
    """A recorder that only counts its flushes (no file)."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self.flushes = 0

    def flush(self) -> None:
        self.flushes += 1


class Rig:
    """A supervisor over a FaultyTransport, stepped tick by tick on a fake clock."""

    def __init__(self, profile: Profile | None = None) -> None:
        self.profile = profile or load_profile(None)
        self.transport = FaultyTransport(self.profile)
        self.recorder = SpyRecorder(self.profile.finger_names, 100.0)
        self.sup = Supervisor(self.profile, self.transport, self.recorder)
        self.now_ns = 1_000_000_000

    def tick(self, n: int = 1) -> None:
        for _ in range(n):
            self.sup.tick(self.now_ns)
            self.now_ns += self.sup.period_ns

    def running(self, angle_deg: float = 30.0) -> None:
        """INIT -> DISARMED -> ARMED -> RUNNING, every finger holding angle_deg."""
        self.tick()
        assert self.sup.state is State.DISARMED
        self.sup.fire(Event.ARM)
        self.sup.targets.mode[:] = 2  # position
        self.sup.targets.angle_deg[:] = angle_deg
        self.sup.fire(Event.START)
        self.tick(50)
        assert self.sup.state is State.RUNNING, self.sup.faults.faults

    def assert_faulted(self, cause: str) -> None:
        sup = self.sup
        assert sup.state is State.FAULT
        assert sup.faults.counts.get(cause) == 1, sup.faults.counts
        assert sup.faults.faults[-1].cause.value == cause
        assert self.recorder.flushes >= 1
        vents_before = self.transport.vents
        self.tick()
        assert self.transport.vents > vents_before or self.transport.lost  # vents every tick
        assert np.all(sup.sent_kpa == 0.0)
        assert np.all(sup.hand.inputs.mode == 0)


@pytest.fixture
def rig() -> Rig:
    return Rig()
