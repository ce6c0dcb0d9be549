"""`hand-service diagnose RECORDING.csv --model MODEL.yaml`: name the physics a model leaves out."""

from __future__ import annotations

import argparse
import sys
from typing import Any

HELP = "find where a model and a recording disagree, and name the missing physics"
DESCRIPTION = """\
Compare a finger model with a recording (t, pressure_kpa, angle_deg; docs/formats.md), find
where and why they differ, and name the physics the model leaves out.

It simulates the model on the recorded command, refits k, B and N (A held) by
output-error least squares, tests the residual (whiteness, cross-correlation with the
command, time windows), then fits each library effect the model does not already
include (valve_lag, dead_time, coulomb_friction, cubic_stiffness, gravity,
asymmetric_stiffness, quadratic_damping, pressure_deadzone, and those an installed package
adds: docs/effects.md; contact, hysteresis and creep behind a screen, fitted where it sets
them apart from those eight; pressure_stiffening and valve_vent_lag only with --search)
jointly with k, B and N.
An effect is named only when the information criterion and held-out data both favour it
and no other effect explains the same residual as well. A quarter of the data, in
interleaved blocks, is held out from every fit.

Verdicts: consistent, parameters_only, missing_physics, unexplained,
insufficient_excitation. See docs/diagnose.md.

examples:
  hand-service diagnose run.csv --model firmware_profiles/sim.yaml --finger index \\
      --json diag.json --report diag.html --write-model index_fixed.yaml
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", help="recording CSV (docs/formats.md)")
    parser.add_argument("--model", required=True, help="model YAML, or a profile with --finger")
    parser.add_argument("--finger", default=None,
                        help="finger to pick from a profile or a multi-finger recording")
    parser.add_argument("--json", default=None, metavar="OUT.json",
                        help="write the result as JSON ('-': stdout, the summary then goes to stderr)")
    parser.add_argument("--report", default=None, metavar="OUT.html",
                        help="write a self-contained HTML report with plots and the evidence table")
    parser.add_argument("--write-model", default=None, metavar="OUT.yaml",
                        help="write the refitted model with the found effects in its effects block "
                             "(not written when the verdict is insufficient_excitation)")
    parser.add_argument("--input-hold", choices=("zoh", "point"), default="zoh",
                        help="how the recorded command acted between samples: zoh, held until the "
                             "next sample (the daemon's and a DAQ output's own record; default); "
                             "point, samples of a command that changed continuously, taken as "
                             "linear between them")
    parser.add_argument("--noise-model", choices=("white", "ar"), default="ar",
                        help="the sensor noise the tests assume: ar (default), correlated in time on "
                             "an offset that drifts, estimated from the recording (an analog sensor "
                             "chain's noise: a clean recording then comes out clean); white, "
                             "independent samples (see docs/diagnose.md)")
    parser.add_argument("--search", action="append", default=[], metavar="EFFECT",
                        help="search for a library effect by name: one diagnose leaves out by "
                             "default (pressure_stiffening, valve_vent_lag), or one it searches "
                             "behind its screen (contact, hysteresis, creep), then fitted "
                             "whatever the screen says, with its shape (a contact's onset, "
                             "exponent and damping, a loop's travel, creep's time; "
                             "docs/diagnose.md); repeatable")
    parser.add_argument("--jobs", type=_jobs, default=None, metavar="N",
                        help="threads the simulations run on (default: one per core, at most 4, or "
                             "HAND_DIAGNOSE_THREADS; 1: one thread); the same answer on any number")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress on stderr (else a bar on a terminal, a line every few "
                             "seconds elsewhere)")


def _jobs(text: str) -> int:
    if not text.strip().isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: a whole number of threads, 1 or more")
    return int(text)


def main(args: argparse.Namespace) -> int:
    import numpy as np

    from hand_service.commands.progress import Progress
    from hand_service.config.plausible import explained, warn_implausible
    from hand_service.config.profile import load_model
    from hand_service.diagnose.engine import diagnose
    from hand_service.diagnose.recording.timebase import regular_grid
    from hand_service.errors import UserError
    from hand_service.jsonio import tables_out, write_json
    from hand_service.outputs import check_writable
    from hand_service.recording import check_finger, read_recording

    for path in (args.json, args.report, args.write_model):
        if path is not None:
            check_writable(path)  # before minutes of fitting, not after
    recording = read_recording(args.recording, args.finger)
    try:
        model = load_model(args.model, args.finger or recording.finger)
    except UserError as refused:
        if args.finger is not None or recording.finger is None:
            raise
        # the recording's `# finger:` line chose the finger: a model file of another finger
        # is the recording's mismatch, said of the recording (check_finger), as identify does
        try:
            other = load_model(args.model)
        except UserError:
            raise refused from None
        check_finger(recording, other.finger)
        raise
    model.require_prbm(purpose="diagnose", force_point=False)  # a free finger: no force
    slips = warn_implausible(model)  # said once: in the refusal they explain, else as warnings
    grid = regular_grid(recording.t_s, recording.pressure_kpa, recording.angle_deg, args.recording)
    rate_hz = grid.rate_hz
    if grid.n_missing:
        print(f"{args.recording}: {grid.n_missing} skipped samples (t jumps): the command is held "
              "through them and they are left out of every fit", file=sys.stderr)
    if recording.duration_s * rate_hz < 100:
        raise UserError(f"{args.recording}: only {len(recording)} samples; diagnose needs at least 100")
    if np.ptp(recording.angle_deg) == 0.0:  # the refit's residual would be exactly zero
        raise UserError(f"{args.recording}: angle_deg is {recording.angle_deg[0]:g} deg throughout: nothing "
                        "moved, so there is nothing to compare with the model (is the sensor connected?)")
    with Progress("diagnose", quiet=args.quiet) as progress:
        try:
            result = diagnose(model, grid.t_s, grid.pressure_kpa, grid.angle_deg, rate_hz, progress,
                              grid.missing, args.input_hold, args.noise_model, also=args.search,
                              jobs=args.jobs)
        except UserError as refused:
            raise explained(refused, slips) from None
        progress.done()
    for line in slips:
        print(f"warning: {line}", file=sys.stderr)
    with tables_out(args.json):  # `--json -`: the JSON alone on stdout
        print_summary(result)
        _write_files(args, result)
    if args.json is not None:
        write_json(args.json, result.to_json())  # an unidentifiable parameter's std (inf) as null
        if args.json != "-":
            print(f"wrote {args.json}")
    return 0


def _write_files(args: argparse.Namespace, result: Any) -> None:
    from hand_service.config.model import save_model

    if args.report:
        from hand_service.diagnose.report.html import write_report

        write_report(result, args.report, str(args.recording))
        print(f"wrote {args.report}")
    if args.write_model:  # a unit slip first: it is why the rest cannot be trusted
        from hand_service.config.plausible import refuse_implausible

        refuse_implausible(result.refit_model(), args.write_model)
    if args.write_model and result.verdict == "insufficient_excitation":
        print(f"not writing {args.write_model}: this recording cannot separate the parameters, so the "
              "refit is not to be trusted (see the warnings)")
    elif args.write_model:
        from hand_service.version import software_version

        save_model(result.refit_model(), args.write_model,
                   header=f"refitted by hand-service diagnose {software_version()} from {args.recording}\n"
                          f"verdict: {result.verdict}")
        print(f"wrote {args.write_model}")


def print_summary(result, screen: bool = True) -> None:
    """The summary; with `screen`, a sentence that is not true of the recording is withheld
    (hand_service/diagnose/report/sentence_checks.py)."""
    from hand_service.diagnose.report.evidence import uncertainty
    from hand_service.diagnose.report.sentence_checks import facts_of, screened

    lines: list[str] = []
    out = lines.append
    j = result.to_json()
    out(f"verdict: {j['verdict']}")
    model = result.model
    out(f"{'parameter':<28} {'nominal':>11} {'refit':>11}  ±")
    for name in ("stiffness_nm_per_rad", "damping_nms_per_rad", "pressure_gain_nm_per_kpa"):
        std = uncertainty(j["refit_std"].get(name, float("nan")), value=j["refit"][name])
        out(f"{name:<28} {getattr(model, name):11.5g} {j['refit'][name]:11.5g}  {std:<16}".rstrip())
    for i, effect in enumerate(result.effects, start=1):
        out(f"{i}. {effect.name}: {effect.evidence}")
    rm, raw = j["rmse_deg"], j.get("raw_rmse_deg", {})
    out("RMS error (deg, a constant offset each, no drift): "
        + ", ".join(f"{name} raw {raw.get(name, float('nan')):.3f} held-out {rm[name]:.3f}"
                    for name in ("nominal", "refit", "augmented"))
        + f"; {result.noise_label} {result.noise_deg:.3f}")
    if j["windows"]:
        out("windows (s): " + ", ".join(f"{max(0.0, a):.2f} to {b:.2f}" for a, b in j["windows"]))
    for warning in j["warnings"]:
        out(f"warning: {warning}")
    out(f"(the fits took {result.seconds:.1f} s)")
    for line in screened(lines, facts_of(result)) if screen else lines:
        print(line)
