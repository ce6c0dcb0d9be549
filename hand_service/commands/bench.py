"""`hand-service bench`: latency figures, as JSON for the README and for CI trends."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

HELP = "measure the control step latency (C and Python reference)"
DESCRIPTION = """\
Measure one control step for the whole hand, called from Python through cffi, and the
same step in the pure-Python reference, call by call in the same run. Timing on shared
machines is noisy: compare the figures as ratios within one run.

JSON keys (formats.md): c_step_ns_p50, c_step_ns_p99, python_step_ns_p50, fingers, ...
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=Path, metavar="OUT", help="write the figures here")
    parser.add_argument("--quick", action="store_true", help="fewer calls: a rough figure in seconds")
    parser.add_argument("--profile", default=None, help="firmware profile (default: sim.yaml)")
    parser.add_argument("--io", action="store_true",
                        help="also time the bus transports against the mock firmware: command -> sensor "
                        "round trip and host SIGKILL -> vent, per transport (io_* keys; a minute or two)")


def main(args: argparse.Namespace) -> int:
    from hand_service.profile import load_profile
    from hand_service.stepbench import measure

    config = load_profile(args.profile).hand_config()
    c_calls, py_calls = (20_000, 1_000) if args.quick else (200_000, 5_000)
    print(f"control step, {config.n_fingers} fingers: {c_calls} C calls, {py_calls} Python calls ...",
          flush=True)
    results = measure(config, c_calls, py_calls).summary()
    print(f"  C step (through cffi)  p50 {results['c_step_ns_p50']:8.0f} ns   "
          f"p99 {results['c_step_ns_p99']:8.0f} ns")
    print(f"  Python reference step  p50 {results['python_step_ns_p50']:8.0f} ns   "
          f"p99 {results['python_step_ns_p99']:8.0f} ns")
    print(f"  Python / C             {results['python_over_c']:.0f}x   "
          f"(timer overhead {results['timer_overhead_ns']:.0f} ns, included)")
    if args.io:
        from hand_service.iobench import run_io_bench

        print("valve I/O against the mock firmware (virtual bus, SLCAN pty, serial pty):", flush=True)
        results.update(run_io_bench(quick=args.quick))
    if args.json:
        args.json.write_text(json.dumps(results, indent=2) + "\n")
        print(f"wrote {args.json}")
    return 0
