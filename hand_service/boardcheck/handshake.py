"""The handshake (VersionRequest -> Status, VersionInfo) and the refusal of another protocol."""

from __future__ import annotations

import time

from hand_service.boardcheck.link import Received
from hand_service.boardcheck.results import CheckResult, failed, passed
from hand_service.boardcheck.session import Session, samples
from hand_service.wire.messages import Status, VersionInfo, VersionRequest

RETRY_S = 0.1  # the host's handshake retry (hand_service/transports/link.py)
CRC_HINT = {
    "serial": "CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) over bytes 2..4+L, sent little-endian",
    "can": "the AUTOSAR E2E profile-2 CRC-8 in byte 0, data id = the low byte of the frame id",
}


def _silence(session: Session, waited_ms: float) -> str:
    stats = session.link.stats()
    text = f"no VersionInfo within {waited_ms:.0f} ms"
    if stats.crc_errors:
        kind = "serial" if "serial" in session.link.description else "can"
        return (f"{text}: {stats.crc_errors} frame(s) came with a bad CRC and {stats.frames} intact "
                f"(check the CRC: {CRC_HINT[kind]})")
    if stats.decode_errors:
        return f"{text}: {stats.decode_errors} frame(s) could not be decoded (last: {stats.errors[-1]})"
    if stats.frames:
        return f"{text}, though {stats.frames} frame(s) arrived: the board does not answer VersionRequest"
    return f"{text} and no frame at all: is the board powered, on this port, at this rate?"


def handshake(session: Session) -> CheckResult:
    """Ask as the host does, every 100 ms, until VersionInfo comes or the profile's timeout
    (and --latency-ms: what the link may add) has passed."""
    cfg = session.settings
    name = "handshake"
    start = time.monotonic()
    deadline = start + cfg.answer_wait_ms / 1e3
    got: list[Received] = []
    info: tuple[float, VersionInfo] | None = None
    while info is None and time.monotonic() < deadline:
        session.link.send(VersionRequest(cfg.protocol_version))
        asked = time.monotonic()
        for item in session.pump(min(RETRY_S, deadline - asked),
                                 until=lambda r: isinstance(r.message, VersionInfo)):
            got.append(item)
            if isinstance(item.message, VersionInfo):
                info = (item.t_s - asked, item.message)
    if info is None:
        return failed(name, _silence(session, cfg.answer_wait_ms))
    answer_s, version = info
    # the answer's Status comes after the request it answers: a heartbeat from an earlier,
    # unanswered request's wait (a board still booting) is not it
    status_first = any(isinstance(r.message, Status) and r.t_s >= asked for r in got)
    values = {"answer_ms": answer_s * 1e3, "protocol_version": version.protocol_version,
              "firmware_version": version.firmware_text, "finger_count": version.finger_count,
              "status_before_version": status_first}
    if version.protocol_version != cfg.protocol_version:
        return failed(name, f"the board speaks protocol {version.protocol_version}; the profile needs "
                      f"{cfg.protocol_version}", **values)
    if version.finger_count != cfg.n_fingers:
        return failed(name, f"the board drives {version.finger_count} fingers; the profile has "
                      f"{cfg.n_fingers}", **values)
    if not status_first:
        # a Status late, or after the VersionInfo, is a wrong order, not a missing Status
        wait_s = (2e3 * cfg.period_s + cfg.latency_ms) / 1e3
        later = [r.t_s for r in session.pump(wait_s) if isinstance(r.message, Status)]
        values["status_after_version_ms"] = 1e3 * (later[0] - asked - answer_s) if later else None
        if later:
            return failed(name, f"the answer's Status came {values['status_after_version_ms']:.1f} ms after "
                          "its VersionInfo: the answer is Status, then VersionInfo, in that order", **values)
        return failed(name, f"VersionInfo came with no Status before it or within {wait_s * 1e3:.0f} ms "
                      "after"
                      " (the answer is Status, then VersionInfo)", **values)
    return passed(name, f"protocol {version.protocol_version}, firmware {version.firmware_text}, "
                  f"{version.finger_count} fingers; Status then VersionInfo, {answer_s * 1e3:.1f} ms "
                  "after the request", **values)


def _ask(session: Session, protocol_version: int) -> tuple[float, VersionInfo] | None:
    """Send one VersionRequest; the VersionInfo that answers it and how long it took (s)."""
    session.link.send(VersionRequest(protocol_version))
    asked = time.monotonic()
    got = session.pump(session.settings.answer_wait_ms / 1e3,
                       until=lambda r: isinstance(r.message, VersionInfo))
    answers = [(r.t_s - asked, r.message) for r in got if isinstance(r.message, VersionInfo)]
    return answers[0] if answers else None  # type: ignore[return-value]


def version_refusal(session: Session) -> CheckResult:
    """A request for another protocol gets the board's own: it never claims one it does not
    speak. Whether it then also ignores valve commands (the reference firmware does, the
    mock does not) is measured with a 0 kPa command and reported; a request for its own
    protocol must then be answered, and lifts any refusal, before the other checks go on."""
    cfg = session.settings
    name = "version-refusal"
    other = cfg.protocol_version + 1 if cfg.protocol_version < 0xFFFF else cfg.protocol_version - 1
    answer = _ask(session, other)
    if answer is None:
        return failed(name, f"no VersionInfo within {cfg.answer_wait_ms:.0f} ms of a VersionRequest "
                      f"for protocol {other}: a board answers every request with the protocol it speaks")
    answer_s, info = answer
    probe = session.command(0.0)
    wait_s = 3 * cfg.period_s + cfg.latency_ms / 1e3
    echoed = any(s.command_sequence == probe.sequence for _, s in samples(session.pump(wait_s)))
    session.pump(cfg.watchdog_ms / 1e3 + 2 * cfg.period_s)  # a board that took it vents again
    again = _ask(session, cfg.protocol_version)
    values = {"requested": other, "answered": info.protocol_version, "answer_ms": answer_s * 1e3,
              "commands_after_refusal": "applied" if echoed else "ignored",
              "own_protocol_answered": again is not None}
    after = "applied" if echoed else "ignored"
    if info.protocol_version != cfg.protocol_version:
        return failed(name, f"asked for protocol {other}, the board answered with protocol "
                      f"{info.protocol_version}, not its own ({cfg.protocol_version}): a board must not "
                      "claim a protocol it does not speak", **values)
    if again is None or again[1].protocol_version != cfg.protocol_version:
        return failed(name, f"after the refused request, no answer with protocol {cfg.protocol_version} "
                      f"to a request for it within {cfg.answer_wait_ms:.0f} ms", **values)
    return passed(name, f"asked for protocol {other}, the board answered with its own, "
                  f"{info.protocol_version}; it {after} the valve command that followed; asked for "
                  f"{cfg.protocol_version}, it answered", **values)
