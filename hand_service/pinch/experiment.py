"""The pinch experiment: tune each controller once per object, then run the four finger
pairs x three objects x two controllers, the same placements for both controllers."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hand_service.config.profile import Profile
from hand_service.pinch.mismatch import NONE, Mismatch
from hand_service.pinch.objects import OBJECTS, PinchObject, Placements
from hand_service.pinch.plant import HELD, OUTCOME_NAMES, RELEASE_S
from hand_service.pinch.stats import Paired, fisher_p, wilson_interval
from hand_service.pinch.trials import CONTROLLERS, PAIRS, Cell, Traces, run_cells
from hand_service.pinch.tuning import HAND_RULE, Rule, Tuned, tune

TRACED_TRIALS = 25  # recorded per object and controller, for the figure

# The paper's Tables 3 (force control) and 4 (constant pressure): (successes, trials).
PAPER_PINCH: dict[str, dict[tuple[str, str], tuple[int, int]]] = {
    "force": {
        ("index", "chip"): (8, 13), ("index", "screwdriver"): (8, 12), ("index", "coin"): (8, 11),
        ("middle", "chip"): (9, 11), ("middle", "screwdriver"): (11, 11), ("middle", "coin"): (8, 12),
        ("ring", "chip"): (10, 10), ("ring", "screwdriver"): (6, 8), ("ring", "coin"): (5, 12),
        ("little", "chip"): (11, 11), ("little", "screwdriver"): (5, 9), ("little", "coin"): (10, 13),
    },
    "pressure": {
        ("index", "chip"): (7, 10), ("index", "screwdriver"): (7, 10), ("index", "coin"): (4, 10),
        ("middle", "chip"): (8, 10), ("middle", "screwdriver"): (8, 10), ("middle", "coin"): (3, 10),
        ("ring", "chip"): (8, 10), ("ring", "screwdriver"): (7, 10), ("ring", "coin"): (3, 10),
        ("little", "chip"): (10, 10), ("little", "screwdriver"): (6, 10), ("little", "coin"): (4, 10),
    },
}


def paper_counts(obj: str, finger: str | None = None) -> dict[str, Any] | None:
    """The paper's force and constant-pressure counts for one pair (or pooled over the four,
    finger None) and Fisher's exact test between them: its trials were not paired."""
    fingers = [finger] if finger else ["index", "middle", "ring", "little"]
    if any((f, obj) not in PAPER_PINCH["force"] for f in fingers):
        return None
    sf, nf = (sum(PAPER_PINCH["force"][(f, obj)][k] for f in fingers) for k in (0, 1))
    sp, n_p = (sum(PAPER_PINCH["pressure"][(f, obj)][k] for f in fingers) for k in (0, 1))
    return {"force": [sf, nf], "pressure": [sp, n_p], "fisher_exact_p": fisher_p(sf, nf, sp, n_p)}


@dataclass
class CellResult:
    pair: tuple[str, str]
    obj: str
    controller: str
    successes: int
    trials: int
    failures: dict[str, int]
    held_force_n: float  # median true normal force over the hold, trials held
    held: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))  # per placement, in order

    @property
    def rate(self) -> float:
        return self.successes / self.trials if self.trials else float("nan")

    @property
    def interval(self) -> tuple[float, float]:
        return wilson_interval(self.successes, self.trials)

    def to_json(self) -> dict[str, Any]:
        low, high = self.interval
        return {"pair": list(self.pair), "object": self.obj, "controller": self.controller,
                "successes": self.successes, "trials": self.trials, "rate": self.rate,
                "wilson95": [low, high], "failures": self.failures, "held_force_n": self.held_force_n}


