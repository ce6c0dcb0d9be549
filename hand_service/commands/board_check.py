"""`hand-service board-check`: the conformance check a lab runs against any valve board."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "check that a valve board speaks serial-v1 or can-v1 as the host needs (one line per check)"
DESCRIPTION = """\
Check a valve board against the protocol it claims (docs/serial-protocol.md,
docs/can-protocol.md), as a host would talk to it, and print one line per check with what
was measured and PASS or FAIL (N/A: the check cannot be made on this board, with why):

  handshake        VersionRequest -> Status, then VersionInfo with the profile's protocol
                   and finger count, within the profile's handshake_timeout_ms
                   + --latency-ms
  version-refusal  a request for another protocol gets the board's own protocol back
  report-rate      samples at the profile's rate (±5 %) with no command; jitter; no gap
                   longer than the host's stale time (stale_sensor_ticks) + --latency-ms
  sequence         the sample sequence goes up by one per sample, never repeats; loss
                   within sample_loss_max_percent; serial-v1: the frame sequence too
  heartbeat        Status with every 10th sample (10 Hz at 100 Hz), uptime_ms keeping
                   the host's time, state not running with no command
  command-echo     commands echoed in command_sequence within 2 sample periods +
                   --latency-ms, judged as the host judges the link's latency: the
                   smallest echo time over any 0.25 s; state running while commands come
  zero-vent        0 kPa on every finger (the vent) empties the chambers; still running
  plant            vented, then --pressure-kpa on every finger for 1.2 s: where the
                   profile says pressure is measured, every chamber reported (no NaN) and
                   within the larger of 3 kPa and 25 % of the setpoint; every flex sensor
                   (the profile's calibration) moves by the finger model's static bend
                   (pressure_gain / stiffness x the step) within 0.67-1.5x, not under
                   0.25x (stuck); each failure names its finger. Needs the supply on
  crc-and-garbage  a bad CRC and a wrong finger count are not applied and count in
                   rx_errors; rubbish is not counted; a good frame right behind it is found
  watchdog         with only bad commands coming, the board vents (Status watchdog_vented)
                   within firmware_watchdog_ms + one sample period + --latency-ms
  reboot-announce  after a reset: VersionInfo unasked, uptime from 0, idle, sequence 0

The checks command --pressure-kpa (default 20) into every chamber: run it on a hand that
may inflate (with the supply off zero-vent is N/A and plant fails: no chamber moves).
The rates, times and finger count come from --profile (default: serial-v1.yaml, can-v1-slcan.yaml for slcan,
can-v1-virtual.yaml for virtual, can-v1.yaml for other CAN interfaces). Progress goes to
stderr: a bar on a terminal, a plain line at most every 2 s in a log, nothing with
--quiet. Exit status: 0 if no check failed, 1 if one did, 2 on bad input.

  hand-service board-check /dev/ttyACM0
  hand-service board-check --can slcan:/dev/ttyACM0 --json result.json
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from hand_service.boardcheck.modes import REBOOT_MODES

    parser.add_argument("port", nargs="?", default=None, help="the board's serial port (serial-v1)")
    parser.add_argument("--can", default=None, metavar="INTERFACE:CHANNEL",
                        help="a can-v1 board: slcan:PORT (an SLCAN adapter), virtual:CHANNEL (python-can's "
                        "in-process bus, for tests), socketcan:can0, ...")
    parser.add_argument("--profile", default=None, help="the board's profile: rate, watchdog, finger count")
    parser.add_argument("--seconds", type=float, default=2.0,
                        help="how long to listen to the stream with no command (default 2)")
    parser.add_argument("--pressure-kpa", type=float, default=20.0,
                        help="the setpoint the valve checks command on every finger (default 20)")
    parser.add_argument("--latency-ms", type=float, default=20.0,
                        help="what the link and this computer may add to any time the board keeps "
                        "(default 20)")
    parser.add_argument("--reboot", choices=REBOOT_MODES, default="debug",
                        help="how to reboot the board: its debug port (test images), by hand, or not at all")
    parser.add_argument("--only", default=None, metavar="CHECK,...",
                        help="run only these checks (and the handshake), e.g. --only watchdog,sequence")
    parser.add_argument("--json", type=Path, default=None, metavar="OUT.json",
                        help="also write the results as JSON ('-': stdout, instead of the lines)")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress on stderr (the results and an instruction to reset the board "
                        "by hand are still printed)")


def main(args: argparse.Namespace) -> int:
    import sys

    from hand_service.boardcheck.open import open_link, profile_for, settings_for
    from hand_service.boardcheck.results import CheckResult
    from hand_service.boardcheck.runner import parse_only, planned, run_checks
    from hand_service.commands import checks
    from hand_service.commands.progress import Progress
    from hand_service.jsonio import write_json

    checks.positive(args.seconds, "--seconds")
    only = parse_only(args.only)
    profile, _ = profile_for(args.port, args.can, args.profile)
    settings = settings_for(profile, args.seconds, args.pressure_kpa, args.latency_ms)
    lines = str(args.json) != "-"
    link = open_link(profile, args.port, args.can)

    def result(check: CheckResult) -> None:
        if lines:
            progress.write(check.line())  # stdout, below the bar
        progress.advance()

    try:
        with Progress("board-check", total=planned(only), quiet=args.quiet) as progress:
            report = run_checks(link, settings, args.reboot, progress=progress.say, on_result=result,
                                tell=lambda text: progress.write(f"board-check: {text}", file=sys.stderr),
                                only=only)
    finally:
        link.close()
    if lines:
        if report.stopped:
            print(f"FAIL  stopped          {report.stopped}")
        print(f"{'PASS' if report.passed else 'FAIL'}: {link.description}, profile {profile.name}")
    if args.json is not None:
        write_json(args.json, {"profile": profile.name, **report.as_dict()})
    return 0 if report.passed else 1
