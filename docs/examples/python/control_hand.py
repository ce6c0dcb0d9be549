"""Drive a running `hand-service run` from Python through the project's client class:
arm, set a target, start, record, read the status while the finger moves, stop.

    hand-service run &                                   # the simulated hand
    python docs/examples/python/control_hand.py          # the default socket
    python docs/examples/python/control_hand.py --tcp-port 7000   # TCP; the token is read for you

The recording goes to --record (default: run-example.csv in the daemon's recording
directory, ~/.local/share/hand-service/recordings; the path must lie there and not
exist). The same steps in MATLAB: docs/examples/matlab/control_hand.m.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from hand_service.api.client import ApiError, HandClient
from hand_service.errors import UserError


def default_record_path() -> Path:
    data = Path(os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share")
    return data / "hand-service" / "recordings" / "run-example.csv"


def wait_for_state(hand: HandClient, states: set[str], timeout_s: float) -> str:
    """Poll `status` until the state is one of `states` (the handshake takes a moment)."""
    end = time.monotonic() + timeout_s
    while True:
        state = hand.status()["state"]
        if state in states or time.monotonic() > end:
            return state
        time.sleep(0.1)


def run(hand: HandClient, finger: str, angle_deg: float, record: Path, seconds: float) -> int:
    state = wait_for_state(hand, {"DISARMED"}, timeout_s=20.0)
    if state != "DISARMED":
        print(f"the hand is {state}, not DISARMED: nothing done", file=sys.stderr)
        return 1
    print("arm:", hand.arm()["state"])
    try:
        print("target:", hand.target(finger, angle_deg=angle_deg))
        print("start:", hand.start()["state"])
        started = hand.record_start(record)
        print(f"recording to {started['path']}")
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            status = hand.status()
            f = status["fingers"][finger]
            print(f"t = {status['t_s']:6.2f} s  {status['state']:<8} {finger}: angle "
                  f"{f['angle_deg']:6.1f} deg (ref {f['angle_ref_deg']:.1f}), pressure "
                  f"{f['pressure_cmd_kpa']:5.1f} kPa, force {f['force_est_n']:+.3f} N")
            time.sleep(0.5)
        stopped = hand.record_stop()
        print(f"recorded {stopped['rows']} rows to {stopped['path']}")
    finally:  # whatever went wrong above (a refused request, Ctrl-C), vent every finger
        print("disarm:", hand.disarm()["state"])
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--socket", type=Path, help="the daemon's control socket (default: the daemon's)")
    parser.add_argument("--tcp-port", type=int, help="talk over 127.0.0.1:PORT with the token instead")
    parser.add_argument("--token-file", type=Path, help="with --tcp-port: the token file (default: "
                                                         "api.token beside the socket)")
    parser.add_argument("--finger", default="index", help="the finger to move (default: index)")
    parser.add_argument("--angle-deg", type=float, default=45.0, help="its target angle (default 45)")
    parser.add_argument("--record", type=Path, default=None, help="the recording to write (a new file "
                                                                   "in the daemon's recording directory)")
    parser.add_argument("--seconds", type=float, default=3.0, help="how long to run (default 3)")
    args = parser.parse_args(argv)
    record = (args.record or default_record_path()).resolve()
    try:
        with HandClient(args.socket, args.tcp_port, token_file=args.token_file) as hand:
            return run(hand, args.finger, args.angle_deg, record, args.seconds)
    except (ApiError, UserError, ConnectionError, OSError) as exc:  # refused, no token, no daemon
        print(f"control_hand: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
