"""`hand-service`: one command line for the service and the scientist's tools.

Each subcommand lives in hand_service/commands/<name>.py with HELP, add_arguments()
and main(). Their module-level imports stay light so that `--help` is instant.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import signal
import sys

from hand_service import __version__
from hand_service.errors import UserError

COMMANDS: dict[str, str] = {
    "run": "hand_service.commands.run",
    "bench": "hand_service.commands.bench",
    "ctl": "hand_service.commands.ctl",
    "identify": "hand_service.commands.identify",
    "calibrate": "hand_service.commands.calibrate",
    "replicate": "hand_service.commands.replicate",
    "trials": "hand_service.commands.trials",
    "mock-firmware": "hand_service.commands.mock_firmware",
    "diagnose": "hand_service.commands.diagnose",
    "simulate": "hand_service.commands.simulate",
    "board-check": "hand_service.commands.board_check",
    "view": "hand_service.commands.view",
    "export": "hand_service.commands.export",
}

DESCRIPTION = """\
Real-time control and model tools for pneumatic soft hands (PRBM + LDM).

Start with `hand-service run`: it drives the simulated five-finger hand of
firmware_profiles/sim.yaml, with no hardware. Every command has its own --help.
"""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="hand-service", description=DESCRIPTION,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"hand-service {__version__}")
    parser.add_argument("--log-level", default="info",
                        choices=["debug", "info", "warning", "error"],
                        help="how much to log to stderr (default: info)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(module_name)
        command = sub.add_parser(name, help=module.HELP, description=module.DESCRIPTION,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(command)
        command.set_defaults(handler=module.main)
    return parser


def _refused_by_rtcore(exc: BaseException) -> bool:
    """An rtcore.ConfigError, without importing rtcore here (it cannot be raised unless
    rtcore is loaded already)."""
    config = sys.modules.get("rtcore.config")
    return config is not None and isinstance(exc, config.ConfigError)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), stream=sys.stderr,
                        format="%(asctime)s %(levelname)-7s %(name)s: %(message)s")
    try:
        return int(args.handler(args) or 0)
    except UserError as exc:
        print(f"hand-service {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except ValueError as exc:
        if not _refused_by_rtcore(exc):
            raise
        # the last line of defence: the inputs should have been checked before the C core
        # saw them, with the file and line; still one line, not a traceback
        source = getattr(args, "profile", None) or getattr(args, "model", None)
        print(f"hand-service {args.command}: error: the control core refused the configuration"
              f"{f' of {source}' if source else ''}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"hand-service {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader of the output went away (`| head`): what it wanted, it has; the rest
        # goes nowhere, quietly (Python's own advice: stdout to devnull, so that the flush
        # at exit does not fail again), and the exit status is a shell's for SIGPIPE
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + signal.SIGPIPE


if __name__ == "__main__":
    sys.exit(main())
