"""Time to diagnose a 30 s, 100 Hz concealed recording (`make bench`; target <= 20 s), and
issue 20's and 44's speed points: the median and the largest time over independent 100 Hz
recordings (issue 44: <= 1 s and <= 3 s), each lab rate's time as a ratio of the 100 Hz
time measured in the same run, and a 5-minute recording at 500 Hz (issue 44: <= 10 s).
Never an absolute time asserted: the machine is shared; each prints its wall and CPU time
(all threads), the CPU time being what a busy machine does not inflate."""

from __future__ import annotations

import os

import pytest

from hand_service.config.profile import load_profile
from hand_service.diagnose.concealed.generator import generate
from hand_service.diagnose.engine import diagnose


@pytest.mark.slow
@pytest.mark.parametrize("effect", ["coulomb_friction", "gravity"])
def test_diagnose_30_s_at_100_hz(benchmark, effect: str) -> None:
    model = load_profile(None).finger("index").model
    c = generate(model, {effect: None}, "steps", noise_deg=0.5, seed=1, conceal_ratio=0.8)
    result = benchmark.pedantic(diagnose, args=(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, 100.0),
                                rounds=3, iterations=1)
    assert result.effects[0].name == effect


def _blas_threads() -> str:
    """How many threads BLAS may use here: past about 10 000 samples (500 Hz and up, 30 s)
    the residual statistics' dot products are threaded, and on 2 busy cores BLAS threads
    that compete with diagnose's own cost several times the time (docs/diagnose.md)."""
    return os.environ.get("OPENBLAS_NUM_THREADS", "unset (one per core)")


RATE_SECONDS: dict[float, float] = {}  # this run's time at each rate, for the ratios


@pytest.mark.slow
@pytest.mark.parametrize("rate_hz", [100.0, 0.25, 500.0, 1000.0])  # 100 Hz first: the others' reference
def test_diagnose_30_s_at_each_rate(benchmark, rate_hz: float) -> None:
    """The same recording at a lab's other rates (issue 20's target: within 3 × the 100 Hz
    time): 30 s, except at 0.25 Hz, where 30 s is 8 samples and diagnose asks for 100, so
    480 s (120 samples). The simulator's steps follow the dynamics, not the rate: a settled
    finger takes long steps, a plain one is exact at any step. Each time is printed as a
    ratio of this run's 100 Hz time."""
    model = load_profile(None).finger("index").model
    c = generate(model, {"gravity": None}, "steps", duration_s=480.0 if rate_hz < 1.0 else 30.0,
                 rate_hz=rate_hz, noise_deg=0.5, seed=1, conceal_ratio=0.8)
    result = benchmark.pedantic(diagnose, args=(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, rate_hz),
                                rounds=1, iterations=1)
    benchmark.extra_info["verdict"] = result.verdict
    benchmark.extra_info["blas_threads"] = _blas_threads()
    RATE_SECONDS[rate_hz] = result.seconds
    if rate_hz != 100.0 and 100.0 in RATE_SECONDS:
        ratio = result.seconds / RATE_SECONDS[100.0]
        benchmark.extra_info["ratio_to_100_hz"] = ratio
        print(f"\ndiagnose at {rate_hz:g} Hz: {result.seconds:.2f} s, {ratio:.2f} x the 100 Hz time "
              f"({RATE_SECONDS[100.0]:.2f} s; BLAS threads: {_blas_threads()})")
    if rate_hz >= 1.0:  # at 0.25 Hz every sample is the settled, static finger: a timing case
        assert result.effects[0].name == "gravity"


def _independent(effect: str, excitation: str, family: str, rate_hz: float, tmp_path,
                 magnitude: str = "evident"):
    """One recording of the independent truth generator (tests/diagnose/truth), read back
    through the recording reader as a lab's file would be."""
    from hand_service.config.profile import load_model
    from hand_service.diagnose.recording.timebase import regular_grid
    from hand_service.recording import read_recording
    from tests.diagnose.truth import cases as cs

    spec = cs.CaseSpec(effect, excitation, 0, magnitude if effect != cs.CLEAN else "none", family, rate_hz)
    rec_path, model_path = cs.write(cs.build(spec), tmp_path)
    rec = read_recording(rec_path, None)
    grid = regular_grid(rec.t_s, rec.pressure_kpa, rec.angle_deg, rec_path)
    return load_model(model_path, None), grid


