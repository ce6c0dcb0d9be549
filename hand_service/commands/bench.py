"""`hand-service bench`: latency figures, as JSON for docs/results.md and for CI trends."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import TYPE_CHECKING

from hand_service.config.rates import RATE_MAX_HZ, RATE_MIN_HZ

if TYPE_CHECKING:
    from hand_service.config.profile import Profile

HELP = "measure the control step latency (C and Python reference)"
DESCRIPTION = """\
Measure one control step for the whole hand, called from Python through cffi, and the
same step in the pure-Python reference, call by call in the same run. Timing on shared
machines is noisy: compare the figures as ratios within one run.

Then the whole supervisor tick (read, step, safety, send, record) on the simulated
hand at --rate for --seconds, in one-second blocks interleaved with a bare C loop on the
same absolute clock_nanosleep schedule: the machine's own jitter floor, measured in the
same run. --spin-us wakes that much early and spins to the deadline (both loops).
On the simulated hand the sleep, the tick and its row are one C call
(csrc/rtcore_tick.c), so the tick ends in C; the time until Python runs again is timed
apart (tick_return_ns_*), and so is the hand's physics for the period after the tick,
which runs in the slack as a board's firmware runs beside the host (plant_ns_*).
A deadline miss is a tick that ends after its period; deadline_misses_woke_late counts
those that woke after their period had ended already, a stall no tick could make up
(every miss of the bare loop is of that kind).

Over can-v1 with the tick in C, the tick's four phases (decode the batch, control, encode
the command, follow check) are timed in the same call, and their p50, p99 and max are
given apart (tick_decode_ns_p50, ..., tick_follow_ns_max): where a slow tick spent its time.

JSON keys (docs/formats.md): c_step_ns_p50, c_step_ns_p99, python_step_ns_p50, fingers,
tick_ns_p50, tick_ns_p99, jitter_us_p50, jitter_us_p99, jitter_us_max, rate_hz,
jitter_floor_us_p50, jitter_floor_us_p99, jitter_floor_us_max, deadline_misses,
deadline_misses_floor, ticks, ...
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=Path, metavar="OUT",
                        help="write the figures here ('-': stdout, the tables then go to stderr)")
    parser.add_argument("--quick", action="store_true", help="fewer calls: a rough figure in seconds")
    parser.add_argument("--profile", default=None, help="firmware profile (default: sim.yaml)")
    parser.add_argument("--rate", type=float, default=None, metavar="HZ",
                        help=f"supervisor tick rate ({RATE_MIN_HZ:g} to {RATE_MAX_HZ:g} Hz, above twice "
                             "the filter cutoff; default: the profile's control.rate_hz, 100 in sim.yaml)")
    parser.add_argument("--seconds", type=float, default=None, metavar="S",
                        help="supervisor ticking time, the same again for the floor "
                             "(default 30; 4 with --quick)")
    parser.add_argument("--spin-us", type=float, default=0.0, metavar="US",
                        help="wake US early and spin to each deadline (default 0: sleep only)")
    parser.add_argument("--recorder", choices=["process", "thread", "off"], default="process",
                        help="record every tick through this writer (default process)")
    parser.add_argument("--record-sync-s", type=float, default=None, metavar="S",
                        help="the writer also fdatasyncs every S s, as `run --record-sync-s` (default: "
                             "as run's default, on faults, signals and at the end only)")
    parser.add_argument("--no-realtime", action="store_true", help="do not ask for SCHED_FIFO")
    parser.add_argument("--foxglove", type=int, nargs="?", const=8765, metavar="PORT",
                        help="also serve the recording to Foxglove on 127.0.0.1:PORT, as run --foxglove "
                             "(default 8765): connect a client to see what it costs the tick")
    parser.add_argument("--switch-interval-us", type=float, default=None, metavar="US",
                        help="GIL switch interval while ticking (default: the daemon's, 100 us; "
                             "CPython's own is 5000; see docs/service.md)")
    parser.add_argument("--machine", action="store_true",
                        help="only check the machine: the bare C loop on every CPU at once (at --rate, "
                        "default 1000 Hz, for --seconds), and each wake-up 1 ms late or more, "
                        "matched across CPUs: a stall on every CPU at once is the whole machine "
                        "stopping (machine_* keys; docs/service.md)")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress on stderr (default: a bar on a terminal, else a line every 2 s)")
    parser.add_argument("--tick-in-python", action="store_true",
                        help="can-v1 only: the tick in Python around latest() and send(), as before the "
                        "tick in C (rtcore_can_tick), to compare the two (tick_path in the figures)")
    parser.add_argument("--io", action="store_true",
                        help="also time the bus transports against the mock firmware: command -> sensor "
                        "round trip and host SIGKILL -> vent, per transport (io_* keys; a minute or two)")


