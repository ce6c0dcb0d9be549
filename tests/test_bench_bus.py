"""`hand-service bench --profile serial-v1.yaml`: the tick bench over the bus transport,
against a mock firmware that bench starts on a pty of its own and always ends."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from hand_service import cli
from hand_service.firmware import rig as rig_module


def test_bench_over_the_serial_mock(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    rigs: list[rig_module.Rig] = []

    class Recorded(rig_module.Rig):
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            rigs.append(self)

    monkeypatch.setattr(rig_module, "Rig", Recorded)
    out = tmp_path / "bench.json"
    argv = ["bench", "--quick", "--seconds", "2", "--no-realtime", "--recorder", "off",
            "--profile", "serial-v1.yaml", "--json", str(out)]
    assert cli.main(argv) == 0, capsys.readouterr().err
    figures = json.loads(out.read_text())
    assert figures["transport"] == "serial" and figures["rate_hz"] == 100
    assert figures["ticks"] == 200 and figures["ticks_floor"] == 200
    assert figures["faults"] == 0  # the bare loop's blocks stay inside the firmware's watchdog
    assert 0 < figures["tick_ns_p50"] <= figures["tick_ns_p99"]
    assert figures["plant_ns_p50"] is None  # a board on a bus runs its own physics
    (rig,) = rigs
    assert rig.profile.name == "serial-v1" and rig.process is not None
    assert rig.process.poll() is not None  # the mock process has ended
    assert not Path(rig.channel).parent.exists()  # and its pty directory is gone


def test_bench_refuses_a_real_bus(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["bench", "--quick", "--profile", "can-v1.yaml"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot mock one on the real bus socketcan" in err


def test_a_firmware_that_does_not_come_up_ends_the_bench(tmp_path: Path) -> None:
    """A refused handshake used to leave the bench ticking in FAULT for ever."""
    from hand_service.bench.tick import measure_ticks
    from hand_service.errors import UserError

    with rig_module.Rig("serial", tmp_path) as rig:
        rig.start_mock(protocol_version=rig.profile.protocol_version + 1)
        with pytest.raises(UserError, match=r"the firmware did not come up .*FAULT.*protocol"):
            measure_ticks(rig.profile, 100.0, 1.0, recorder=None, realtime_priority=None,
                          transport=rig.transport())
