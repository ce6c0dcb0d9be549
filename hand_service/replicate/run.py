"""`replicate`: the paper's Tables 1 and 2 and its force test, entirely in simulation.

The truth is a profile's hand (default sim.yaml: the paper's Table 1 with a 30 ms valve
lag and 5 ms dead time, 0.3° sensor noise). The controller knows only what the lab
measured on simulated recordings with the project's own calibrate and identify
(hand_service.identification.measured_hand). Then, in closed loop with the C control step:

- Table 1: k and B per finger by identify (and by the paper's two-peak recipe);
- Table 2: the cosine sweep 45·(1 − cos(2πt/0.75 s)) for 10 periods, the first left out,
  by PRBM+LDM feedforward + PID (the profile's gains, untuned) and by PID alone (tuned
  to its best, hand_service.replicate.tracking);
- force: the finger at 90° against an object, the pressure ramped until the true force
  reaches 2 N; the controller's estimate against the true force.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from hand_service.config.effects import effect_value
from hand_service.config.profile import Profile, load_profile
from hand_service.identification.measured_hand import controller_profile, measure_finger
from hand_service.replicate.force_test import CONTACT_ANGLE_DEG, run_force_test
from hand_service.replicate.result import PAPER_FORCE, PAPER_LDM, PAPER_POSITION, Options, Result
from hand_service.replicate.tracking import TUNED, pid_alone, track, tune_pid, with_gains
from hand_service.simulator import Contact, Simulator, hand_simulator


def _make_sim(truth: Profile, contacts: dict[str, Contact] | None = None) -> Callable[[int], Simulator]:
    return lambda seed: hand_simulator(truth, seed=seed, contacts=contacts)


def check_truth(truth: Profile) -> None:
    from hand_service.errors import UserError

    if truth.simulation["sensor_noise_deg"] < 0.3:
        raise UserError(f"{truth.path}: replicate needs sensor noise >= 0.3 deg "
                        f"(simulation.sensor_noise_deg is {truth.simulation['sensor_noise_deg']:g})")
    for f in truth.fingers:
        lag = effect_value(f.model.effects, "valve_lag")
        if lag < 0.03:
            raise UserError(f"{truth.path}: replicate needs a valve lag >= 30 ms in every finger "
                            f"(hand.{f.name}.effects.valve_lag.tau_s is {lag:g} s)")


def replicate(options: Options, progress: Callable[[str], None] | None = None) -> Result:
    say = progress or (lambda _: None)
    started = time.perf_counter()
    truth = load_profile(options.profile)
    check_truth(truth)
    seeds = [int(s) for s in np.random.SeedSequence([options.seed]).generate_state(len(truth.fingers) + 3)]
    with tempfile.TemporaryDirectory(prefix="replicate-") as scratch:
        workdir = options.trials_dir or Path(scratch)
        workdir.mkdir(parents=True, exist_ok=True)
        say(f"measuring the simulated hand ({options.trials_per_finger} releases a finger) into {workdir}")
        measured = [measure_finger(f, truth.simulation, workdir, options.trials_per_finger, seeds[i], say)
                    for i, f in enumerate(truth.fingers)]
    controller = controller_profile(truth, measured)
    config = controller.hand_config()
    make_sim = _make_sim(truth)
    evaluation_seed, force_seed, tuning_seed = seeds[-3:]  # tuning also uses tuning_seed + 1
    say(f"Table 2: FF+PID tracking the sweep for {options.periods} periods")
    ff_pid = track(config, make_sim, evaluation_seed, options.periods)
    say("Table 2: tuning PID alone to its best (grid, then compass searches)")
    tuning = tune_pid(config, make_sim, tuning_seed, options.periods, options.quick, say)
    pid = track(with_gains(pid_alone(config), tuning.gains), make_sim, evaluation_seed, options.periods)
    say(f"force test: object at {CONTACT_ANGLE_DEG:g} deg, pressure ramped to 2 N true force")
    contacts = {f.name: Contact(CONTACT_ANGLE_DEG) for f in truth.fingers}
    force = run_force_test(controller, _make_sim(truth, contacts), force_seed)
    runs = [dataclasses.replace(run, fingers=truth.finger_names) for run in (ff_pid, pid)]
    force = dataclasses.replace(force, fingers=truth.finger_names)
    return Result(options, truth, controller, measured, runs[0], runs[1], tuning, force,
                  time.perf_counter() - started)


__all__ = ["PAPER_FORCE", "PAPER_LDM", "PAPER_POSITION", "TUNED", "Options", "Result", "replicate"]
