"""Every request does what it answers in every state, or is refused with the state and the
commands that would make it work: the table of api/state_table.py, walked state by state
through the API on a supervisor ticked by hand, and docs/api.md shows that table."""

from __future__ import annotations

import re
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hand_service.api.requests import Api
from hand_service.api.server import Deferred
from hand_service.api.state_table import NOW, REQUESTS, cell, render
from hand_service.config.profile import load_profile
from hand_service.service.recorder import Recorder
from hand_service.service.safety import Cause, Fault
from hand_service.service.states import State
from hand_service.service.supervisor import Supervisor
from rtcore import MODE_POSITION
from tests.service.fakes import FaultyTransport

ROOT = Path(__file__).resolve().parents[2]
FINGER = "index"
RUNNING_DEG, TARGET_DEG = 30.0, 20.0
TRAJECTORY = "t,angle_ref_deg_index\n0.0,50\n0.5,50\n"


class Hand:
    """A supervisor on the simulated hand behind the API, ticked on a fake clock."""

    def __init__(self, record_dir: Path) -> None:
        profile = load_profile(None)
        recorder = Recorder(profile.finger_names, 100.0, "thread")
        self.sup = Supervisor(profile, FaultyTransport(profile), recorder)
        self.api = Api(self.sup, metadata=dict, record_dir=record_dir)
        self.index = profile.finger_names.index(FINGER)
        self.now_ns = 10**9

    def tick(self, n: int = 1) -> None:
        for _ in range(n):
            self.sup.tick_index += 1
            self.sup.tick(self.now_ns)
            self.now_ns += self.sup.period_ns

    def ask(self, cmd: str, **args: Any) -> dict[str, Any]:
        reply = self.api.handle({"cmd": cmd, **args})
        if isinstance(reply, Deferred):  # load_trajectory: parsed in a worker
            end = time.monotonic() + 10.0
            while (answer := reply.reply()) is None and time.monotonic() < end:
                self.api.poll()
                time.sleep(0.005)
            assert answer is not None, f"{cmd}: no reply"
            return answer
        return reply

    def follows_target(self) -> bool:
        inputs = self.sup.hand.inputs
        return bool(inputs.mode[self.index] == MODE_POSITION
                    and inputs.angle_ref_deg[self.index] == pytest.approx(TARGET_DEG))

    def plays(self) -> bool:
        return self.sup.hand.inputs.angle_ref_deg[self.index] == pytest.approx(50.0)


def in_state(state: State, record_dir: Path) -> Hand:
    hand = Hand(record_dir)
    if state is State.INIT:
        return hand
    hand.tick()  # the handshake
    if state is State.FAULT:
        hand.sup.fault(Fault(Cause.TRANSPORT_LOST, "test"))
    elif state is State.ESTOP:
        hand.ask("estop")
    elif state is not State.DISARMED:
        hand.ask("arm")
        hand.ask("mode", finger="all", mode="position")
        hand.ask("target", finger="all", angle_deg=RUNNING_DEG)
        if state is not State.ARMED:
            hand.ask("start")
            hand.tick(5)
            if state is State.HOLD:
                hand.ask("hold")
    hand.tick()
    assert hand.sup.state is state
    return hand


def commands_in(text: str) -> list[str]:
    """The commands a refusal or an `applies` names, in order: `reset, then arm first (the
    handshake comes between)` -> [reset, arm]; of `hold or disarm` the first; none for
    `already RUNNING` or `only FAULT or ESTOP take it`."""
    if text.startswith(("already", "only")):
        return []
    words = re.sub(r"\(.*?\)", "", text.split(";")[-1]).replace(" first", "").replace("from ", "")
    words = words.replace("wait for the handshake", "")
    return [step.split(" or ")[0].strip() for step in words.split(", then ") if step.strip()]


def carry_out(hand: Hand, commands: list[str]) -> None:
    for command in commands:
        if hand.sup.state is State.INIT:
            hand.tick()  # the handshake comes between
        reply = hand.ask(command)
        assert reply["ok"], (command, reply)
        hand.tick(3)
    if hand.sup.state is State.INIT:
        hand.tick()


