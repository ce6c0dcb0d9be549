"""The valve commands: echo, the vent on a zero command, what counts as valid, the watchdog.

A valid command is a whole, intact ValveCommand for the hand's finger count; only valid
commands are applied, echoed in command_sequence and feed the watchdog. Anything else
(a bad CRC, the wrong finger count, rubbish) is thrown away, and every thrown-away frame
counts once in Status.rx_errors.
"""

from __future__ import annotations

import math
import time

import numpy as np

from hand_service.boardcheck.link import Received
from hand_service.boardcheck.results import CheckResult, failed, not_made, verdict
from hand_service.boardcheck.session import Session, samples, statuses
from hand_service.transports.round_trip import WINDOW_S as ROUND_TRIP_WINDOW_S
from hand_service.transports.round_trip import RoundTrip
from hand_service.wire.messages import SEQUENCE_MODULO, FirmwareState, SensorReport, Status, ValveCommand

HOLD_S = 0.5  # how long each valve check commands
FAR_SEQUENCE = 128  # a bad frame's sequence: half the counter away from any good one
VENTED_FRACTION = 0.1  # vented: every chamber below this fraction of the setpoint...
VENTED_FLOOR_KPA = 2.0  # ...or this, whichever is more (sensor noise)
RISEN_FRACTION = 0.5  # the setpoint showed in the pressure: the vent can be seen
RX_ERRORS_MAX = 255  # rx_errors saturates
WARM_S = 0.3  # commanded before the bad frames: long enough for two 10 Hz heartbeats
FELL_FRACTION = 0.8  # the watchdog's vent seen in the chambers: every one below this of what it held


def _max_pressure_kpa(got: list[Received], last: int = 3) -> float:
    """The highest chamber pressure over the last few samples; NaN if the board does not measure it."""
    rows = samples(got)[-last:]
    values = [p for _, s in rows for p in s.pressure_meas_kpa]
    finite = [p for p in values if math.isfinite(p)]
    return max(finite) if finite else math.nan


def _stays_out_of_running(session: Session, states: list[FirmwareState], pressure_kpa: float) -> bool:
    """Whether the board stays out of `running` while valid commands keep coming. A board that
    left running for a moment (a late command on a loaded link or host lets its watchdog fire,
    as it should) and came back is not at fault; if the stretch ends out of running, command
    `pressure_kpa` for one more stretch and take the board's last word."""
    if not states or all(s == FirmwareState.RUNNING for s in states):
        return False
    if states[-1] == FirmwareState.RUNNING:
        return False
    more = [s.state for _, s in statuses(session.pump(HOLD_S, pressure_kpa))]
    return not more or more[-1] != FirmwareState.RUNNING


def _echoes(session: Session, got: list[Received], sent: set[int]) -> list[tuple[int, float]]:
    """For every command of this stretch (`sent`) that was echoed, in order: its sequence and
    when the first sample echoing it could have been read (this process's own lateness is
    not the board's), never before the command left."""
    first: dict[int, float] = {}
    for item in got:
        if isinstance(item.message, SensorReport):
            first.setdefault(item.message.command_sequence, item.board_t_s)
    return [(seq, max(t, session.sent_s[seq])) for seq, t in first.items() if seq in sent]


def _latency_ms(session: Session, echoes: list[tuple[int, float]], before: int) -> float | None:
    """The link's latency as the daemon judges it (transports/round_trip.py): the smallest
    echo time over a sliding window, at its largest over the stretch. One echo this busy
    host read late does not raise it; a board late with all of them does. None if the
    window never filled."""
    trip = RoundTrip()
    events = [(t, False, before + i) for i, t in enumerate(session.command_times_s[before:], start=1)]
    events += [(t, True, before + (seq - before) % SEQUENCE_MODULO) for seq, t in echoes]
    estimates = []
    for t, is_echo, unwrapped in sorted(events):
        if not is_echo:
            trip.sent(unwrapped, t)
        elif (estimate := trip.echoed(unwrapped, t)) is not None:
            estimates.append(1e3 * estimate)
    return max(estimates) if estimates else None


