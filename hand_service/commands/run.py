"""`hand-service run`: the supervisor daemon (docs/service.md, docs/api.md)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hand_service.config.rates import RATE_MAX_HZ, RATE_MIN_HZ

HELP = "run the supervisor daemon (default: the simulated hand of sim.yaml); --demo shows it off"
DESCRIPTION = """\
Run the supervisor: a control tick at the profile's rate (100 Hz by default, up to
1 kHz) on an absolute clock_nanosleep schedule, the safety state machine, the control
API on a Unix socket (0600, in a directory only you may write) and, with --record, one
CSV row per tick. Requests load and record only inside the data directory (--data-dir). With --tcp-port a
client must show the token the daemon writes beside its socket (ctl reads it).

The daemon starts in INIT, shakes hands with the firmware and waits DISARMED (vented)
for requests: `hand-service ctl arm`, `ctl target index --angle-deg 45`, `ctl start`...
It stops on SIGTERM or SIGINT (vents, flushes the recording, exits 0) or after
--duration. SIGUSR1 is an emergency stop that needs no socket: ESTOP (vented,
latched) from the next tick. With --demo it arms itself and runs the demo on the
simulated hand: the paper's 0 -> 90 deg sweep on every finger, then a pinch (thumb and
index close on objects in force mode), then prints the tracking and timing figures.

