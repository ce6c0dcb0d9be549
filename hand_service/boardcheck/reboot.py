"""The reboot announcement: a board that restarts says so before anything else.

After a reset the board sends VersionInfo unasked, then Status with an uptime that
starts again near 0 and state idle (every valve vented), and its samples count again
from sequence 0 with command_sequence 0. To make a board reboot, the check asks the
debug port (FaultRequest kind 7, reboot), which only test images have; a board without
one is reset by hand (--reboot manual), or the check is not made (--reboot skip).
"""

from __future__ import annotations

import time

from hand_service.boardcheck.link import Received
from hand_service.boardcheck.results import CheckResult, failed, not_made, verdict
from hand_service.boardcheck.session import Session, samples, statuses, versions
from hand_service.wire.messages import FaultKind, FaultRequest, FirmwareState, Status

DEBUG_BOOT_MS = 200  # how long the debug reboot asks the board to stay silent
MANUAL_WAIT_S = 30.0
FRESH_STATUS_S = 0.25  # two and a half 10 Hz heartbeats


def _rebooted(before_ms: int, item: Received) -> bool:
    return isinstance(item.message, Status) and item.message.uptime_ms < before_ms


def reboot(session: Session, mode: str) -> CheckResult:
    cfg = session.settings
    name = "reboot-announce"
    if mode == "skip":
        return not_made(name, "skipped (--reboot skip): the announcement after a reset was not checked")
    session.pump(FRESH_STATUS_S)  # a fresh heartbeat: the uptime before the reset
    before = session.last_status
    if before is None:
        return failed(name, "no Status to compare the uptime after a reboot with")
    if mode == "debug":
        session.progress("asking the board's debug port to reboot (FaultRequest kind 7)")
        session.link.send(FaultRequest(FaultKind.REBOOT, value=DEBUG_BOOT_MS))
        wait_s = (DEBUG_BOOT_MS + cfg.handshake_timeout_ms) / 1e3
    else:
        session.tell(f"reset the board now (by its reset button or power); waiting {MANUAL_WAIT_S:g} s")
        wait_s = MANUAL_WAIT_S
    start = time.monotonic()
    got = session.pump(wait_s, until=lambda r: _rebooted(before.uptime_ms, r))
    got += session.pump(0.3)  # the samples after it
    after = [(t, s) for t, s in statuses(got) if s.uptime_ms < before.uptime_ms]
    if not after:
        if mode == "debug":
            return not_made(name, f"the board did not reboot within {wait_s * 1e3:.0f} ms of a debug reboot "
                            "request (no debug port?): reset it by hand with --reboot manual to check this")
        return failed(name, f"no Status with a lower uptime within {MANUAL_WAIT_S:g} s: was the board reset?")
    reset_t, first = after[0]
    announced = [t for t, _ in versions(got) if start <= t <= reset_t]
    later = [s for t, s in samples(got) if t >= reset_t]
    values = {"uptime_before_ms": before.uptime_ms, "uptime_after_ms": first.uptime_ms,
              "state_after": first.state.name.lower(), "announced": bool(announced),
              "first_sequence_after": later[0].sequence if later else None,
              "first_command_sequence_after": later[0].command_sequence if later else None,
              "silent_ms": 1e3 * (reset_t - start)}
    problems = []
    if not announced:
        problems.append("no VersionInfo before the first Status after the reboot (a board announces itself "
                        "when it boots)")
    if first.state != FirmwareState.IDLE:
        problems.append(f"state {first.state.name.lower()} after the reboot, not idle")
    if later and (later[0].sequence, later[0].command_sequence) != (0, 0):
        problems.append(f"the first sample after the reboot has sequence {later[0].sequence}, "
                        f"command_sequence {later[0].command_sequence}; both restart at 0")
    text = (f"uptime {before.uptime_ms} -> {first.uptime_ms} ms, VersionInfo first, state idle, samples "
            "from sequence 0")
    return verdict(name, not problems, "; ".join(problems) or text, **values)
