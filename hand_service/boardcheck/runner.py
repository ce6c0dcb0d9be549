"""Run the checks in order against one board, each on what the ones before left behind.

Order: the handshake (nothing else can run without it), the refusal of another protocol,
the stream with no command (rate and jitter, sequence numbers, heartbeat), the command
echo, the vent on a zero command, the plant through the board (plant.py), bad frames and
rubbish, the watchdog, and last the reboot (it resets the board). The board is left
vented: the last valid command the check sends is 0 kPa on every finger, and the
watchdog vents it after that anyway.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from hand_service.boardcheck import handshake, plant, reboot, stream, valves
from hand_service.boardcheck.link import BoardLink
from hand_service.boardcheck.results import CheckResult
from hand_service.boardcheck.session import Session, Settings
from hand_service.errors import UserError

CHECKS = ("handshake", "version-refusal", "report-rate", "sequence", "heartbeat", "command-echo",
          "zero-vent", "plant", "crc-and-garbage", "watchdog", "reboot-announce")


@dataclass
class Report:
    link: str
    results: list[CheckResult] = field(default_factory=list)
    stopped: str = ""  # why the rest was not run

    @property
    def passed(self) -> bool:
        return not self.stopped and not any(r.failed for r in self.results)

    def as_dict(self) -> dict:
        return {"link": self.link, "passed": self.passed, "stopped": self.stopped or None,
                "checks": [r.as_dict() for r in self.results]}


def run_checks(link: BoardLink, settings: Settings, reboot_mode: str = "debug",
               progress: Callable[[str], None] = lambda text: None,
               on_result: Callable[[CheckResult], None] = lambda result: None,
               only: frozenset[str] | None = None,
               tell: Callable[[str], None] | None = None) -> Report:
    """Every check, or the handshake and those named in `only`. `progress` hears what is
    being done; `tell` (default: `progress`) what the user must do (reset the board)."""
    session = Session(link, settings, progress, tell=tell if tell is not None else progress)
    try:
        return _run(session, reboot_mode, on_result, only)
    finally:
        session.cpu.close()


def _run(session: Session, reboot_mode: str, on_result: Callable[[CheckResult], None],
         only: frozenset[str] | None) -> Report:
    link, progress = session.link, session.progress
    report = Report(link.description)
    wanted = frozenset(CHECKS) if only is None else only | {"handshake"}

    def add(result: CheckResult) -> CheckResult:
        report.results.append(result)
        on_result(result)
        return result

    progress(f"handshake on {link.description}")
    if add(handshake.handshake(session)).failed:
        report.stopped = "the handshake failed: no other check can run"
        return report
    if "version-refusal" in wanted:
        add(handshake.version_refusal(session))
    if wanted & {"report-rate", "sequence", "heartbeat"}:
        quiet = stream.listen(session)
        for check in (stream.rate, stream.sequence, stream.heartbeat):
            result = check(session, quiet)
            if result.name in wanted:
                add(result)
    if wanted & {"command-echo", "zero-vent"}:
        echo, reached_kpa = valves.echo(session)
        if "command-echo" in wanted:
            add(echo)
        if "zero-vent" in wanted:
            add(valves.zero_vent(session, reached_kpa))
    if "plant" in wanted:
        add(plant.plant(session))
    if "crc-and-garbage" in wanted:
        add(valves.invalid_input(session))
    if "watchdog" in wanted:
        add(valves.watchdog(session))
    if "reboot-announce" in wanted:
        add(reboot.reboot(session, reboot_mode))
    session.command(0.0)
    return report


def planned(only: frozenset[str] | None) -> int:
    """How many checks run_checks reports with this `only` (the handshake always)."""
    return len(CHECKS) if only is None else len(only | {"handshake"})


def parse_only(text: str | None) -> frozenset[str] | None:
    """`--only watchdog,sequence`: the checks to run besides the handshake."""
    if text is None:
        return None
    names = frozenset(part.strip() for part in text.split(",") if part.strip())
    unknown = sorted(names - set(CHECKS))
    if unknown or not names:
        raise UserError(f"--only: no check {', '.join(unknown) or repr(text)} (checks: {', '.join(CHECKS)})")
    return names
