"""`hand-service mock-firmware`: the valve-board firmware in its own process, on a pty or a CAN bus."""

from __future__ import annotations

import argparse

HELP = "run the valve-board firmware (C core, simulated hand) on a pty or a CAN bus"
DESCRIPTION = """\
Run the valve-board firmware in this process: the C core of board/ (its test image,
compiled into hand_service.firmware._board) against a simulated hand (board/plant: the
shipped profiles' hand, its first N fingers). It sends sensor frames at the profile's
control rate on its own clock, regulates each chamber to the valve commands it receives,
vents every valve when no valid command comes within safety.firmware_watchdog_ms, reports
its status and version, and injects faults when the host asks through its debug port
(drop, delay, corrupt, stuck or out-of-range sensor, silence, reboot, ...; see
docs/firmware.md).

  serial profiles (serial-v1.yaml): speaks serial-v1 on a pseudo-terminal;
  can profiles with interface slcan (can-v1-slcan.yaml): plays an SLCAN adapter with
      the CAN firmware behind it on a pseudo-terminal;
  other can interfaces (socketcan, ...): joins that bus.

--port PATH: if PATH is an existing terminal, the firmware opens it; otherwise it creates
a pseudo-terminal and makes PATH a symlink to it, for the host to open (the profile's
port or channel by default). The line "ready: PATH" on stdout says it is listening.
python-can's virtual bus exists inside one process only: for can-v1-virtual.yaml run
the firmware in a thread (hand_service.firmware.board.run_in_thread) instead.
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--profile", required=True, help="a can or serial firmware profile")
    parser.add_argument("--port", default=None, help="pty path or channel (default: the profile's)")
    parser.add_argument("--protocol-version", type=int, default=None,
                        help="protocol version to report (default: the profile's; another tests refusal)")
    parser.add_argument("--firmware-version", default="1.0.0", help="firmware version to report (X.Y.Z)")
    parser.add_argument("--seed", type=int, default=None, help="sensor noise seed (default: the profile's)")
    parser.add_argument("--seconds", type=float, default=None, help="stop after this long (default: never)")
    parser.add_argument("--broken", default=None, metavar="RULE",
                        help="break one rule of the protocol on purpose, to see board-check catch it "
                             "(docs/firmware.md names them)")


def _version(text: str) -> tuple[int, int, int]:
    from hand_service.errors import UserError

    parts = text.split(".")
    if len(parts) != 3 or not all(p.isdigit() and int(p) < 256 for p in parts):
        raise UserError(f"--firmware-version must be X.Y.Z with numbers below 256, not {text!r}")
    return int(parts[0]), int(parts[1]), int(parts[2])


def main(args: argparse.Namespace) -> int:
    import signal

    from hand_service.commands import checks
    from hand_service.config.profile import load_profile
    from hand_service.errors import UserError
    from hand_service.firmware.board import BROKEN, BoardFirmware
    from hand_service.firmware.ports import open_port

    checks.seed(args.seed)
    checks.positive(args.seconds, "--seconds")
    profile = load_profile(args.profile)
    firmware_version = _version(args.firmware_version)
    if args.protocol_version is not None and not 1 <= args.protocol_version <= 65535:
        raise UserError("--protocol-version must be 1 to 65535")
    if args.broken is not None and args.broken not in BROKEN:
        raise UserError(f"--broken must be one of {', '.join(BROKEN)}, not {args.broken!r}")
    port = open_port(profile, args.port)
    try:
        firmware = BoardFirmware(profile, port, args.protocol_version, firmware_version, args.seed,
                                 args.broken)
    except ValueError as exc:
        port.close()
        raise UserError(str(exc)) from None
    signal.signal(signal.SIGTERM, lambda *_: firmware.stop_event.set())
    print(f"mock-firmware: profile {profile.name}, protocol {firmware.protocol_version}, firmware "
          f"{args.firmware_version}, {port.description}", flush=True)
    print(f"ready: {getattr(port, 'path', port.description)}", flush=True)
    try:
        firmware.run(args.seconds)
    finally:
        port.close()
    return 0
