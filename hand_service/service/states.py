"""The supervisor's safety state machine.

    INIT ──handshake ok──▶ DISARMED ──arm──▶ ARMED ──start──▶ RUNNING ◀──resume/hold──▶ HOLD
      │                      ▲   ◀─────────disarm─────────────┴───────────────────────┘
      └──handshake failed──▶ FAULT (latched, vented) ──reset──▶ INIT
    any state ──estop──▶ ESTOP (latched, vented) ──reset──▶ INIT
    any state but ESTOP ──fault──▶ FAULT

Only ARMED, RUNNING and HOLD may put pressure in a finger; every other state vents.
ARMED holds every finger at 0 kPa, ready; RUNNING follows the targets and the
trajectory; HOLD freezes every reference where it is (a pause).
"""

from __future__ import annotations

import enum

from rtcore.tick import REFS_HOLD, REFS_RUN, REFS_VENT


class State(enum.IntEnum):
    INIT = 0
    DISARMED = 1
    ARMED = 2
    RUNNING = 3
    HOLD = 4
    FAULT = 5
    ESTOP = 6


class Event(str, enum.Enum):
    HANDSHAKE_OK = "handshake_ok"
    HANDSHAKE_FAILED = "handshake_failed"
    ARM = "arm"
    DISARM = "disarm"
    START = "start"
    HOLD = "hold"
    RESUME = "resume"
    FAULT = "fault"
    ESTOP = "estop"
    RESET = "reset"


ACTIVE = frozenset({State.RUNNING, State.HOLD})  # the controller drives the fingers
VENTED = frozenset({State.INIT, State.DISARMED, State.ARMED, State.FAULT, State.ESTOP})
LATCHED = frozenset({State.FAULT, State.ESTOP})

TRANSITIONS: dict[tuple[State, Event], State] = {
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
    **{(s, Event.ESTOP): State.ESTOP for s in State},
    **{(s, Event.FAULT): State.FAULT for s in State if s is not State.ESTOP},
}

HINTS: dict[Event, str] = {
    Event.ARM: "arm only from DISARMED",
    Event.DISARM: "disarm from ARMED, RUNNING or HOLD",
    Event.START: "start only from ARMED (arm first)",
    Event.HOLD: "hold only while RUNNING",
    Event.RESUME: "resume only from HOLD",
    Event.RESET: "reset only from FAULT or ESTOP",
    Event.HANDSHAKE_OK: "the handshake happens in INIT",
    Event.HANDSHAKE_FAILED: "the handshake happens in INIT",
    Event.FAULT: "ESTOP outranks a fault",
    Event.ESTOP: "ESTOP is accepted everywhere",
}


class TransitionError(Exception):
    """An event the current state does not accept; the message says what would."""


class StateMachine:
    def __init__(self) -> None:
        self.state = State.INIT
        self.changes = 0

    def accepts(self, event: Event) -> bool:
        return (self.state, event) in TRANSITIONS

    def fire(self, event: Event) -> State:
        """Take the transition or raise TransitionError; returns the new state."""
        target = TRANSITIONS.get((self.state, event))
        if target is None:
            raise TransitionError(f"cannot {event.value} in {self.state.name}: {HINTS[event]}")
        if target is not self.state:
            self.changes += 1
        self.state = target
        return target

    @property
    def vented(self) -> bool:
        return self.state in VENTED


# the references each state feeds the control step, indexed by State
REFS = tuple(REFS_RUN if state is State.RUNNING else REFS_HOLD if state is State.HOLD else REFS_VENT
             for state in State)

__all__ = ["ACTIVE", "LATCHED", "REFS", "TRANSITIONS", "VENTED", "Event", "State", "StateMachine",
           "TransitionError"]