def echo(session: Session) -> tuple[CheckResult, float]:
    """Command the check's setpoint at the profile's rate; returns the result and the pressure reached."""
    cfg = session.settings
    name = "command-echo"
    session.progress(f"commanding {cfg.pressure_kpa:g} kPa for {HOLD_S:g} s")
    before = session.command_sequence
    held = [s.command_sequence for _, s in samples(session.log)[-1:]]  # what the board held till now
    if before == 0:  # no command yet: the board reports command_sequence 0 until the first
        held.append(0)
    got = session.pump(HOLD_S, cfg.pressure_kpa)
    rows = samples(got)
    sent = {(before + i) % SEQUENCE_MODULO for i in range(1, session.command_sequence - before + 1)}
    echoed = [s.command_sequence for _, s in rows]
    strangers = sorted({seq for seq in echoed if seq not in sent} - set(held))
    echoes = _echoes(session, got, sent)
    delays_ms = [1e3 * (t - session.sent_s[seq]) for seq, t in echoes]
    latency_ms = _latency_ms(session, echoes, before)
    judged_ms = latency_ms if latency_ms is not None else max(delays_ms, default=math.nan)
    limit_ms = 2e3 * cfg.period_s + cfg.latency_ms
    states = [s.state for _, s in statuses(got)]
    reached_kpa = _max_pressure_kpa(got)
    values = {"commands": len(sent), "echoed": len(set(echoed) & sent), "echo_limit_ms": limit_ms,
              "echo_p50_ms": float(np.percentile(delays_ms, 50)) if delays_ms else None,
              "echo_max_ms": max(delays_ms) if delays_ms else None, "latency_ms": latency_ms,
              "pressure_kpa": reached_kpa,
              "final_state": states[-1].name.lower() if states else None}
    if not rows:
        return failed(name, "no sample while commanding"), reached_kpa
    problems = []
    if not delays_ms:
        problems.append(f"no sample echoed any of {len(sent)} commands in command_sequence")
    elif judged_ms > limit_ms:
        problems.append(f"every command for {1e3 * ROUND_TRIP_WINDOW_S:.0f} ms took {judged_ms:.1f} ms or "
                        f"more to be echoed (limit {limit_ms:.0f} ms)" if latency_ms is not None else
                        f"a command took {judged_ms:.1f} ms to be echoed (limit {limit_ms:.0f} ms)")
    if strangers:
        problems.append(f"command_sequence {strangers[:5]} never sent")
    pause_ms = session.longest_pause_ms(before + 1)
    values["longest_host_pause_ms"] = pause_ms
    if not states:
        problems.append("no Status while commanded")
    elif (_stays_out_of_running(session, states[1:] or states, cfg.pressure_kpa)
          and pause_ms < cfg.watchdog_ms):
        problems.append(f"state {values['final_state']} while valid commands kept coming, not running")
    pressure = "not measured" if math.isnan(reached_kpa) else f"{reached_kpa:.1f} kPa"
    p50_ms = math.nan if values["echo_p50_ms"] is None else values["echo_p50_ms"]
    window = (f"the smallest over {1e3 * ROUND_TRIP_WINDOW_S:.0f} ms at most {judged_ms:.1f} ms"
              if latency_ms is not None else f"the {1e3 * ROUND_TRIP_WINDOW_S:.0f} ms window never filled")
    text = (f"{values['echoed']} of {len(sent)} commands echoed (a sample echoes the newest), "
            f"p50 {p50_ms:.1f} ms max {max(delays_ms, default=math.nan):.1f} ms, {window} "
            f"(limit {limit_ms:.0f} ms), state {values['final_state']}, chamber {pressure}")
    result = verdict(name, not problems, "; ".join([*problems, text]) if problems else text, **values)
    return result, reached_kpa


def _chambers_fell_ms(got: list[Received], since_s: float, held_kpa: float) -> float | None:
    """When, after since_s, every chamber began to fall: below FELL_FRACTION of what it held
    (ms after since_s, less this process's own lateness in reading it); None if they did
    not, or are not measured."""
    if not math.isfinite(held_kpa) or held_kpa <= VENTED_FLOOR_KPA:
        return None
    for item in got:
        if not isinstance(item.message, SensorReport):
            continue
        finite = [p for p in item.message.pressure_meas_kpa if math.isfinite(p)]
        if item.t_s > since_s and finite and max(finite) < FELL_FRACTION * held_kpa:
            return 1e3 * max(0.0, item.board_t_s - since_s)
    return None


def _vented_kpa(cfg_pressure_kpa: float) -> float:
    return max(VENTED_FLOOR_KPA, VENTED_FRACTION * cfg_pressure_kpa)


