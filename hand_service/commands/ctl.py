"""`hand-service ctl`: talk to a running daemon through its control API (docs/api.md)."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

HELP = "send a request to the running daemon (status, arm, target, load, ...)"
DESCRIPTION = """\
Send one request to a running `hand-service run` over its control socket and print the
reply. Examples:

    hand-service ctl status
    hand-service ctl arm
    hand-service ctl target index --angle-deg 45
    hand-service ctl target all --force-n 1.0
    hand-service ctl mode ring vent
    hand-service ctl mode index impedance --stiffness 0.1 --damping 0.0003
    hand-service ctl load ~/.local/share/hand-service/recordings/wave.csv && hand-service ctl start
    hand-service ctl record-start ~/.local/share/hand-service/recordings/run.csv
    hand-service ctl estop            # then: ctl reset
    hand-service ctl --tcp-port 7000 status   # reads the token beside the default socket

Every reply prints as `key: value` lines (status as a table); --json prints the reply's
result as one line of JSON instead, for scripts (docs/api.md lists every reply's keys).
A path must lie in the daemon's data directory (run --data-dir; `ctl status` shows it). `ctl estop`
is served even when the daemon has all the connections it takes. A refused request
prints the daemon's reason on one line and exits with status 2.
"""

SIMPLE = {
    "status": "state, fingers, timing, faults, recording, transport",
    "params": "the profile's rates, limits and gains",
    "faults": "every fault with its time and cause, and the counts",
    "arm": "DISARMED -> ARMED",
    "disarm": "ARMED, RUNNING or HOLD -> DISARMED (vents)",
    "start": "ARMED -> RUNNING: follow the targets and the trajectory",
    "hold": "RUNNING -> HOLD: freeze every reference",
    "resume": "HOLD -> RUNNING",
    "estop": "emergency stop: vent and latch, from any state",
    "reset": "FAULT or ESTOP -> INIT (shake hands again)",
    "clear-trajectory": "forget the loaded trajectory",
    "record-stop": "stop recording (drained and closed)",
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--socket", type=Path, metavar="PATH", help="the daemon's control socket")
    parser.add_argument("--tcp-port", type=int, metavar="PORT",
                        help="use 127.0.0.1:PORT (1 to 65535) instead; the token is read from the file "
                             "the daemon wrote beside its socket (--socket names the socket)")
    parser.add_argument("--token-file", type=Path, metavar="FILE",
                        help="with --tcp-port: the daemon's token file (default: <socket dir>/api.token "
                             "for socket api.sock)")
    parser.add_argument("--json", action="store_true",
                        help="print the reply's result as JSON on one line, for scripts (default: "
                             "`key: value` lines, and a table for status)")
    sub = parser.add_subparsers(dest="request", required=True, metavar="REQUEST")
    for name, doc in SIMPLE.items():
        sub.add_parser(name, help=doc, description=doc)
    mode = sub.add_parser("mode", help="set a finger's mode", description="set a finger's mode")
    mode.add_argument("finger", help="finger name, or all")
    mode.add_argument("mode", choices=["vent", "pressure", "position", "force", "impedance"])
    mode.add_argument("--stiffness", type=float, metavar="N_PER_DEG",
                      help="impedance: virtual stiffness, N of tip force per deg short of the target angle; "
                           "0 to the finger's stable limit (0.11 to 0.18 N/deg on sim.yaml; docs/api.md)")
    mode.add_argument("--damping", type=float, metavar="N_S_PER_DEG",
                      help="impedance: virtual damping, N per deg/s (default 0; at most about 0.001)")
    target = sub.add_parser("target", help="set a finger's target (its mode follows)",
                            description="set one target; the finger's mode follows it")
    target.add_argument("finger", help="finger name, or all")
    which = target.add_mutually_exclusive_group(required=True)
    which.add_argument("--angle-deg", type=float,
                       help="position mode, this angle (impedance mode: its reference, mode kept)")
    which.add_argument("--force-n", type=float, help="force mode, this signed normal force")
    which.add_argument("--pressure-kpa", type=float, help="pressure mode, this chamber pressure")
    load = sub.add_parser("load", help="load a trajectory CSV (docs/trajectory.md)",
                          description="load a trajectory CSV (docs/trajectory.md)")
    load.add_argument("path", type=Path)
    load.add_argument("--loop", action="store_true", help="start again at the end")
    record = sub.add_parser("record-start", help="record every tick to a new CSV",
                            description="record every tick to a new CSV")
    record.add_argument("path", type=Path)


def _request(args: argparse.Namespace) -> tuple[str, dict[str, Any]]:
    name = args.request
    if name == "mode":
        gains = {"stiffness_n_per_deg": args.stiffness, "damping_n_s_per_deg": args.damping}
        return "mode", {"finger": args.finger, "mode": args.mode,
                        **{k: v for k, v in gains.items() if v is not None}}
    if name == "target":
        for key in ("angle_deg", "force_n", "pressure_kpa"):
            if getattr(args, key) is not None:
                return "target", {"finger": args.finger, key: getattr(args, key)}
    if name == "load":
        return "load_trajectory", {"path": str(args.path.resolve()), "loop": args.loop}
    if name == "record-start":
        return "record_start", {"path": str(args.path.resolve())}
    return name.replace("-", "_"), {}


def _show_status(result: dict[str, Any]) -> str:
    lines = [f"{result['state']}  t = {result['t_s']:.2f} s  ({result['rate_hz']:g} Hz)"]
    lines.append(f"{'finger':<8} {'mode':<9} {'angle':>8} {'ref':>8} {'p cmd':>8} {'p meas':>8} {'F est':>7}")
    for name, f in result["fingers"].items():
        ref = f["angle_ref_deg"] if f["angle_ref_deg"] is not None else f["force_ref_n"]
        meas = f["pressure_meas_kpa"]
        lines.append(f"{name:<8} {f['mode']:<9} {f['angle_deg']:8.2f} "
                     f"{'-' if ref is None else format(ref, '8.2f'):>8} {f['pressure_cmd_kpa']:8.1f} "
                     f"{'-' if meas is None else format(meas, '8.1f'):>8} {f['force_est_n']:7.3f}")
    t = result["timing"]
    if t.get("ticks"):
        lines.append(f"tick p50 {t['tick_ns_p50'] / 1e3:.0f} us p99 {t['tick_ns_p99'] / 1e3:.0f} us | "
                     f"jitter p99 {t['jitter_us_p99']:.0f} us max {t['jitter_us_max']:.0f} us | "
                     f"misses {t['deadline_misses']}")
    faults = result["faults"]
    if faults["total"]:
        last = faults["last"]
        lines.append(f"faults {faults['total']}: last {last['cause']} at t = {last['t_s']} s: "
                     f"{last['detail']}")
    rec = result["recording"]
    if rec["active"]:
        lines.append(f"recording {rec['path']}: {rec['rows']} rows")
    if result.get("data_dir"):
        lines.append(f"data directory {result['data_dir']}")
    return "\n".join(lines)


def _text(value: Any) -> str:
    """One value as a person reads it: numbers short, nothing as '-', lists joined."""
    if value is None or value == {} or value == []:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list):
        return ", ".join(_text(v) for v in value)
    if isinstance(value, dict):  # a small mapping inside a list item
        return "{" + ", ".join(f"{k} {_text(v)}" for k, v in value.items()) + "}"
    return str(value)


def _lines(value: Any, indent: int = 0) -> list[str]:
    """`key: value` lines, a nested mapping indented under its key, a list of mappings one
    `- key value, ...` line per item."""
    pad = "  " * indent
    if not isinstance(value, dict):
        return [f"{pad}{_text(value)}"]
    lines = []
    for key, item in value.items():
        if isinstance(item, dict) and item:
            lines.append(f"{pad}{key}:")
            lines += _lines(item, indent + 1)
        elif isinstance(item, list) and item and all(isinstance(i, dict) for i in item):
            lines.append(f"{pad}{key}:")
            lines += [f"{pad}  - " + ", ".join(f"{k} {_text(v)}" for k, v in i.items()) for i in item]
        else:
            lines.append(f"{pad}{key}: {_text(item)}")
    return lines


def show(cmd: str, result: Any) -> str:
    """A reply as ctl prints it: `status` as a table, every other reply as `key: value`
    lines (the JSON's keys, units in their names)."""
    if cmd == "status":
        return _show_status(result)
    return "\n".join(_lines(result if result is not None else {"done": True}))


TARGET_FLAGS = {"angle_deg": "--angle-deg", "force_n": "--force-n", "pressure_kpa": "--pressure-kpa"}
GAIN_FLAGS = {"stiffness": "--stiffness", "damping": "--damping"}


def check(args: argparse.Namespace) -> None:
    """What the command line alone can refuse, in one line: a target that is not a finite
    number (`nan`, `inf`, `1e400`), an impedance gain that is not finite or is negative. The
    ranges are the daemon's profile's: the daemon refuses a target outside it (a negative
    force, say) or a gain above the finger's stable limit, and ctl prints that reason (exit 2)."""
    from hand_service.commands import checks
    from hand_service.errors import UserError

    checks.tcp_port(args.tcp_port)
    if args.token_file is not None and args.tcp_port is None:
        raise UserError("--token-file goes with --tcp-port (the Unix socket needs no token)")
    for key, flag in TARGET_FLAGS.items():
        value = getattr(args, key, None)
        if value is not None and not math.isfinite(value):
            raise UserError(f"{flag} must be a finite number, not {value:g}")
    for key, flag in GAIN_FLAGS.items():
        value = getattr(args, key, None)
        if value is not None and not (math.isfinite(value) and value >= 0.0):
            raise UserError(f"{flag} must be a finite number, 0 or more, not {value:g} "
                            "(its upper limit is the finger's: the daemon says it)")


def main(args: argparse.Namespace) -> int:
    from hand_service.api.client import ApiError, HandClient
    from hand_service.errors import UserError

    check(args)
    cmd, params = _request(args)
    try:
        with HandClient(args.socket, args.tcp_port, token_file=args.token_file) as client:
            result = client.request(cmd, **params)
    except (ConnectionError, OSError) as exc:
        raise UserError(str(exc)) from None
    except ApiError as exc:
        raise UserError(str(exc)) from None
    print(json.dumps(result) if args.json else show(cmd, result))
    return 0
