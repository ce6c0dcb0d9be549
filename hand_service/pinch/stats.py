"""Success rates with their Wilson score intervals, and the paired comparison of the two
controllers: McNemar's exact test and Newcombe's interval on the difference of paired
rates; Fisher's exact test for the paper's unpaired counts."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import binomtest, fisher_exact


def wilson_interval(successes: int, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion; (0, 1) when there were no trials."""
    if trials <= 0:
        return 0.0, 1.0
    interval = binomtest(successes, trials).proportion_ci(confidence_level=confidence, method="wilson")
    return float(interval.low), float(interval.high)


def mcnemar_exact_p(force_only: int, pressure_only: int) -> float:
    """McNemar's exact test: the two-sided binomial test of the discordant pairs against 1/2
    (1.0 when no pair is discordant)."""
    discordant = force_only + pressure_only
    if discordant == 0:
        return 1.0
    return float(binomtest(force_only, discordant, 0.5).pvalue)


def fisher_p(successes_a: int, trials_a: int, successes_b: int, trials_b: int) -> float:
    """Fisher's exact test (two-sided) of two independent success counts."""
    table = [[successes_a, trials_a - successes_a], [successes_b, trials_b - successes_b]]
    return float(fisher_exact(table).pvalue)


def paired_difference_interval(both: int, force_only: int, pressure_only: int, neither: int,
                               confidence: float = 0.95) -> tuple[float, float]:
    """Newcombe's hybrid score interval (1998, method 10) on p_force - p_pressure from paired
    outcomes: each rate's Wilson interval, combined with the pairs' correlation phi, whose
    positive part is reduced by n/2 as Newcombe does (without it, pairs that all agree give
    the empty interval [0, 0])."""
    n = both + force_only + pressure_only + neither
    if n == 0:
        return -1.0, 1.0
    p1, p2 = (both + force_only) / n, (both + pressure_only) / n
    l1, u1 = wilson_interval(both + force_only, n, confidence)
    l2, u2 = wilson_interval(both + pressure_only, n, confidence)
    margins = ((both + force_only) * (pressure_only + neither) * (both + pressure_only)
               * (force_only + neither))
    cross = both * neither - force_only * pressure_only
    if cross > 0:
        cross = max(cross - n / 2.0, 0.0)
    phi = cross / math.sqrt(margins) if margins > 0 else 0.0
    delta = p1 - p2
    below = math.sqrt(max((p1 - l1) ** 2 - 2 * phi * (p1 - l1) * (u2 - p2) + (u2 - p2) ** 2, 0.0))
    above = math.sqrt(max((u1 - p1) ** 2 - 2 * phi * (u1 - p1) * (p2 - l2) + (p2 - l2) ** 2, 0.0))
    return max(delta - below, -1.0), min(delta + above, 1.0)


@dataclass(frozen=True)
class Paired:
    """The two controllers on the same placements: the 2x2 table of paired outcomes."""

    both: int
    force_only: int
    pressure_only: int
    neither: int

    @classmethod
    def of(cls, force_held: np.ndarray, pressure_held: np.ndarray) -> Paired:
        f, p = np.asarray(force_held, dtype=bool), np.asarray(pressure_held, dtype=bool)
        if f.shape != p.shape:
            raise ValueError(f"paired outcomes need the same trials: {f.shape} against {p.shape}")
        return cls(int(np.sum(f & p)), int(np.sum(f & ~p)), int(np.sum(~f & p)), int(np.sum(~f & ~p)))

    def __add__(self, other: Paired) -> Paired:
        return Paired(self.both + other.both, self.force_only + other.force_only,
                      self.pressure_only + other.pressure_only, self.neither + other.neither)

    @property
    def trials(self) -> int:
        return self.both + self.force_only + self.pressure_only + self.neither

    @property
    def difference(self) -> float:
        """p_force - p_pressure."""
        return (self.force_only - self.pressure_only) / self.trials if self.trials else float("nan")

    @property
    def interval(self) -> tuple[float, float]:
        return paired_difference_interval(self.both, self.force_only, self.pressure_only, self.neither)

    @property
    def mcnemar_p(self) -> float:
        return mcnemar_exact_p(self.force_only, self.pressure_only)

    def to_json(self) -> dict[str, Any]:
        return {"both": self.both, "force_only": self.force_only, "pressure_only": self.pressure_only,
                "neither": self.neither, "difference": self.difference,
                "difference95": list(self.interval), "mcnemar_exact_p": self.mcnemar_p}
