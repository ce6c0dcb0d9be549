"""`hand-service calibrate gain|sensor|valve|tare|span`: calibrations from measured data."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

HELP = ("calibrate the pressure gain N, the sensor map, the valve, or the estimate's tare or span from "
        "measured data")
GAIN_DOC = """\
gain SWEEP.csv --model MODEL.yaml [--finger NAME]
    N (pressure gain, N·m/kPa) from a slow pressure sweep at quasi-static equilibrium:
    N·p = k·θ (plus the model's static effects), fitted over the whole sweep with the
    fit quality (R², residual in deg). The chamber pressure is the measured one
    (pressure_meas_kpa) when the recording has it, else the command; a ṗ term absorbs
    the lag of the valve and finger, so sweep up and down. Needs k (run identify first).
"""
SENSOR_DOC = """\
sensor PAIRS.csv
    The flex sensor's linear map angle_deg = gain·mV + offset, per finger, from measured
    pairs (columns sensor_mv and angle_deg, optional finger), with R².
"""
VALVE_DOC = """\
valve STEPS.csv --model MODEL.yaml [--finger NAME] [--vent]
    The valve's first-order lag τ and dead time from the measured chamber pressure
    (pressure_meas_kpa) after command steps (pressure_kpa): the model's valve_lag and
    dead_time effects, which the feedforward compensates. The fit over every step is the
    one written back; the rising and the falling steps are also fitted alone (rows
    "rising", "falling"), since a pneumatic valve may fill and vent at different rates.
    With --vent the fit over every step takes the vent's lag apart from the fill's and
    writes it too (the valve_vent_lag effect).
"""
TARE_DOC = """\
tare HOLD.csv --model MODEL.yaml [--finger NAME] [--loop]
    The force estimate's tare: N set so that the estimate of a free finger (no contact)
    reads 0 N over the recording, a hold at the angle the finger will work at (measured
    chamber pressure, pressure_meas_kpa, needed). It pins N/k to the finger's own there,
    which an error in k and N apart breaks (docs/replicate.md, impedance). --loop takes
    the model's hysteresis loop into the estimate, as control.force_estimate_hysteresis does.
"""
SPAN_DOC = """\
span FREE.csv LOADED.csv --load-n L --model MODEL.yaml [--finger NAME] [--loop]
    The force estimate's span, after the tare: the lever arm r set so that a known load
    (L newtons hung on the pad, opening the finger) reads as itself. The recordings are the
    finger in impedance mode, at the stiffness it will render, sweeping its reference a few
    degrees about the working angle, free and with the load, each over whole sweeps (a
    recording that is not, to 0.05 of one, is refused; measured chamber pressure needed); the
    sweep, wider than the silicone's loop, averages its friction out. It takes out what the
    tare leaves: k's error as a scale and a contact point that moves with the bend
    (docs/replicate.md, impedance).
"""
OUTPUT_DOC = """
All print a table and write JSON with --json. --write-model OUT.yaml writes the model
with the new value(s); --update-profile PROFILE.yaml changes the values in the profile
in place, line by line, so its comments survive.
"""
DESCRIPTION = GAIN_DOC + SENSOR_DOC + VALVE_DOC + TARE_DOC + SPAN_DOC + OUTPUT_DOC + """
Examples:
  hand-service calibrate gain sweep.csv --model sim.yaml --finger index --update-profile my.yaml
  hand-service calibrate sensor pairs.csv --json sensor.json --update-profile my.yaml
"""


def _common(parser: argparse.ArgumentParser, model: bool) -> None:
    if model:
        parser.add_argument("--model", required=True, type=Path, metavar="MODEL.yaml",
                            help="finger model or firmware profile")
    parser.add_argument("--finger", help="finger name (a profile's block, a recording's columns)")
    parser.add_argument("--json", type=Path, metavar="OUT.json", help="write JSON ('-': stdout)")
    parser.add_argument("--write-model", type=Path, metavar="OUT.yaml", help="write the updated model here")
    parser.add_argument("--update-profile", type=Path, metavar="PROFILE.yaml",
                        help="change the values in this profile in place (comments kept)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="what", required=True, metavar="gain|sensor|valve|tare|span")

    def add(name: str, help_text: str, doc: str) -> argparse.ArgumentParser:
        return sub.add_parser(name, help=help_text, description=doc + OUTPUT_DOC,
                              formatter_class=argparse.RawDescriptionHelpFormatter)

    gain = add("gain", "N from a slow pressure sweep", GAIN_DOC)
    gain.add_argument("recording", type=Path, metavar="SWEEP.csv")
    _common(gain, model=True)
    gain.add_argument("--pressure", choices=["auto", "measured", "command"], default="auto",
                      help="which pressure: measured chamber pressure (auto: when present) or the command")
    gain.add_argument("--plot", type=Path, metavar="OUT.png", help="torque against pressure, residual")
    sensor = add("sensor", "the flex sensor's mV -> deg map from measured pairs", SENSOR_DOC)
    sensor.add_argument("recording", type=Path, metavar="PAIRS.csv")
    _common(sensor, model=False)
    valve = add("valve", "valve lag and dead time from pressure steps", VALVE_DOC)
    valve.add_argument("recording", type=Path, metavar="STEPS.csv")
    valve.add_argument("--vent", action="store_true", help="fit the vent's lag apart (valve_vent_lag)")
    _common(valve, model=True)
    tare = add("tare", "N that zeroes a free hold's force estimate", TARE_DOC)
    tare.add_argument("recording", type=Path, metavar="HOLD.csv")
    tare.add_argument("--loop", action="store_true", help="the model's hysteresis loop in the estimate")
    _common(tare, model=True)
    span = add("span", "the lever arm that makes a known load read as itself", SPAN_DOC)
    span.add_argument("free", type=Path, metavar="FREE.csv")
    span.add_argument("loaded", type=Path, metavar="LOADED.csv")
    span.add_argument("--load-n", type=float, required=True, help="the known load at the pad (N)")
    span.add_argument("--loop", action="store_true", help="the model's hysteresis loop in the estimate")
    _common(span, model=True)


def _finger_name(args: argparse.Namespace, model_finger: str | None, recording_finger: str | None) -> str:
    from hand_service.errors import UserError

    name = args.finger or model_finger or recording_finger
    if name is None:
        raise UserError("--update-profile needs to know the finger: give --finger")
    return name


def _write_back(args: argparse.Namespace, model: Any, changes: dict[str, Any], finger: str | None,
                header: str) -> None:
    from hand_service.config.model import save_model
    from hand_service.config.plausible import refuse_implausible
    from hand_service.config.profile import load_profile
    from hand_service.config.yamlupdate import update_values

    if args.write_model is not None:
        refuse_implausible(model.with_changes(**changes), args.write_model)
        save_model(model.with_changes(**changes), args.write_model, header=header)
        print(f"wrote {args.write_model}")
    if args.update_profile is not None:
        name = _finger_name(args, model.finger, finger)
        updates = []
        for key, value in changes.items():
            if key == "effects":  # only the effects that changed
                updates += [(("hand", name, "effects", effect, param), v)
                            for effect, params in value.items() if model.effects.get(effect) != params
                            for param, v in params.items()]
            else:
                updates.append((("hand", name, key), value))
        load_profile(args.update_profile).finger(name)  # the finger must exist
        update_values(args.update_profile, updates, load_profile)
        changed = ", ".join(".".join(u[0][2:]) for u in updates)
        print(f"updated {args.update_profile} (hand.{name}: {changed})")


def _gain(args: argparse.Namespace) -> dict[str, Any]:
    from hand_service.config.plausible import say_implausible
    from hand_service.config.profile import load_model
    from hand_service.identification.calibration import fit_pressure_gain
    from hand_service.recording import check_finger, read_recording

    model = load_model(args.model, args.finger)
    say_implausible(model)
    recording = read_recording(args.recording, args.finger)
    check_finger(recording, args.finger or model.finger)
    fit = fit_pressure_gain(recording, model, args.pressure)
    print(f"calibrate gain: {args.recording.name}, finger {model.finger or recording.finger or '?'}, "
          f"k = {fit.stiffness_nm_per_rad:.5g} N·m/rad from the model, pressure from {fit.pressure_column}\n")
    print("| N (N·m/kPa) | ± (1 s.e.) | R² | residual RMS (deg) | lag (s) | samples |")
    print("|---|---|---|---|---|---|")
    print(f"| {fit.pressure_gain_nm_per_kpa:.6g} | {fit.pressure_gain_se_nm_per_kpa:.2g} "
          f"| {fit.r_squared:.6f} | {fit.rmse_deg:.3f} | {fit.lag_s:.4f} | {fit.pressure_kpa.size} |")
    if model.pressure_gain_nm_per_kpa:
        change = fit.pressure_gain_nm_per_kpa / model.pressure_gain_nm_per_kpa - 1.0
        print(f"\nthe model had N = {model.pressure_gain_nm_per_kpa:.6g} ({100 * change:+.2f} %)")
    if fit.r_squared < 0.99:
        print(f"warning: R² = {fit.r_squared:.4f}: the angle is not linear in the pressure; a static "
              "effect (cubic stiffness, dead zone, gravity) may be missing: try `hand-service diagnose`")
    if args.plot is not None:
        from hand_service.identification.plots import gain_figure

        print(f"wrote {gain_figure(fit, args.plot)}")
    _write_back(args, model, {"pressure_gain_nm_per_kpa": fit.pressure_gain_nm_per_kpa}, recording.finger,
                f"N from `hand-service calibrate gain {args.recording.name}` "
                f"(R² {fit.r_squared:.6f}, k = {fit.stiffness_nm_per_rad:.5g})")
    return {"finger": model.finger or recording.finger, **fit.to_json()}


def _sensor(args: argparse.Namespace) -> dict[str, Any]:
    from hand_service.config.profile import load_profile
    from hand_service.config.yamlupdate import update_values
    from hand_service.errors import UserError
    from hand_service.identification.calibration import fit_sensor_map
    from hand_service.recording import read_recording

    if args.write_model is not None:
        raise UserError("the sensor map is not part of a model file (docs/formats.md): write it "
                        "into a profile with --update-profile")
    recording = read_recording(args.recording, None, required=("sensor_mv", "angle_deg"), min_duration_s=0.0)
    fits = fit_sensor_map(recording, args.finger)
    print(f"calibrate sensor: {args.recording.name}, angle_deg = gain·mV + offset\n")
    print("| finger | gain (deg/mV) | offset (deg) | R² | residual RMS (deg) | pairs |")
    print("|---|---|---|---|---|---|")
    for f in fits:
        print(f"| {f.finger} | {f.gain_deg_per_mv:.6g} | {f.offset_deg:.4f} | {f.r_squared:.6f} "
              f"| {f.rmse_deg:.3f} | {f.pairs} |")
    for f in fits:
        if f.r_squared < 0.99:
            print(f"warning: finger {f.finger}: R² = {f.r_squared:.4f}, the sensor is not linear "
                  "over this range")
    if args.update_profile is not None:
        profile = load_profile(args.update_profile)
        missing = [f.finger for f in fits if f.finger not in profile.finger_names]
        if missing:
            raise UserError(f"{args.update_profile}: no finger {', '.join(missing)} in hand "
                            f"({', '.join(profile.finger_names)}); name the fingers in a finger column")
        updates = [(("hand", f.finger, key), value) for f in fits
                   for key, value in (("sensor_gain_deg_per_mv", f.gain_deg_per_mv),
                                      ("sensor_offset_deg", f.offset_deg))]
        update_values(args.update_profile, updates, load_profile)
        print(f"updated {args.update_profile} (sensor_gain_deg_per_mv, sensor_offset_deg of "
              f"{', '.join(f.finger for f in fits)})")
    return {"fingers": {f.finger: f.to_json() for f in fits}}


def _valve(args: argparse.Namespace) -> dict[str, Any]:
    from hand_service.config.plausible import say_implausible
    from hand_service.config.profile import load_model
    from hand_service.identification.calibration import fit_valve, step_samples
    from hand_service.recording import check_finger, read_recording

    model = load_model(args.model, args.finger)
    say_implausible(model)
    recording = read_recording(args.recording, args.finger)
    check_finger(recording, args.finger or model.finger)
    fit = fit_valve(recording, vent=args.vent)
    directions = {steps: fit_valve(recording, steps) for steps in ("rising", "falling")
                  if step_samples(recording.pressure_kpa, steps).any()}
    print(f"calibrate valve: {args.recording.name}, first-order lag behind a dead time\n")
    print("| steps | valve_lag tau (s) | valve_vent_lag tau (s) | dead_time (s) | residual RMS (kPa) "
          "| samples |")
    print("|---|---|---|---|---|---|")
    for each in (fit, *directions.values()):
        vent = f"{each.vent_tau_s:.4f}" if each.vent_tau_s > 0.0 else "-"
        print(f"| {each.steps} | {each.tau_s:.4f} | {vent} | {each.delay_s:.4f} | {each.rmse_kpa:.3f} | "
              f"{each.samples} |")
    written = "valve_lag, valve_vent_lag and dead_time" if args.vent else "valve_lag and dead_time"
    _write_back(args, model, {"effects": {**model.effects, **fit.effects()}}, recording.finger,
                f"{written} from `hand-service calibrate valve {args.recording.name}`")
    return {"finger": model.finger or recording.finger, **fit.to_json(),
            **{steps: each.to_json() for steps, each in directions.items()}}


def _tare(args: argparse.Namespace) -> dict[str, Any]:
    from hand_service.config.profile import load_model
    from hand_service.errors import UserError
    from hand_service.identification.tare import tare_from_recording
    from hand_service.recording import check_finger, read_recording

    model = load_model(args.model, args.finger)
    recording = read_recording(args.recording, args.finger)
    check_finger(recording, args.finger or model.finger)
    finger = model.finger or recording.finger or "?"
    try:
        tare = tare_from_recording(recording, model, finger, with_loop=args.loop)
    except ValueError as error:
        raise UserError(str(error)) from error
    print(f"calibrate tare: {args.recording.name}, finger {finger}, {len(recording.angle_deg)} samples "
          f"about {float(recording.angle_deg.mean()):.2f}°\n")
    print("| estimate before (N) | p_eff (kPa) | N before (N·m/kPa) | N after (N·m/kPa) | change |")
    print("|---|---|---|---|---|")
    print(f"| {tare.estimate_n:+.4f} | {tare.effective_kpa:.2f} | {tare.gain_before_nm_per_kpa:.6g} "
          f"| {tare.gain_after_nm_per_kpa:.6g} | {tare.gain_change_pct:+.2f} % |")
    _write_back(args, model, {"pressure_gain_nm_per_kpa": tare.gain_after_nm_per_kpa}, recording.finger,
                f"N from `hand-service calibrate tare {args.recording.name}`")
    return {"finger": finger, "estimate_n": tare.estimate_n, "effective_kpa": tare.effective_kpa,
            "pressure_gain_before_nm_per_kpa": tare.gain_before_nm_per_kpa,
            "pressure_gain_nm_per_kpa": tare.gain_after_nm_per_kpa}


def _span(args: argparse.Namespace) -> dict[str, Any]:
    from hand_service.config.profile import load_model
    from hand_service.errors import UserError
    from hand_service.identification.span import span_from_recordings
    from hand_service.recording import check_finger, read_recording

    model = load_model(args.model, args.finger)
    free, loaded = read_recording(args.free, args.finger), read_recording(args.loaded, args.finger)
    for recording in (free, loaded):
        check_finger(recording, args.finger or model.finger)
    finger = model.finger or free.finger or "?"
    try:
        span = span_from_recordings(free, loaded, args.load_n, model, finger, with_loop=args.loop)
    except ValueError as error:
        raise UserError(str(error)) from error
    print(f"calibrate span: {args.free.name} and {args.loaded.name}, finger {finger}, {args.load_n:g} N\n")
    print("| estimate free (N) | estimate loaded (N) | read per N of load | r before (m) | r after (m) |")
    print("|---|---|---|---|---|")
    print(f"| {span.unloaded_n:+.4f} | {span.loaded_n:+.4f} | {span.scale:.4f} | {span.lever_before_m:.6g} "
          f"| {span.lever_after_m:.6g} |")
    _write_back(args, model, {"lever_arm_m": span.lever_after_m}, free.finger,
                f"r from `hand-service calibrate span {args.free.name} {args.loaded.name}`")
    return {"finger": finger, "estimate_free_n": span.unloaded_n, "estimate_loaded_n": span.loaded_n,
            "load_n": span.load_n, "scale": span.scale, "lever_arm_before_m": span.lever_before_m,
            "lever_arm_m": span.lever_after_m}


def main(args: argparse.Namespace) -> int:
    from hand_service.jsonio import tables_out, write_json

    with tables_out(args.json):
        calibrations = {"gain": _gain, "sensor": _sensor, "valve": _valve, "tare": _tare, "span": _span}
        result = calibrations[args.what](args)
    if args.json is not None:
        write_json(args.json, result)
    return 0
