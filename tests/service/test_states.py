"""Every transition of the safety state machine, allowed and refused."""

from __future__ import annotations

import itertools

import pytest

from hand_service.service.states import (
    LATCHED,
    TRANSITIONS,
    VENTED,
    Event,
    State,
    StateMachine,
    TransitionError,
)

EXPECTED = {
    (State.INIT, Event.HANDSHAKE_OK): State.DISARMED,
    (State.INIT, Event.HANDSHAKE_FAILED): State.FAULT,
    (State.DISARMED, Event.ARM): State.ARMED,
    (State.ARMED, Event.START): State.RUNNING,
    (State.ARMED, Event.DISARM): State.DISARMED,
    (State.RUNNING, Event.HOLD): State.HOLD,
    (State.RUNNING, Event.DISARM): State.DISARMED,
    (State.HOLD, Event.RESUME): State.RUNNING,
    (State.HOLD, Event.DISARM): State.DISARMED,
    (State.FAULT, Event.RESET): State.INIT,
    (State.ESTOP, Event.RESET): State.INIT,
}


@pytest.mark.parametrize(("state", "event"), list(itertools.product(State, Event)))
def test_every_state_and_event(state: State, event: Event) -> None:
    machine = StateMachine()
    machine.state = state
    if event is Event.ESTOP:
        expected: State | None = State.ESTOP
    elif event is Event.FAULT:
        expected = None if state is State.ESTOP else State.FAULT  # ESTOP outranks a fault
    else:
        expected = EXPECTED.get((state, event))
    if expected is None:
        with pytest.raises(TransitionError, match=f"cannot {event.value} in {state.name}"):
            machine.fire(event)
        assert machine.state is state
    else:
        assert machine.fire(event) is expected
        assert machine.state is expected


def test_the_table_is_what_the_tests_expect() -> None:
    listed = {k: v for k, v in TRANSITIONS.items() if k[1] not in (Event.ESTOP, Event.FAULT)}
    assert listed == EXPECTED


def test_only_running_and_hold_may_pressurise() -> None:
    assert {s for s in State if s not in VENTED} == {State.RUNNING, State.HOLD}
    assert {State.FAULT, State.ESTOP} == LATCHED
