"""A board that leaves `running` for a moment (its watchdog fired on a late command over a
loaded link) is not at fault; one that stays out while valid commands keep coming is."""

from __future__ import annotations

from dataclasses import dataclass, field

from hand_service.boardcheck.link import Received
from hand_service.boardcheck.valves import _stays_out_of_running
from hand_service.wire.messages import FirmwareState, Status

RUN, VENTED = FirmwareState.RUNNING, FirmwareState.WATCHDOG_VENTED


@dataclass
class _Session:
    """Answers the confirming stretch with the board's next states."""

    next_states: list[FirmwareState]
    pumped: list[float] = field(default_factory=list)

    def pump(self, seconds: float, pressure_kpa: float | None = None) -> list[Received]:
        self.pumped.append(seconds)
        return [Received(0.1 * i, Status(state, 0)) for i, state in enumerate(self.next_states)]


def test_a_moment_out_of_running_that_ends_running_is_not_a_fault() -> None:
    session = _Session([VENTED])
    assert not _stays_out_of_running(session, [RUN, VENTED, RUN], 0.0)  # type: ignore[arg-type]
    assert session.pumped == []  # the stretch ended running: nothing more to ask


def test_a_stretch_that_ends_out_of_running_is_confirmed_with_one_more() -> None:
    recovers = _Session([VENTED, RUN, RUN])
    assert not _stays_out_of_running(recovers, [RUN, RUN, VENTED], 0.0)  # type: ignore[arg-type]
    stays = _Session([VENTED, VENTED, VENTED])
    assert _stays_out_of_running(stays, [RUN, VENTED, VENTED], 0.0)  # type: ignore[arg-type]
    silent = _Session([])
    assert _stays_out_of_running(silent, [VENTED], 0.0)  # type: ignore[arg-type]
    assert len(stays.pumped) == len(recovers.pumped) == 1
