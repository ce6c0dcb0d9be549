"""The daemon under what should never happen: an exception escaping the loop still
vents, records the vented tick, closes the recording and the link."""

from __future__ import annotations

from pathlib import Path

import pytest

from hand_service.profile import load_profile
from hand_service.recorder import Recorder
from hand_service.recording import read_recording
from hand_service.states import Event, State
from hand_service.supervisor import Supervisor
from tests.daemon.fakes import FaultyTransport


def test_an_exception_in_the_loop_still_vents_and_closes_the_recording(tmp_path: Path) -> None:
    profile = load_profile(None)
    transport = FaultyTransport(profile)
    sup = Supervisor(profile, transport, Recorder(profile.finger_names, 100.0))
    record = tmp_path / "crash.csv"
    sup.recorder.start(record, {"profile": "sim"})

    def slack(_slack_ns: int) -> None:
        ticks = sup.stats.ticks
        if ticks == 2:
            sup.fire(Event.ARM)
            sup.targets.mode[:] = 1  # pressure
            sup.targets.pressure_kpa[:] = 40.0
            sup.fire(Event.START)
        if ticks == 130:
            at_crash.update(vents=transport.vents, sent_kpa=float(transport.sent[-1].max()))
            raise RuntimeError("a bug in a slack job")

    at_crash: dict[str, float] = {}
    sup.slack.append(slack)
    with pytest.raises(RuntimeError, match="a bug in a slack job"):
        sup.run(max_ticks=1000)
    assert sup.state is State.RUNNING  # the loop died pressurised ...
    assert sup.stop_reason == "RuntimeError in the loop"
    assert at_crash["sent_kpa"] > 10.0
    assert transport.vents > at_crash["vents"]  # ... and shutdown vented all the same
    assert not sup.link_open
    assert not sup.recorder.active
    rec = read_recording(record, finger="index")
    assert rec.columns["pressure_kpa"].max() > 10.0
    assert rec.columns["pressure_kpa"][-1] == 0.0  # the vented tick is the last row
    assert rec.text_columns["mode"][-1] == "vent"
