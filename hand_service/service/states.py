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

# what a client may send (the handshake and a fault come on their own)
COMMANDS = (Event.ARM, Event.DISARM, Event.START, Event.HOLD, Event.RESUME, Event.ESTOP, Event.RESET)


def accepting(event: Event) -> list[State]:
    """The states that take `event`, in the machine's order."""
    return [state for state in State if (state, event) in TRANSITIONS]


def commands_to(state: State, goal: frozenset[State] | set[State]) -> list[Event] | None:
    """The shortest run of a client's commands (the handshake taken as it comes) from
    `state` to one of `goal`: [] when it is there, None when no run leads there."""
    steps = (*[e for e in COMMANDS if e is not Event.ESTOP], Event.HANDSHAKE_OK)
    paths: dict[State, list[Event]] = {state: []}
    frontier = [state]
    while frontier:
        here = frontier.pop(0)
        if here in goal:
            return paths[here]
        for event in steps:
            there = TRANSITIONS.get((here, event))
            if there is not None and there not in paths:
                paths[there] = [*paths[here], event]
                frontier.append(there)
    return None


def how_to_reach(state: State, goal: frozenset[State] | set[State]) -> str:
    """What a client does in `state` to get to one of `goal`, in words: `arm first`,
    `reset, then arm first (the handshake comes between)`, `wait for the handshake`;
    '' when it is there or no command leads there."""
    run = commands_to(state, goal) or []
    said = [e.value for e in run if e is not Event.HANDSHAKE_OK]
    text = ", then ".join(said) + " first" if said else ""
    if Event.HANDSHAKE_OK in run:
        text = f"{text} {handshake_note(run)}" if said else "wait for the handshake"
    return text


def handshake_note(run: list[Event]) -> str:
    """Where the handshake falls in a run of commands."""
    return "(after the handshake)" if run[0] is Event.HANDSHAKE_OK else "(the handshake comes between)"


def refusal(state: State, event: Event) -> str:
    """Why `state` does not take `event`, and the commands that would make it."""
    takers = accepting(event)
    head = f"cannot {event.value} in {state.name}"
    if any(TRANSITIONS[(s, event)] is state for s in takers):
        return f"{head}: already {state.name}"
    where = " or ".join(s.name for s in takers)
    how = how_to_reach(state, set(takers))
    return f"{head}: {event.value} from {where}; {how}" if how else f"{head}: only {where} take it"


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
            raise TransitionError(refusal(self.state, event))
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

__all__ = ["ACTIVE", "COMMANDS", "LATCHED", "REFS", "TRANSITIONS", "VENTED", "Event", "State", "StateMachine",
           "TransitionError", "accepting", "commands_to", "handshake_note", "how_to_reach", "refusal"]