def main(args: argparse.Namespace) -> int:
    from hand_service.bench.step import measure
    from hand_service.config.profile import load_profile
    from hand_service.jsonio import tables_out, write_json

    profile = load_profile(args.profile)
    rate_hz, seconds = _check(args, profile)
    if args.machine:
        return _machine(args, 1000.0 if args.rate is None else rate_hz, seconds)
    config = profile.hand_config()
    c_calls, py_calls = (20_000, 1_000) if args.quick else (200_000, 5_000)
    with tables_out(args.json):
        print(f"control step, {config.n_fingers} fingers: {c_calls} C calls, {py_calls} Python calls ...",
              flush=True)
        results = measure(config, c_calls, py_calls).summary()
        print(f"  C step (through cffi)  p50 {results['c_step_ns_p50']:8.0f} ns   "
              f"p99 {results['c_step_ns_p99']:8.0f} ns")
        print(f"  Python reference step  p50 {results['python_step_ns_p50']:8.0f} ns   "
              f"p99 {results['python_step_ns_p99']:8.0f} ns")
        print(f"  Python / C             {results['python_over_c']:.0f}x   "
              f"(timer overhead {results['timer_overhead_ns']:.0f} ns, included)")
        results.update(_ticks(args, profile, rate_hz, seconds))
        if args.io:
            from hand_service.bench.io import run_io_bench

            print("valve I/O against the mock firmware (virtual bus, SLCAN pty, serial pty):", flush=True)
            results.update(run_io_bench(quick=args.quick))
    if args.json:
        write_json(args.json, results)  # NaN (a ratio to a zero floor) is written as null
        if str(args.json) != "-":
            print(f"wrote {args.json}")
    return 0


def _check(args: argparse.Namespace, profile: Profile) -> tuple[float, float]:
    """Every argument checked before anything is measured; returns the rate (Hz) and the
    ticking time (s)."""
    from hand_service.commands import checks
    from hand_service.config.at_rate import with_rate
    from hand_service.errors import UserError
    from hand_service.firmware.rig import Rig
    from hand_service.outputs import check_writable

    rate_hz = with_rate(profile, args.rate).control.rate_hz  # range, filter cutoff, a bus firmware's rate
    if profile.transport["kind"] != "sim" and Rig.name_for(profile) is None:
        raise UserError(f"{profile.path}: bench runs a bus profile against a mock firmware it starts itself, "
                        f"and cannot mock one on the real bus {profile.transport['interface']}; use "
                        "can-v1-slcan.yaml or can-v1-virtual.yaml, or a serial profile")
    seconds = args.seconds if args.seconds is not None else (4.0 if args.quick else 30.0)
    if not (0 < seconds < math.inf and 0 <= args.spin_us * 1000 < 1e9 / rate_hz):
        raise UserError("--seconds must be positive and --spin-us between 0 and the period")
    if args.switch_interval_us is not None and not 1 <= args.switch_interval_us <= 1e6:
        raise UserError(f"--switch-interval-us must be 1 to 1000000, not {args.switch_interval_us:g}")
    checks.positive(args.record_sync_s, "--record-sync-s")
    if args.tick_in_python and profile.transport["kind"] != "can":
        raise UserError("--tick-in-python compares the two ticks of a can-v1 profile; this one is "
                        f"{profile.transport['kind']}")
    if args.foxglove is not None:
        checks.tcp_port(args.foxglove, "--foxglove", allow_any=True)
        if args.recorder == "off" or profile.transport["kind"] != "sim":
            raise UserError("--foxglove serves the recording of the simulated hand: not with --recorder off "
                            "or a bus profile")
    if args.record_sync_s is not None and args.recorder == "off":
        raise UserError("--record-sync-s needs a recording (not --recorder off)")
    if args.machine and (args.io or args.profile or args.spin_us or args.recorder != "process"
                         or args.switch_interval_us is not None or args.record_sync_s is not None):
        raise UserError("--machine checks the machine alone: it takes --seconds, --rate, --no-realtime "
                        "and --json only")
    if args.json:
        check_writable(args.json)
    return rate_hz, seconds


