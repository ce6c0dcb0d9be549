"""The daemon runs with a short GIL switch interval and gives the old one back after."""

from __future__ import annotations

import sys

import pytest

from hand_service.app.daemon import Daemon, DaemonOptions
from hand_service.config.profile import load_profile
from hand_service.service.timing import SWITCH_INTERVAL_S
from hand_service.transports import transport_class


def test_the_loop_runs_with_a_short_switch_interval() -> None:
    profile = load_profile()
    daemon = Daemon(profile, transport_class("sim")(profile), DaemonOptions())
    seen: list[float] = []
    daemon.sup.slack.append(lambda _slack_ns: seen.append(sys.getswitchinterval()))
    before = sys.getswitchinterval()
    assert before != pytest.approx(SWITCH_INTERVAL_S)  # CPython's 5 ms, unless something leaked it
    daemon.open()
    daemon.run(0.1, install_signals=False)
    assert seen and all(value == pytest.approx(SWITCH_INTERVAL_S) for value in seen)
    assert sys.getswitchinterval() == before