def request_args(request: str, record_dir: Path) -> dict[str, Any]:
    if request == "mode":
        return {"finger": FINGER, "mode": "position"}
    if request == "target":
        return {"finger": FINGER, "angle_deg": TARGET_DEG}
    if request == "load_trajectory":
        path = record_dir / "step.csv"
        path.write_text(TRAJECTORY)
        return {"path": str(path)}
    if request == "record_start":
        return {"path": str(record_dir / f"rec-{time.monotonic_ns()}.csv")}
    return {}


@pytest.mark.parametrize("state", list(State), ids=lambda s: s.name)
@pytest.mark.parametrize("request_name", REQUESTS)
def test_each_request_does_what_it_answers_or_says_what_would(request_name: str, state: State,
                                                               tmp_path: Path) -> None:
    hand = in_state(state, tmp_path)
    expected = cell(request_name, state)
    if request_name == "record_stop":
        assert hand.ask("record_start", **request_args("record_start", tmp_path))["ok"]
    if request_name == "mode":  # what mode would follow: the target the finger holds
        hand.sup.set_target([hand.index], "angle_deg", TARGET_DEG)
        hand.sup.set_mode([hand.index], 0)
    reply = hand.ask(request_name, **request_args(request_name, tmp_path))
    if not expected.taken:
        assert not reply["ok"], reply
        assert state.name in reply["error"], reply["error"]
        assert expected.applies in reply["error"], (expected.applies, reply["error"])
        commands = commands_in(expected.applies)
        if commands or "handshake" in expected.applies:  # the commands it names make it work
            carry_out(hand, commands)
            assert hand.ask(request_name, **request_args(request_name, tmp_path))["ok"]
        return
    assert reply["ok"], reply
    if expected.state_after is not None:
        assert hand.sup.state is expected.state_after
        return
    if request_name not in ("mode", "target", "load_trajectory"):
        return
    assert reply["result"]["applies"] == expected.applies
    followed = hand.plays if request_name == "load_trajectory" else hand.follows_target
    hand.tick(3)
    if expected.applies == NOW:
        assert followed(), hand.sup.hand.inputs
        return
    assert not followed(), f"{request_name} in {state.name} acted before {expected.applies}"
    carry_out(hand, commands_in(expected.applies))
    hand.tick(3)
    assert hand.sup.state is State.RUNNING
    assert followed(), f"{request_name} in {state.name}: not followed {expected.applies}"


@pytest.mark.parametrize("state", [State.DISARMED, State.ARMED, State.RUNNING, State.HOLD],
                         ids=lambda s: s.name)
def test_a_finger_the_trajectory_drives_refuses_a_target_naming_the_command(state: State,
                                                                           tmp_path: Path) -> None:
    hand = in_state(State.DISARMED, tmp_path)
    assert hand.ask("load_trajectory", **request_args("load_trajectory", tmp_path))["ok"]
    carry_out(hand, {State.DISARMED: [], State.ARMED: ["arm"], State.RUNNING: ["arm", "start"],
                     State.HOLD: ["arm", "start", "hold"]}[state])
    reply = hand.ask("target", finger=FINGER, angle_deg=TARGET_DEG)
    assert not reply["ok"] and state.name in reply["error"] and "ctl clear-trajectory" in reply["error"]
    if state is State.RUNNING:
        assert "hold, then clear the trajectory" in reply["error"]
        carry_out(hand, ["hold"])
    assert hand.ask("clear_trajectory")["ok"]
    assert hand.ask("target", finger=FINGER, angle_deg=TARGET_DEG)["ok"]


def test_docs_api_shows_the_table() -> None:
    assert render() in (ROOT / "docs" / "api.md").read_text()


def test_the_table_covers_every_request_of_the_api(tmp_path: Path) -> None:
    assert set(REQUESTS) == set(Hand(tmp_path).api.table)
    assert np.all([cell(r, s).taken or cell(r, s).applies for r in REQUESTS for s in State])