@pytest.mark.slow
def test_diagnose_an_over_damped_actuator(benchmark, tmp_path) -> None:
    """A soft actuator with no resonance (B/A in the thousands per second), 30 s at 100 Hz,
    with an evident stiffening spring: the exact integrator keeps it as fast as a finger."""
    model, grid = _independent("cubic_stiffness", "steps", "overdamped", 100.0, tmp_path)
    args = (model, grid.t_s, grid.pressure_kpa, grid.angle_deg, grid.rate_hz)
    result = benchmark.pedantic(diagnose, args=args, rounds=1, iterations=1)
    benchmark.extra_info["verdict"] = result.verdict
    benchmark.extra_info["effects"] = [e.name for e in result.effects]


CLASSES = ["steps", "chirp", "prbs", "multisine", "ramp", "slow_sine", "vent_release", "pi_steps"]
FAMILIES = ["ringing", "overdamped", "stiff"]
BEHIND_SCREEN = ("contact", "hysteresis", "pressure_stiffening", "creep")  # issue 41's four
EIGHT_ONLY = ("<the eight alone>",)  # _timed's default search without BEHIND_SCREEN


def _eight(tmp_path) -> list:
    """The speed points' recordings: one per excitation class of the independent generator,
    dry friction missing, the three plant families in turn, 30 s at 100 Hz."""
    return [_independent("coulomb_friction", c, FAMILIES[i % 3], 100.0, tmp_path / c)
            for i, c in enumerate(CLASSES)]


def _timed(model, grid, also: tuple[str, ...] = ()) -> tuple[float, float, str]:
    """One diagnose: wall and CPU seconds (all threads) and the verdict with its names.
    `also` EIGHT_ONLY: the default search without the effects searched behind the screen."""
    import contextlib
    import time
    from unittest import mock

    from hand_service.config import effects as fx
    from hand_service.diagnose import requested

    def eight(asked: tuple[str, ...]) -> list[str]:
        return [name for name in requested.searched(()) if not fx.BY_NAME[name].admitted_by_screen]

    alone = also == EIGHT_ONLY
    with mock.patch("hand_service.diagnose.engine.searched", eight) if alone else contextlib.nullcontext():
        started, cpu_started = time.perf_counter(), time.process_time()
        result = diagnose(model, grid.t_s, grid.pressure_kpa, grid.angle_deg, grid.rate_hz,
                          also=() if alone else also)
    named = ",".join(e.name for e in result.effects)
    answer = f"{result.verdict} {named}".strip()
    return time.perf_counter() - started, time.process_time() - cpu_started, answer


@pytest.mark.slow
def test_diagnose_median_and_max_over_independent_100_hz_recordings(benchmark, tmp_path) -> None:
    """Issue 20's speed target, median <= 2 s and max <= 5 s per 30 s, 100 Hz recording:
    one recording per excitation class of the independent generator, three plant families."""
    import numpy as np

    inputs = _eight(tmp_path)
    seconds: list[float] = []
    cpu_seconds: list[float] = []

    def run_all() -> None:
        for model, grid in inputs:
            wall_s, cpu_s, _ = _timed(model, grid)
            seconds.append(wall_s)
            cpu_seconds.append(cpu_s)

    benchmark.pedantic(run_all, rounds=1, iterations=1)
    benchmark.extra_info["median_s"] = float(np.median(seconds))
    benchmark.extra_info["max_s"] = float(np.max(seconds))
    benchmark.extra_info["cpu_s"] = float(np.sum(cpu_seconds))  # all threads: the work, whatever the cores
    benchmark.extra_info["blas_threads"] = _blas_threads()
    print(f"\ndiagnose per 30 s, 100 Hz recording: median {np.median(seconds):.2f} s, "
          f"max {np.max(seconds):.2f} s; CPU time over the {len(inputs)}: {np.sum(cpu_seconds):.1f} s")