With --view it also starts `hand-service view` beside it, a process of its own (never in
the tick's process, never realtime), which prints the page's link with the token and
ends when the daemon stops. The page needs the daemon's token, which the daemon writes
when it serves TCP: --view serves the API on a free loopback port (--tcp-port 0) unless
--tcp-port says which. The plots need a recording (--record, or `ctl record-start`):

    hand-service run --view --record ~/.local/share/hand-service/recordings/run.csv
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--profile", default=None, help="firmware profile (default: sim.yaml)")
    parser.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    parser.add_argument("--record", type=Path, metavar="FILE.csv",
                        help="record every tick to this new CSV (docs/formats.md, per-finger columns)")
    parser.add_argument("--demo", action="store_true",
                        help="run the demo on the simulated hand, print figures, exit")
    parser.add_argument("--socket", type=Path, metavar="PATH",
                        help="control socket (default: $HAND_SERVICE_SOCKET, "
                             "$XDG_RUNTIME_DIR/hand-service/api.sock or /tmp/hand-service-UID/api.sock)")
    parser.add_argument("--no-socket", action="store_true", help="no control API")
    parser.add_argument("--tcp-port", type=int, metavar="PORT",
                        help="also serve the API on 127.0.0.1:PORT (loopback only; 0 picks one); a "
                             "client must show the token the daemon writes beside its socket "
                             "(api.token beside api.sock, mode 0600; docs/api.md)")
    parser.add_argument("--data-dir", "--record-dir", dest="data_dir", type=Path, metavar="DIR",
                        help="the data directory: the only one requests (ctl load, ctl record-start) "
                             "may read or record in, created 0700 if absent, shown at start and in "
                             "`ctl status` (default: the profile's recording.data_dir, else the "
                             "directory of --record, else $XDG_DATA_HOME/hand-service/recordings, by "
                             "default ~/.local/share/hand-service/recordings)")
    parser.add_argument("--rate", type=float, metavar="HZ",
                        help=f"control rate ({RATE_MIN_HZ:g} to {RATE_MAX_HZ:g} Hz, above twice the "
                             "filter cutoff; default: the profile's control.rate_hz)")
    parser.add_argument("--spin-us", type=float, default=0.0, metavar="US",
                        help="wake this early and spin to the deadline (CPU for jitter; default 0)")
    parser.add_argument("--recorder", choices=["process", "thread"], default="process",
                        help="where the CSV writer runs (default: process, off the daemon's GIL)")
    parser.add_argument("--record-sync-s", type=float, metavar="S",
                        help="also fdatasync the recording every S seconds, so that a power cut loses "
                             "at most S s (default: only on faults, signals and at the end; the "
                             "kernel writes back within about 30 s; on a VM a sync can stall the "
                             "tick: docs/service.md)")
    parser.add_argument("--realtime-priority", type=int, default=50, metavar="N",
                        help="SCHED_FIFO priority 1 to 99, used when permitted (default 50)")
    parser.add_argument("--no-realtime", action="store_true", help="stay with the normal scheduler")
    parser.add_argument("--no-mlock", action="store_true", help="do not lock memory (mlockall)")
    parser.add_argument("--port", metavar="DEVICE",
                        help="the serial device or CAN channel to use instead of the profile's "
                             "(e.g. /dev/ttyUSB1, can1)")
    parser.add_argument("--seed", type=int, help="simulator seed (sim transport; default: the profile's)")
    parser.add_argument("--status", choices=["auto", "line", "off"], default="auto",
                        help="live status line: auto shows it on a terminal (default)")
    parser.add_argument("--view", action="store_true",
                        help="also start the live view in a browser (docs/view.md), a process of its "
                             "own that prints its link and ends with the daemon; implies --tcp-port 0 "
                             "unless --tcp-port is given (the page needs the daemon's token)")
    parser.add_argument("--view-port", type=int, default=0, metavar="PORT",
                        help="with --view: serve the page on 127.0.0.1:PORT (default 0: a free port)")
    parser.add_argument("--foxglove", type=int, nargs="?", const=8765, metavar="PORT",
                        help="also serve the hand live to Foxglove (its WebSocket protocol) on "
                             "127.0.0.1:PORT (default 8765; 0: a free port, printed), a process of its "
                             "own reading the recording: the MCAP export's channels, every tick's row "
                             "(docs/view.md)")


def main(args: argparse.Namespace) -> int:
    from hand_service.app.daemon import Daemon, DaemonOptions, print_summary
    from hand_service.commands import checks
    from hand_service.config.at_rate import with_rate
    from hand_service.config.plausible import profile_warnings
    from hand_service.config.profile import load_profile
    from hand_service.errors import UserError
    from hand_service.transports import transport_class

    checks.positive(args.duration, "--duration")
    checks.positive(args.record_sync_s, "--record-sync-s")
    checks.tcp_port(args.tcp_port, allow_any=True)
    checks.tcp_port(args.view_port, "--view-port", allow_any=True)
    if args.view and (args.no_socket or args.demo):
        raise UserError("--view talks to the daemon's control socket: not with "
                        + ("--no-socket" if args.no_socket else "--demo (it prints its figures and exits)"))
    if args.foxglove is not None and (args.no_socket or args.demo):
        raise UserError("--foxglove asks the daemon for its recording over its control socket: not with "
                        + ("--no-socket" if args.no_socket else "--demo"))
    if args.foxglove is not None:
        checks.tcp_port(args.foxglove, "--foxglove", allow_any=True)
    if args.view_port and not args.view:
        raise UserError("--view-port is the page's port: it needs --view")
    if args.view and args.tcp_port is None:
        args.tcp_port = 0  # the daemon writes its token, which the page asks for
    checks.seed(args.seed)
    if not args.no_realtime and not 1 <= args.realtime_priority <= 99:
        raise UserError(f"--realtime-priority must be 1 to 99 (SCHED_FIFO), not {args.realtime_priority}")
    profile = with_rate(load_profile(args.profile), args.rate)  # checks the range and the filter
    for line in profile_warnings(profile):
        print(f"warning: {line}", file=sys.stderr)
    if not 0 <= args.spin_us * 1000 < 1e9 / profile.control.rate_hz:
        raise UserError("--spin-us must be at least 0 and shorter than the period")
    if args.record is not None and args.record.exists():
        raise UserError(f"{args.record}: exists already; a recording never overwrites one")
    kind = profile.transport["kind"]
    transport_options: dict[str, object] = {}
    if args.demo:
        if kind != "sim":
            raise UserError(f"--demo runs on the simulated hand (transport sim), not {kind}")
        from hand_service.app.demo import contacts
        transport_options["contacts"] = contacts(profile)
    if args.port is not None:
        if kind == "sim":
            raise UserError("--port needs a bus profile (transport can or serial), not sim")
        transport_options["port" if kind == "serial" else "channel"] = args.port
    if args.seed is not None:
        if kind != "sim":
            raise UserError("--seed applies to the sim transport only")
        transport_options["seed"] = args.seed
    transport = transport_class(kind)(profile, **transport_options)
    from hand_service.api.server import default_socket_path
    options = DaemonOptions(
        socket_path=None if args.no_socket else (args.socket or default_socket_path()),
        tcp_port=args.tcp_port, record=args.record, record_dir=args.data_dir, recorder=args.recorder,
        record_sync_s=args.record_sync_s, spin_us=args.spin_us,
        realtime_priority=None if args.no_realtime else args.realtime_priority,
        lock_memory=not (args.no_realtime or args.no_mlock),
        status_line=args.status == "line" or (args.status == "auto" and sys.stdout.isatty()),
        seed=args.seed)
    daemon = Daemon(profile, transport, options)
    if args.demo:
        from hand_service.app.demo import run_demo
        return run_demo(daemon, args.record, sys.stdout)
    daemon.open()
    from hand_service.view.beside import start_beside, start_view, stop_view

    beside = []
    assert options.socket_path is not None or not (args.view or args.foxglove is not None)
    sys.stdout.flush()
    try:
        if args.view:
            beside.append(start_view(options.socket_path, args.view_port))
        if args.foxglove is not None:
            beside.append(start_beside(["hand_service.view.foxglove", "--socket", str(options.socket_path),
                                        "--port", str(args.foxglove)]))
    except OSError as exc:
        for child in beside:
            stop_view(child)
        daemon.server.close()
        raise UserError(f"cannot start the view or the Foxglove server: {exc.strerror or exc}") from None
    try:
        summary = daemon.run(args.duration)
    finally:
        for child in beside:
            stop_view(child)
    print_summary(summary, sys.stdout)
    return 0