def zero_vent(session: Session, reached_kpa: float) -> CheckResult:
    """A command of 0 kPa on every finger is the vent: the chambers empty, the board stays running."""
    cfg = session.settings
    name = "zero-vent"
    session.progress(f"commanding 0 kPa for {HOLD_S:g} s")
    first = session.command_sequence + 1
    got = session.pump(HOLD_S, 0.0)
    states = [s.state for _, s in statuses(got)]
    left_kpa = _max_pressure_kpa(got)
    vented_kpa = _vented_kpa(cfg.pressure_kpa)
    values = {"pressure_before_kpa": reached_kpa, "pressure_after_kpa": left_kpa,
              "vented_below_kpa": vented_kpa,
              "states": sorted({s.name.lower() for s in states})}
    if math.isnan(left_kpa) or math.isnan(reached_kpa):
        return not_made(name, "the board does not measure chamber pressure: the vent cannot be seen",
                        **values)
    if reached_kpa < RISEN_FRACTION * cfg.pressure_kpa:
        return not_made(name, f"the chambers reached only {reached_kpa:.1f} kPa of {cfg.pressure_kpa:g} "
                        "(no supply?): a vent cannot be told from no pressure", **values)
    problems = []
    if left_kpa > vented_kpa:
        problems.append(f"chambers still at {left_kpa:.1f} kPa after {HOLD_S:g} s of 0 kPa commands")
    if _stays_out_of_running(session, states, 0.0) and session.longest_pause_ms(first) < cfg.watchdog_ms:
        problems.append("left the running state on a zero command and stayed out "
                        "(0 kPa is a valid setpoint, not a vent request)")
    text = (f"{reached_kpa:.1f} kPa -> {left_kpa:.1f} kPa (vented below {vented_kpa:.1f}) in {HOLD_S:g} s of "
            "0 kPa commands, state running")
    return verdict(name, not problems, "; ".join(problems) or text, **values)


def _rx_errors(rows: list[tuple[float, Status]]) -> int | None:
    return rows[-1][1].rx_errors if rows else None


def invalid_input(session: Session) -> CheckResult:
    """Bad CRC, wrong finger count and rubbish: not applied, counted, and the good frame behind them found."""
    cfg = session.settings
    name = "crc-and-garbage"
    session.progress("sending frames with a bad CRC, the wrong finger count, and rubbish")
    warm = session.pump(WARM_S, cfg.pressure_kpa)
    rx_before = _rx_errors(statuses(warm))
    far = (session.command_sequence + FAR_SEQUENCE) % SEQUENCE_MODULO
    bad = ValveCommand(far, [0.0] * cfg.n_fingers)
    follow = session.next_command(cfg.pressure_kpa)
    sent = session.link.send_invalid(bad, follow)
    # no other command for two sample periods: the one behind the rubbish must be echoed
    after = session.pump(min(2.5 * cfg.period_s, 0.5 * cfg.watchdog_ms / 1e3))
    after += session.pump(0.25, cfg.pressure_kpa)
    echoed = {s.command_sequence for _, s in samples(after)}
    rx_after = _rx_errors(statuses(after))
    values = {"bad_frames_sent": sent.bad_frames, "rubbish_sent": sent.rubbish_units,
              "rx_errors_before": rx_before, "rx_errors_after": rx_after,
              "bad_command_applied": far in echoed, "good_command_found": follow.sequence in echoed}
    if rx_before is None or rx_after is None:
        return failed(name, "no Status to read rx_errors from", **values)
    expected = min(RX_ERRORS_MAX, rx_before + sent.bad_frames)
    problems = []
    if far in echoed:
        problems.append(f"a command with a bad CRC or wrong finger count was applied (sequence {far} echoed)")
    if follow.sequence not in echoed:
        problems.append("the good command right behind the rubbish was lost (a receiver hunts for the next "
                        "sync one byte after a false one)" if "serial" in session.link.description else
                        "the good command right after the bad frames was lost")
    if rx_after != expected:
        problems.append(f"rx_errors went {rx_before} -> {rx_after}, expected {expected} "
                        f"({sent.bad_frames} bad frames; rubbish with no frame in it is not counted)")
    text = (f"{sent.bad_frames} bad frames not applied, rx_errors {rx_before} -> {rx_after}; "
            "the good command behind the rubbish applied")
    return verdict(name, not problems, "; ".join(problems) or text, **values)


