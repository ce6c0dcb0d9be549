"""The paired comparison: McNemar's exact test on the discordant pairs, Newcombe's interval
on the difference of paired rates, Fisher's exact test on the paper's counts, and the
pairing of the run's cells by placement."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import binom

from hand_service.pinch.experiment import CellResult, PinchResult, paper_counts
from hand_service.pinch.stats import Paired, fisher_p, mcnemar_exact_p, paired_difference_interval
from hand_service.pinch.tables import paired_table


def test_mcnemar_exact_is_the_binomial_on_the_discordant_pairs() -> None:
    # 9 discordant pairs, 1 against 8: p = 2 P(X <= 1), X ~ Bin(9, 1/2)
    assert mcnemar_exact_p(1, 8) == pytest.approx(2 * binom.cdf(1, 9, 0.5))
    assert mcnemar_exact_p(8, 1) == mcnemar_exact_p(1, 8)
    assert mcnemar_exact_p(0, 0) == 1.0
    assert mcnemar_exact_p(5, 5) == 1.0
    # concordant pairs do not enter
    assert Paired(0, 0, 10, 0).mcnemar_p == Paired(990, 0, 10, 5).mcnemar_p
    assert Paired(990, 0, 10, 0).mcnemar_p == pytest.approx(2 * 0.5**10)


def test_fisher_on_the_papers_pooled_counts() -> None:
    coin, chip = paper_counts("coin"), paper_counts("chip")
    assert coin is not None and chip is not None
    assert coin["force"] == [31, 48] and coin["pressure"] == [14, 40]
    assert chip["force"] == [38, 45] and chip["pressure"] == [33, 40]
    assert 0.005 < coin["fisher_exact_p"] < 0.02  # the paper's one significant difference
    assert chip["fisher_exact_p"] > 0.5
    assert paper_counts("coin", "index") == {"force": [8, 11], "pressure": [4, 10],
                                             "fisher_exact_p": pytest.approx(fisher_p(8, 11, 4, 10))}


def test_newcombe_interval_holds_the_difference_and_narrows_with_pairing() -> None:
    low, high = paired_difference_interval(40, 10, 2, 48)
    assert low < 0.08 < high and low >= -1.0 and high <= 1.0
    assert low > 0.0  # 10 against 2 in 100 pairs: force better
    # no discordant pair: the interval sits around 0 and narrows as the pairs grow
    small = paired_difference_interval(5, 0, 0, 5)
    large = paired_difference_interval(500, 0, 0, 500)
    assert small[0] < 0.0 < small[1] and large[0] < 0.0 < large[1]
    assert large[1] - large[0] < small[1] - small[0]
    # with many pairs it meets the Wald interval of the paired difference
    b, c, n = 300, 200, 10000
    d = (b - c) / n
    wald = 1.959964 * math.sqrt((b + c) / n - d**2) / math.sqrt(n)
    low, high = paired_difference_interval(4000, b, c, n - 4000 - b - c)
    assert low == pytest.approx(d - wald, abs=2e-3) and high == pytest.approx(d + wald, abs=2e-3)
    # positive correlation between the controllers' outcomes narrows it against the unpaired
    independent = paired_difference_interval(25, 25, 25, 25)
    correlated = paired_difference_interval(45, 5, 5, 45)
    assert correlated[1] - correlated[0] < independent[1] - independent[0]


def _cell(finger: str, controller: str, held: list[bool]) -> CellResult:
    h = np.array(held)
    return CellResult(("thumb", finger), "coin", controller, int(h.sum()), len(h), {}, float("nan"), h)


def test_the_run_pairs_its_cells_by_placement() -> None:
    cells = [_cell("index", "force", [True, True, False, True]),
             _cell("index", "pressure", [True, False, False, False]),
             _cell("middle", "force", [False, True]),
             _cell("middle", "pressure", [True, True])]
    result = PinchResult(4, 1, {}, cells)
    assert result.paired("coin", "index") == Paired(1, 2, 0, 1)
    assert result.paired("coin", "middle") == Paired(1, 0, 1, 0)
    assert result.paired("coin") == Paired(2, 2, 1, 1)
    with pytest.raises(ValueError):
        Paired.of(np.ones(3, bool), np.ones(2, bool))
    table = paired_table(result)
    assert "| Brass Coin | thumb & index | 1 | 2 | 0 | 1 | +50.0 [" in table
    assert "| Brass Coin | all pairs | 2 | 2 | 1 | 1 |" in table
    assert "65 % (31/48) / 35 % (14/40) | 0.0098 |" in table
