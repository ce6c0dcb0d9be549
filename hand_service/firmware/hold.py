"""A minimal host for the HIL tests and benchmarks: hold a pressure through a transport.

    python -m hand_service.firmware.hold --profile P --option port=/tmp/x --pressure-kpa 40

opens the profile's transport, prints "holding" once the firmware answers, and then
answers every sensor sample with the same setpoints until it is killed. The tests
SIGKILL it to prove that the firmware's watchdog vents on its own.
"""

from __future__ import annotations

import argparse
import sys
import threading
import time

import numpy as np

from hand_service.transports.base import Transport

POLL_S = 0.001


def hold(transport: Transport, pressure_kpa: float, stop: threading.Event,
         seconds: float | None = None) -> int:
    """Answer every new sample with `pressure_kpa` on every finger; returns the samples seen."""
    command = np.full(transport.n_fingers, pressure_kpa)
    end = None if seconds is None else time.monotonic() + seconds
    samples = 0
    while not stop.is_set() and (end is None or time.monotonic() < end):
        if transport.latest() is not None:
            samples += 1
            transport.send(command)
        time.sleep(POLL_S)
    return samples


def main(argv: list[str] | None = None) -> int:
    from hand_service.config.profile import load_profile
    from hand_service.transports import transport_class

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--profile", required=True)
    parser.add_argument("--option", action="append", default=[], help="transport option KEY=VALUE")
    parser.add_argument("--pressure-kpa", type=float, default=40.0)
    args = parser.parse_args(argv)
    profile = load_profile(args.profile)
    options = dict(item.split("=", 1) for item in args.option)
    transport = transport_class(profile.transport["kind"])(profile, **options)
    transport.open()
    transport.send(np.full(transport.n_fingers, args.pressure_kpa))
    print("holding", flush=True)
    hold(transport, args.pressure_kpa, threading.Event())
    return 0


if __name__ == "__main__":
    sys.exit(main())