@dataclass
class PinchResult:
    trials_per_cell: int
    seed: int
    tuned: dict[tuple[str, str, str], Tuned]  # (finger, object, controller)
    cells: list[CellResult]
    rule: Rule = HAND_RULE
    # (object, controller): the first trials of the first pair, the same placements for both
    traces: dict[tuple[str, str], list[Traces]] = field(default_factory=dict)
    trace_held: dict[tuple[str, str], list[bool]] = field(default_factory=dict)
    seconds: float = 0.0
    mismatch: Mismatch = NONE
    # the force estimate's RMS error against the plant's true normal force, fingers in contact
    estimate_rmse_n: dict[str, float] = field(default_factory=dict)

    def shown_trial(self, obj: str) -> int:
        """The recorded trial to plot: the first where the two controllers differ, else the first."""
        force, pressure = self.trace_held[(obj, "force")], self.trace_held[(obj, "pressure")]
        return next((k for k, (a, b) in enumerate(zip(force, pressure, strict=True)) if a != b), 0)

    def cell(self, controller: str, finger: str, obj: str) -> CellResult:
        return next(c for c in self.cells
                    if c.controller == controller and c.pair[1] == finger and c.obj == obj)

    def paired(self, obj: str, finger: str | None = None) -> Paired:
        """Force control against constant pressure on the same placements: one pair's
        cell, or (finger None) every pair's pooled."""
        total = Paired(0, 0, 0, 0)
        for force in self.cells:
            if force.controller != "force" or force.obj != obj or finger not in (None, force.pair[1]):
                continue
            pressure = next(c for c in self.cells
                            if c.controller == "pressure" and c.obj == obj and c.pair == force.pair)
            total = total + Paired.of(force.held, pressure.held)
        return total

    def tuned_once(self) -> list[Tuned]:
        """Each tuning once (a setpoint tuned on thumb and index serves every pair)."""
        return list(dict.fromkeys(self.tuned.values()))

    def pooled(self, controller: str, obj: str) -> tuple[int, int]:
        mine = [c for c in self.cells if c.controller == controller and c.obj == obj]
        return sum(c.successes for c in mine), sum(c.trials for c in mine)

    def to_json(self) -> dict[str, Any]:
        pooled = {}
        for controller in CONTROLLERS:
            for obj in (o.name for o in OBJECTS):
                s, n = self.pooled(controller, obj)
                pooled[f"{controller}/{obj}"] = {"successes": s, "trials": n, "rate": s / n if n else None,
                                                 "wilson95": list(wilson_interval(s, n))}
        paired = []
        for obj in (o.name for o in OBJECTS):
            fingers = [c.pair[1] for c in self.cells if c.controller == "force" and c.obj == obj]
            for finger in [*fingers, None]:
                row = {"object": obj, "finger": finger or "all", **self.paired(obj, finger).to_json()}
                paper = paper_counts(obj, finger)
                if paper is not None:
                    row["paper"] = paper
                paired.append(row)
        return {"trials_per_cell": self.trials_per_cell, "seed": self.seed, "seconds": self.seconds,
                "tuning_rule": self.rule.describe(), "tuned": [vars(t) for t in self.tuned_once()],
                "cells": [c.to_json() for c in self.cells],
                "pooled": pooled, "paired": paired, "plant_mismatch": dataclasses.asdict(self.mismatch),
                "estimate_rmse_n": self.estimate_rmse_n}


def run_pinch(truth: Profile, controller_profile: Profile, trials_per_cell: int, seed: int,
              progress: Callable[[str], None] | None = None,
              objects: tuple[PinchObject, ...] = OBJECTS,
              pairs: tuple[tuple[str, str], ...] = PAIRS, rule: Rule = HAND_RULE,
              mismatch: Mismatch = NONE, release_s: float = RELEASE_S) -> PinchResult:
    say = progress or (lambda _: None)
    started = time.perf_counter()
    tune_seed, place_seed, run_seed = (int(s) for s in np.random.SeedSequence([seed, 18]).generate_state(3))
    say(f"pinch: tuning each controller's setpoint ({rule.where}; {rule.describe()})")
    tuned = tune(truth, controller_profile, tune_seed, objects, rule, pairs, mismatch, release_s)
    for t in dict.fromkeys(tuned.values()):
        low, high, chosen = t.in_own_unit()
        say(f"pinch: {t.obj} {t.controller} (thumb & {t.finger}): holds from {low:g} to {high:g} {t.unit}, "
            f"set to {chosen:g} {t.unit}")
    rng = np.random.default_rng(place_seed)
    placements = {(pair, obj.name): Placements.draw(obj, trials_per_cell, rng)
                  for pair in pairs for obj in objects}
    cells: list[Cell] = []
    record: dict[tuple[str, str], list[int]] = {}
    shown = min(trials_per_cell, TRACED_TRIALS)
    for controller in CONTROLLERS:
        for pair in pairs:
            for obj in objects:
                if pair == pairs[0]:
                    first = sum(c.n for c in cells)
                    record[(obj.name, controller)] = list(range(first, first + shown))
                setpoint = tuned[(pair[1], obj.name, controller)].in_own_unit()[2]
                cells.append(Cell(pair, obj, controller, np.full(trials_per_cell, setpoint),
                                  placements[(pair, obj.name)]))
    total = sum(c.n for c in cells)
    say(f"pinch: {total} trials ({trials_per_cell} a cell), 2 s closing and 5 s hold each, stepped together")
    recorded = tuple(i for rows in record.values() for i in rows)
    batch = run_cells(truth, controller_profile, cells, run_seed, recorded, mismatch, release_s)
    controllers = np.array([c.controller for c in cells])[batch.cell_of_trial]
    rmse = {c: batch.estimate_rmse_n(controllers == c) for c in CONTROLLERS}
    results = []
    for k, cell in enumerate(cells):
        mine = batch.cell_of_trial == k
        outcome = batch.outcome[mine]
        successes, trials = batch.successes(k)
        failures = {name: int(np.count_nonzero(outcome == code)) for code, name in OUTCOME_NAMES.items()
                    if name != "held" and np.any(outcome == code)}
        held = batch.held_force_n[mine]
        held_force = float(np.nanmedian(held)) if np.any(np.isfinite(held)) else float("nan")
        results.append(CellResult(cell.pair, cell.obj.name, cell.controller, successes, trials, failures,
                                  held_force, outcome == HELD))
    traces = {key: [batch.traces[i] for i in rows] for key, rows in record.items()}
    held = {key: [bool(batch.outcome[i] == HELD) for i in rows] for key, rows in record.items()}
    return PinchResult(trials_per_cell, seed, tuned, results, rule, traces, held,
                       time.perf_counter() - started, mismatch, rmse)