def _ticks(args: argparse.Namespace, profile: Profile, rate_hz: float, seconds: float) -> dict[str, object]:
    import tempfile

    from hand_service.bench.tick import measure_ticks
    from hand_service.errors import UserError
    from hand_service.firmware.rig import Rig, RigError

    print(f"supervisor tick at {rate_hz:g} Hz, {seconds:g} s, interleaved with the bare C loop "
          f"(spin {args.spin_us:g} us, recorder {args.recorder}) ...", flush=True)
    options = (args.spin_us, None if args.recorder == "off" else args.recorder,
               None if args.no_realtime else 50)
    extra: dict[str, float] = {"record_sync_s": args.record_sync_s} if args.record_sync_s else {}
    if args.switch_interval_us is not None:
        extra["switch_interval_s"] = args.switch_interval_us / 1e6
    if profile.transport["kind"] == "sim":
        r = measure_ticks(profile, rate_hz, seconds, *options, progress=not args.quiet,
                          foxglove_port=args.foxglove, **extra)
    else:  # the bus transport against a mock firmware on its own pty (or virtual channel)
        with tempfile.TemporaryDirectory(prefix="hand-service-bench-") as workdir, \
                Rig(str(Rig.name_for(profile)), Path(workdir), profile) as rig:
            try:
                rig.start_mock()  # rig.close() ends the mock process, however this ends
            except RigError as exc:
                raise UserError(f"the mock firmware for {profile.path} did not start: {exc}") from None
            transport = rig.transport(**({"tick_in_c": False} if args.tick_in_python else {}))
            print(f"  over {transport.link.description} to the mock firmware of profile {profile.name}",
                  flush=True)
            r = measure_ticks(profile, rate_hz, seconds, *options, progress=not args.quiet,
                              transport=transport, **extra)
        r["transport"] = profile.transport["kind"]
        r["tick_path"] = "c" if getattr(transport, "tick_state", None) is not None else "python"
    print(f"  tick                   p50 {r['tick_ns_p50']:8.0f} ns   p99 {r['tick_ns_p99']:8.0f} ns")
    if r.get("tick_decode_ns_p50") is not None:
        from rtcore.can import PHASES

        phases = "   ".join(f"{name} {r[f'tick_{name}_ns_p50'] / 1e3:.1f}/"
                               f"{r[f'tick_{name}_ns_p99'] / 1e3:.1f}" for name in PHASES)
        print(f"  tick phases p50/p99    {phases} us")
    if r.get("tick_return_ns_p50") is not None:
        print(f"  back in Python         p50 {r['tick_return_ns_p50']:8.0f} ns   p99 "
              f"{r['tick_return_ns_p99']:8.0f} ns   (after a tick that ended in C)")
    if r.get("plant_ns_p50") is not None:
        print(f"  simulated hand         p50 {r['plant_ns_p50']:8.0f} ns   p99 {r['plant_ns_p99']:8.0f} ns"
              "   (its physics, in the slack after the tick)")
    print(f"  jitter supervisor      p50 {r['jitter_us_p50']:8.1f} us   p99 {r['jitter_us_p99']:8.1f} us   "
          f"max {r['jitter_us_max']:8.1f} us   misses {r['deadline_misses']} "
          f"({r['deadline_misses_woke_late']} woke after their period)")
    print(f"  jitter bare C loop     p50 {r['jitter_floor_us_p50']:8.1f} us   p99 "
          f"{r['jitter_floor_us_p99']:8.1f} us   max {r['jitter_floor_us_max']:8.1f} us   "
          f"misses {r['deadline_misses_floor']}")
    print(f"  p99 jitter / floor     {r['jitter_ratio_p99']:.2f}   cpu {r['cpu_percent']:.1f} % "
          f"(floor {r['cpu_percent_floor']:.1f} %)   {r['realtime']}")
    if r["faults"]:
        print(f"  warning: {r['faults']} fault(s) during the run: the figures include ticks in FAULT")
    return r


def _machine(args: argparse.Namespace, rate_hz: float, seconds: float) -> int:
    from hand_service.bench.machine import match_stalls, probe, summary
    from hand_service.jsonio import tables_out, write_json

    with tables_out(args.json):
        print(f"the bare C loop on every CPU at once, {rate_hz:g} Hz, {seconds:g} s ...", flush=True)
        cpus, late, index, realtime = probe(seconds, rate_hz, None if args.no_realtime else 50)
        print(f"  CPUs {', '.join(map(str, cpus))} ({', '.join(sorted(set(realtime)))})")
        if len(cpus) == 1:
            print("  one CPU only: a stall on it cannot be told from the whole machine stopping")
        stalls = match_stalls(late, index, round(1e9 / rate_hz))
        r = summary(cpus, late, stalls, rate_hz, seconds, realtime)
        for cpu, p50, p99, top in zip(cpus, r["machine_jitter_us_p50"], r["machine_jitter_us_p99"],
                                      r["machine_jitter_us_max"], strict=True):
            print(f"  cpu {cpu}   jitter p50 {p50:8.1f} us   p99 {p99:8.1f} us   max {top:8.1f} us")
        print(f"  stalls of {r['machine_stall_ms']:g} ms or more: {len(stalls)}; on every CPU at once "
              f"(the machine stopped): {r['machine_stalls_every_cpu']}; on some CPUs only: "
              f"{r['machine_stalls_some_cpus']}")
        for stall in sorted(stalls, key=lambda s: -max(x or 0.0 for x in s.late_ms))[:10]:
            lates = "  ".join("-" if x is None else f"{x:.1f}" for x in stall.late_ms)
            print(f"    t {stall.t_s:8.3f} s   late (ms, per CPU): {lates}")
    if args.json:
        write_json(args.json, r)
        if str(args.json) != "-":
            print(f"wrote {args.json}")
    return 0
