"""What each request does in each state of the supervisor: docs/api.md's table "What each
state accepts" is this one, rendered (tests/api/test_state_table.py walks it).

A request is either carried out now, taken now and followed from a later command (a
target in HOLD is followed from `resume`: HOLD freezes every reference), or refused with
the state and the commands that would make it work.
"""

from __future__ import annotations

from dataclasses import dataclass

from hand_service.service.states import TRANSITIONS, Event, State, commands_to, handshake_note, refusal

EVENTS = {event.value: event for event in (Event.ARM, Event.DISARM, Event.START, Event.HOLD,
                                           Event.RESUME, Event.ESTOP, Event.RESET)}
FOLLOWED = ("mode", "target", "load_trajectory")  # taken in any state, followed while RUNNING
ANY_STATE = ("status", "params", "faults", "record_start", "record_stop")
REQUESTS = (*EVENTS, *FOLLOWED, "clear_trajectory", *ANY_STATE)
NOW = "now"


@dataclass(frozen=True)
class Cell:
    """What a request does in one state: taken (now, or followed from `applies`) or refused."""

    taken: bool
    applies: str  # NOW, `from start` ..., or the refusal's reason after "cannot X in STATE: "
    state_after: State | None = None  # an event's new state


def followed_from(state: State) -> str:
    """When what a request set reaches the fingers: NOW while RUNNING, else after the commands
    that lead there (`from arm, then start`)."""
    run = commands_to(state, {State.RUNNING}) or []
    said = [event.value for event in run if event is not Event.HANDSHAKE_OK]
    if not run:
        return NOW
    text = "from " + ", then ".join(said) if said else "after the handshake"
    return f"{text} {handshake_note(run)}" if said and Event.HANDSHAKE_OK in run else text


def cell(request: str, state: State) -> Cell:
    if request in EVENTS:
        after = TRANSITIONS.get((state, EVENTS[request]))
        if after is None:
            return Cell(False, refusal(state, EVENTS[request]).split(": ", 1)[1])
        return Cell(True, NOW, after)
    if request == "load_trajectory" and state is State.RUNNING:
        return Cell(False, "hold or disarm first")
    if request in FOLLOWED:
        return Cell(True, followed_from(state))
    if request in REQUESTS:
        return Cell(True, NOW)
    raise KeyError(request)


def render() -> str:
    """The table as docs/api.md has it: one row per request, one column per state."""
    head = "| request | " + " | ".join(state.name for state in State) + " |"
    rows = [head, "|---" * (len(State) + 1) + "|"]
    for request in REQUESTS:
        cells = []
        for state in State:
            c = cell(request, state)
            if not c.taken:
                cells.append(f"refused: {c.applies}")
            elif c.state_after is not None:
                cells.append(f"→ {c.state_after.name}")
            else:
                cells.append(c.applies)
        rows.append(f"| `{request}` | " + " | ".join(cells) + " |")
    return "\n".join(rows)
