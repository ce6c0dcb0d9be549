"""`hand-service view`: the running hand, live in a browser (docs/view.md)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "watch the running hand live in a browser: plots, state, faults, and an E-stop"
DESCRIPTION = """\
Serve a page on 127.0.0.1 (loopback only) that shows the running daemon live: per
finger the reference, measured and filtered angle (and the simulated hand's true
angle), the commanded and measured pressure
and the estimated force, scrolling, about 30 frames a second; the state, the faults and
the deadline misses; buttons for arm, start, hold, resume, disarm, reset, and an E-stop
that is always in view.

The view is a process apart from the daemon: it reads the daemon's recording ring
(shared memory, at the path the daemon's status gives) read-only, so the tick never
waits for it, and the signals are there
while the daemon records (`run --record FILE`, `ctl record-start`, or --record here).
State, faults and the buttons go through the daemon's control API.

The page asks for the daemon's API token: the daemon writes it beside its socket when
it runs with --tcp-port (api.sock -> api.token, mode 0600). The view prints a link that
carries it (after the #, which the browser never sends to a server). Examples:

    hand-service run --tcp-port 0 --record ~/.local/share/hand-service/recordings/run.csv &
    hand-service view                     # prints http://127.0.0.1:PORT/#token=...
    hand-service view --port 8017 --open  # a fixed port, and open the browser
    hand-service run --view --record FILE.csv   # the daemon and its view in one command
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--socket", type=Path, metavar="PATH",
                        help="the daemon's control socket (default: as `run`: $HAND_SERVICE_SOCKET, "
                             "$XDG_RUNTIME_DIR/hand-service/api.sock or /tmp/hand-service-UID/api.sock)")
    parser.add_argument("--tcp-port", type=int, metavar="PORT",
                        help="talk to the daemon on 127.0.0.1:PORT (its --tcp-port) with its token, "
                             "instead of its Unix socket")
    parser.add_argument("--token-file", type=Path, metavar="FILE",
                        help="the daemon's token file (default: beside the socket, api.sock -> api.token)")
    parser.add_argument("--port", type=int, default=0, metavar="PORT",
                        help="serve the page on 127.0.0.1:PORT (default 0: a free port, printed)")
    parser.add_argument("--record", type=Path, metavar="FILE.csv",
                        help="if the daemon is not recording, start a recording to this new file (in "
                             "its data directory) and stop it when the view ends")
    parser.add_argument("--open", action="store_true", help="open the page in the default browser")
    parser.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    parser.add_argument("--with-daemon", type=int, metavar="PID",
                        help="also stop when process PID ends (`run --view` starts the view so, "
                             "with the daemon's pid)")


def main(args: argparse.Namespace) -> int:
    from hand_service.commands import checks
    from hand_service.errors import UserError
    from hand_service.view.app import ViewOptions, serve
    from hand_service.view.beside import leave_realtime

    checks.tcp_port(args.tcp_port)
    checks.tcp_port(args.port, "--port", allow_any=True)
    checks.positive(args.duration, "--duration")
    if args.with_daemon is not None and args.with_daemon <= 0:
        raise UserError(f"--with-daemon must be a process id, not {args.with_daemon}")
    leave_realtime()  # started by run --view after the daemon took SCHED_FIFO
    if args.record is not None and args.record.exists():
        raise UserError(f"{args.record}: exists already; a recording never overwrites one")
    options = ViewOptions(socket_path=args.socket, tcp_port=args.tcp_port, token_file=args.token_file,
                          port=args.port, record=args.record, open_browser=args.open,
                          duration_s=args.duration, with_daemon=args.with_daemon)
    return serve(options, sys.stdout)
