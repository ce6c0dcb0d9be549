"""`hand-service simulate`: recordings of a simulated finger, with effects concealed in them."""

from __future__ import annotations

import argparse

HELP = "write a simulated recording, optionally with an effect concealed from the model"
DESCRIPTION = """\
Simulate one finger on a pressure excitation and write the recording (docs/formats.md), the
nominal model a lab would have (k, B, N off by up to --perturb) and the hidden truth.

With --effect NAME=VALUE the truth includes that effect at that value. With --effect NAME
alone, the effect is scaled until the refitted plain model (k, B, N; A held) leaves a
residual of --conceal times the sensor noise: concealed, so nobody can see it in a plot.
Hidden effects are left out of the nominal model even when the profile includes them;
the profile's other effects stay in both. This is how `diagnose` is proven.

excitations: steps (random staircase with vents), sweep (ramps, chirp 0.3-15 Hz,
inflate-and-vent swings), sine (one 1 Hz sine: too poor to separate parameters).

examples:
  hand-service simulate --effect coulomb_friction -o conceal.csv --nominal-model nominal.yaml
  hand-service simulate --effect gravity=0.05 --excitation sweep --noise 0.3 -o g.csv
  hand-service simulate -o clean.csv --nominal-model nominal.yaml     # nothing hidden
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-o", "--output", required=True, metavar="OUT.csv", help="recording to write")
    parser.add_argument("--profile", default=None, help="profile holding the finger (default: sim.yaml)")
    parser.add_argument("--finger", default="index", help="finger of the profile (default: index)")
    parser.add_argument("--model", default=None, help="a model file instead of a profile's finger")
    parser.add_argument("--effect", action="append", default=[], metavar="NAME[=VALUE]",
                        help="hidden effect (repeatable); without a value it is scaled to --conceal")
    parser.add_argument("--conceal", type=float, default=0.8, metavar="RATIO",
                        help="residual/noise the refitted plain model leaves (default 0.8); a negative "
                             "ratio deviates the other way from neutral (softening, negative gravity)")
    parser.add_argument("--excitation", default="steps", help="steps, sweep or sine (default steps)")
    parser.add_argument("--duration", type=float, default=30.0, help="seconds (default 30)")
    parser.add_argument("--rate", type=float, default=100.0, help="sample rate in Hz (default 100)")
    parser.add_argument("--noise", type=float, default=0.5, help="sensor noise in deg (default 0.5)")
    parser.add_argument("--adc-step-deg", type=float, default=0.122,
                        help="ADC quantisation in deg (default 0.122: 1.22 mV at 0.1 deg/mV)")
    parser.add_argument("--perturb", type=float, default=0.1,
                        help="k, B and N of the nominal model off by up to this fraction (default 0.1)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (excitation, noise, perturbation)")
    parser.add_argument("--nominal-model", default=None, metavar="OUT.yaml",
                        help="write the nominal model (perturbed, hidden effects left out)")
    parser.add_argument("--truth", default=None, metavar="OUT.json",
                        help="write the hidden truth as JSON ('-': stdout)")


def parse_effects(items: list[str]) -> dict[str, float | None]:
    from hand_service.config import effects as fx
    from hand_service.errors import UserError

    hidden: dict[str, float | None] = {}
    for item in items:
        name, _, value = item.partition("=")
        name = name.strip()
        if name not in fx.BY_NAME:
            raise UserError(f"--effect {item}: unknown effect '{name}' (known: {', '.join(fx.BY_NAME)})")
        if not value:
            hidden[name] = None
            continue
        try:
            number = float(value)
        except ValueError:
            raise UserError(f"--effect {item}: '{value}' is not a number") from None
        spec = fx.BY_NAME[name]
        if not spec.lower <= number <= spec.upper:
            raise UserError(f"--effect {item}: {spec.param} must be within {spec.lower:g} to {spec.upper:g} "
                            f"{spec.unit}")
        hidden[name] = number
    return hidden


# what a recording of a finger can be: an hour at most, a sensor no worse than ±45 deg
MAX_DURATION_S = 3600.0
MAX_NOISE_DEG = 45.0


def _check_numbers(args: argparse.Namespace) -> None:
    """Each number in its range, or one line naming the flag."""
    import math

    from hand_service.errors import UserError

    rules = (("--duration", args.duration, 1.0 <= args.duration <= MAX_DURATION_S,
              f"1 to {MAX_DURATION_S:g} s"),
             ("--rate", args.rate, 10.0 <= args.rate <= 10000.0, "10 to 10000 Hz"),
             ("--noise", args.noise, 0.0 < args.noise <= MAX_NOISE_DEG,
              f"above 0 and at most {MAX_NOISE_DEG:g} deg"),
             ("--perturb", args.perturb, 0.0 <= args.perturb < 1.0, "in [0, 1)"),
             ("--adc-step-deg", args.adc_step_deg, 0.0 <= args.adc_step_deg <= MAX_NOISE_DEG,
              f"0 to {MAX_NOISE_DEG:g} deg"),
             ("--conceal", args.conceal, args.conceal != 0.0 and abs(args.conceal) <= 1e3,
              "non-zero, at most 1000 in size"))
    for flag, value, ok, allowed in rules:
        if not (math.isfinite(value) and ok):
            raise UserError(f"{flag} must be {allowed}, not {value:g}")


def main(args: argparse.Namespace) -> int:

    import numpy as np

    from hand_service.commands import checks
    from hand_service.config.model import save_model
    from hand_service.config.profile import load_model, load_profile
    from hand_service.diagnose.concealed.generator import generate
    from hand_service.jsonio import tables_out, write_json
    from hand_service.outputs import check_writable
    from hand_service.recording import write_recording
    from hand_service.version import software_version

    if args.model:
        model = load_model(args.model, args.finger)
        source = args.model
    else:
        profile = load_profile(args.profile)
        model = profile.finger(args.finger).model
        source = str(profile.path)
    model.require_prbm(purpose="simulation", force_point=False)  # a free finger: no force
    _check_numbers(args)
    checks.seed(args.seed)
    for path in (args.output, args.nominal_model, args.truth):
        if path is not None:
            check_writable(path)  # before the simulation and its concealment search
    hidden = parse_effects(args.effect)
    c = generate(model, hidden, args.excitation, args.duration, args.rate, args.noise, args.adc_step_deg,
                 args.perturb, args.seed, args.conceal)
    metadata = {**c.metadata(), "model": source, "software_version": software_version()}
    with tables_out(args.truth):  # `--truth -`: the JSON alone on stdout
        write_recording(args.output, {"t": c.t_s, "pressure_kpa": c.pressure_kpa, "angle_deg": c.angle_deg,
                                      "angle_true_deg": c.angle_true_deg}, metadata)
        print(f"wrote {args.output}: {c.t_s.size} samples at {args.rate:g} Hz, excitation {args.excitation}, "
              f"noise {args.noise:g} deg")
        for name, params in c.hidden.items():
            print(f"hidden {name}: {params}; refitted plain model's residual = {c.concealment:.2f} x noise")
        if args.nominal_model:
            save_model(c.nominal, args.nominal_model,
                       header=f"nominal model from hand-service simulate (seed {args.seed}): k, B, N "
                              f"perturbed by up to {100 * args.perturb:g} %, hidden effects left out")
            print(f"wrote {args.nominal_model}")
    if args.truth:
        truth = {"hidden_effects": c.hidden, "concealment_residual_over_noise": c.concealment,
                 "truth": {k: v for k, v in c.truth.to_dict().items() if k != "effects"},
                 "truth_effects": c.truth.effects,
                 "nominal": {k: v for k, v in c.nominal.to_dict().items() if k != "effects"},
                 "noise_deg": args.noise, "seed": args.seed, "excitation": args.excitation,
                 "angle_rms_deg": float(np.sqrt(np.mean(c.angle_true_deg**2)))}
        write_json(args.truth, truth)
        if args.truth != "-":
            print(f"wrote {args.truth}")
    return 0