def watchdog(session: Session) -> CheckResult:
    """Stop valid commands (keep sending invalid ones): the board vents within its watchdog time."""
    cfg = session.settings
    name = "watchdog"
    session.pump(HOLD_S, cfg.pressure_kpa)
    held_kpa = _max_pressure_kpa(session.log)
    last_valid_s = session.sent_s[session.command_sequence % SEQUENCE_MODULO]
    session.progress(f"stopped commanding; the board should vent within {cfg.watchdog_ms:g} ms")
    limit_ms = cfg.watchdog_ms + 1e3 * cfg.period_s + cfg.latency_ms
    give_up = time.monotonic() + (cfg.watchdog_ms + 1000.0) / 1e3
    far = (session.command_sequence + FAR_SEQUENCE) % SEQUENCE_MODULO
    vent: tuple[float, Status] | None = None
    vent_late_s = 0.0
    got: list[Received] = []
    while vent is None and time.monotonic() < give_up:
        session.link.send_invalid(ValveCommand(far, [cfg.pressure_kpa] * cfg.n_fingers))
        got += session.pump(cfg.period_s)
        first = next((r for r in got if isinstance(r.message, Status)
                      and r.message.state == FirmwareState.WATCHDOG_VENTED), None)
        if first is not None:
            assert isinstance(first.message, Status)
            vent, vent_late_s = (first.t_s, first.message), first.late_s
    got += session.pump(HOLD_S)
    after_kpa = _max_pressure_kpa([r for r in got if vent is not None and r.t_s > vent[0]])
    values = {"watchdog_ms": cfg.watchdog_ms, "limit_ms": limit_ms, "pressure_held_kpa": held_kpa,
              "pressure_after_kpa": after_kpa}
    if vent is None:
        states = sorted({s.state.name.lower() for _, s in statuses(got)})
        return failed(name, f"no watchdog_vented Status within {cfg.watchdog_ms + 1000:.0f} ms of the last "
                      f"valid command (watchdog {cfg.watchdog_ms:g} ms); state stayed "
                      f"{'/'.join(states) or 'silent'}", **values)
    own_ms = 1e3 * vent_late_s  # this process read the Status late by its own stalls: not the board's
    vent_ms = 1e3 * (vent[0] - last_valid_s) - own_ms
    values["vent_ms"], values["own_stall_ms"] = vent_ms, own_ms
    problems = []
    if not samples([r for r in got if r.t_s > vent[0]]):
        problems.append(f"no sample in the {HOLD_S:g} s after the vent (a vented board keeps reporting)")
    if vent_ms > limit_ms:
        fell_ms = _chambers_fell_ms(got, last_valid_s, held_kpa)
        values["chambers_fell_ms"] = fell_ms
        if fell_ms is not None and fell_ms <= limit_ms:
            problems.append(f"the chambers fell {fell_ms:.0f} ms after the last valid command (in time), "
                            f"but the watchdog_vented Status came only {vent_ms:.0f} ms after it (limit "
                            f"{limit_ms:.0f} ms): a board sends a Status at once on every change of state, "
                            "not with the next heartbeat")
        else:
            unseen = (" (the chambers' pressure is not measured: a Status sent late on the change reads the "
                      "same)" if fell_ms is None and math.isnan(held_kpa) else "")
            problems.append(f"vented {vent_ms:.0f} ms after the last valid command, limit {limit_ms:.0f} ms"
                            f"{unseen}")
    if vent_ms + own_ms < cfg.watchdog_ms - 1e3 * cfg.period_s:  # early: on the host's clock alone
        problems.append(f"vented after {vent_ms + own_ms:.0f} ms, before its watchdog time of "
                        f"{cfg.watchdog_ms:g} ms")
    vented_kpa = _vented_kpa(cfg.pressure_kpa)
    if math.isfinite(after_kpa) and after_kpa > vented_kpa:
        problems.append(f"chambers still at {after_kpa:.1f} kPa {HOLD_S:g} s after the vent")
    pressure = "" if math.isnan(after_kpa) else f", chambers {held_kpa:.1f} -> {after_kpa:.1f} kPa"
    text = (f"vented {vent_ms:.0f} ms after the last valid command (watchdog {cfg.watchdog_ms:g} ms, limit "
            f"{limit_ms:.0f} ms) while bad commands kept coming{pressure}")
    return verdict(name, not problems, "; ".join(problems) or text, **values)