@pytest.mark.slow
def test_diagnose_with_the_four_searched_behind_the_screen(benchmark, tmp_path) -> None:
    """Issue 41's speed budget for searching the four effects by default: the median and the
    largest CPU time over the same eight recordings with the default search (the four behind
    the screen, search/admission.py) within 1.5 times those with the eight alone, and every
    name the eight give kept (a Dahl loop named for dry friction broke both: docs/results.md
    §12.30; where the eight name nothing, a new name is printed, judged in docs/results.md).
    Both searches run on each recording in turn, so that a load that changes over the run
    weighs on both; each recording's CPU time (the figure a busy machine does not inflate),
    both answers and the ratios are printed."""
    import numpy as np

    inputs = _eight(tmp_path)
    cpu_s: dict[tuple[str, ...], list[float]] = {EIGHT_ONLY: [], (): []}
    wall_s: dict[tuple[str, ...], list[float]] = {EIGHT_ONLY: [], (): []}
    answers: dict[tuple[str, ...], list[str]] = {EIGHT_ONLY: [], (): []}

    def run_all() -> None:
        for excitation, (model, grid) in zip(CLASSES, inputs, strict=True):
            for search in cpu_s:
                wall, cpu, answer = _timed(model, grid, search)
                wall_s[search].append(wall)
                cpu_s[search].append(cpu)
                answers[search].append(answer)
            print(f"\n{excitation}: CPU {cpu_s[EIGHT_ONLY][-1]:.2f} s -> {cpu_s[()][-1]:.2f} s; "
                  f"{answers[EIGHT_ONLY][-1]} -> {answers[()][-1]}")

    benchmark.pedantic(run_all, rounds=1, iterations=1)
    ratios = {}
    for label, figure in (("median", np.median), ("max", np.max)):
        before, after = float(figure(cpu_s[EIGHT_ONLY])), float(figure(cpu_s[()]))
        ratios[label] = benchmark.extra_info[f"{label}_cpu_ratio"] = after / before
        print(f"\n{label} CPU per recording: {before:.2f} s -> {after:.2f} s ({after / before:.2f} x; "
              f"wall {float(figure(wall_s[EIGHT_ONLY])):.2f} -> {float(figure(wall_s[()])):.2f} s)")
    named_by_eight = [(a, b) for a, b in zip(answers[EIGHT_ONLY], answers[()], strict=True)
                      if a.startswith("missing_physics")]
    assert all(a == b for a, b in named_by_eight), named_by_eight
    assert ratios["median"] <= 1.5 and ratios["max"] <= 1.5


@pytest.mark.slow
@pytest.mark.parametrize("effect", ["gravity", "coulomb_friction"])
def test_diagnose_5_minutes_at_500_hz(benchmark, effect: str) -> None:
    """Issue 44's long recording: 5 minutes at 500 Hz (150 000 samples), the concealed
    generator's steps with one effect missing."""
    import time

    model = load_profile(None).finger("index").model
    c = generate(model, {effect: None}, "steps", duration_s=300.0, rate_hz=500.0, noise_deg=0.5, seed=1,
                 conceal_ratio=0.8)
    cpu_started = time.process_time()
    result = benchmark.pedantic(diagnose, args=(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, 500.0),
                                rounds=1, iterations=1)
    cpu_s = time.process_time() - cpu_started
    benchmark.extra_info["verdict"] = result.verdict
    benchmark.extra_info["cpu_s"] = cpu_s
    benchmark.extra_info["blas_threads"] = _blas_threads()
    print(f"\ndiagnose, 5 minutes at 500 Hz, {effect} missing: {result.seconds:.2f} s, CPU {cpu_s:.1f} s")
    assert result.effects[0].name == effect
