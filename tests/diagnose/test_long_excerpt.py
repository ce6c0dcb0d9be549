"""A recording longer than the excerpt's budget is searched over what its leading excerpt
found worth fitting (search/excerpt.py, docs/diagnose.md "Long recordings").

The budget is lowered here so that a 30 s, 100 Hz recording counts as long (its first
15 s the excerpt): the mechanism is the same at any budget. What the project measures its
answers on (the battery's 30 s at up to 1 kHz, the real rigs) stays below the real budget."""

from __future__ import annotations

from pathlib import Path

import pytest

from hand_service.config.profile import load_profile
from hand_service.diagnose.concealed.generator import generate
from hand_service.diagnose.engine import diagnose
from hand_service.diagnose.report.sentence_checks import facts_of, failures
from hand_service.diagnose.search import excerpt
from hand_service.recording import read_recording
from tests.diagnose.truth import cases as cs

REAL = Path(__file__).parent / "real"
BUDGET_S = 15.0  # of a 30 s, 100 Hz recording


def _long(monkeypatch, hidden: dict[str, float | None]):
    """A concealed 30 s, 100 Hz recording diagnosed with the budget at its first 15 s: the
    result, the excerpt's diagnosis, and the progress lines said after the excerpt's."""
    monkeypatch.setattr(excerpt, "BUDGET_SAMPLES", int(BUDGET_S * 100.0))
    model = load_profile(None).finger("index").model
    c = generate(model, hidden, "steps", noise_deg=0.5, seed=1, conceal_ratio=0.8)
    seen: list[tuple[int, list[str], object]] = []  # each run's samples, names and diagnosis
    run_excerpt = excerpt.searched_from_excerpt

    def spying(run, n_samples, rate_hz, search, asked, progress=None):
        def spied(part: slice, names: list[str]):
            d = run(part, names)
            seen.append((part.stop, list(names), d))
            return d
        return run_excerpt(spied, n_samples, rate_hz, search, asked, progress)

    monkeypatch.setattr(excerpt, "searched_from_excerpt", spying)
    lines: list[str] = []
    result = diagnose(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, 100.0, progress=lines.append)
    return result, seen, lines


def test_a_long_recording_is_searched_over_its_excerpts_candidates(monkeypatch) -> None:
    result, seen, lines = _long(monkeypatch, {"gravity": None})
    (first_n, first_names, first), (whole_n, whole_names, _) = seen
    assert (first_n, whole_n) == (1500, 3000)
    worth = excerpt.worth_fitting(first)
    assert set(whole_names) == worth and len(whole_names) < len(first_names)
    # every effect the whole's search screened or fitted came from the excerpt
    said = next(i for i, line in enumerate(lines) if "searched over the effects" in line)
    searched = [line.removeprefix("screening ").removeprefix("fitting ").removesuffix(" with the model")
                for line in lines[said:] if line.startswith(("screening ", "fitting "))]
    assert searched and all(set(names.split(", ")) <= worth for names in searched), searched
    round1 = {c.name for c in result.selection.rounds[0].candidates}
    assert round1 <= worth
    assert [e.name for e in result.effects] == ["gravity"]
    sentence = f"searched over the effects that gained on the first 15 s: {', '.join(whole_names)}"
    assert any(sentence in w for w in result.warnings), result.warnings
    assert not failures(sentence, facts_of(result))
    assert result.problem.measured_deg.size == 3000  # the report's figures are the whole's


def test_nothing_worth_fitting_leaves_the_plain_models_verdict(monkeypatch) -> None:
    result, seen, _ = _long(monkeypatch, {})
    (_, _, first), (_, whole_names, _) = seen
    assert whole_names == [] and not excerpt.worth_fitting(first)
    assert result.selection.rounds == [] and not result.effects
    assert result.verdict in ("consistent", "parameters_only", "unexplained")
    assert any("first 15 s: none, so only the plain model was fitted" in w for w in result.warnings)


def test_below_the_budget_nothing_changes(monkeypatch) -> None:
    """The whole is run once, over every effect, and nothing is said of an excerpt."""
    calls: list[int] = []
    run_excerpt = excerpt.searched_from_excerpt

    def counting(run, n_samples, rate_hz, search, asked, progress=None):
        return run_excerpt(lambda part, names: calls.append(len(names)) or run(part, names),
                           n_samples, rate_hz, search, asked, progress)

    monkeypatch.setattr(excerpt, "searched_from_excerpt", counting)
    model = load_profile(None).finger("index").model
    c = generate(model, {"gravity": None}, "steps", duration_s=10.0, noise_deg=0.5, seed=1, conceal_ratio=0.8)
    result = diagnose(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, 100.0)
    assert len(calls) == 1 and calls[0] >= 9
    assert not any("first" in w and "searched over" in w for w in result.warnings)


@pytest.mark.parametrize("fixture", sorted(p.name for p in REAL.glob("*.csv")))
def test_the_real_rigs_lie_below_the_budget(fixture: str) -> None:
    assert read_recording(REAL / fixture, None).t_s.size <= excerpt.BUDGET_SAMPLES


def test_the_batterys_recordings_lie_below_the_budget() -> None:
    longest = max(cs.RATES) * cs.CaseSpec("gravity", "steps", 0, "evident", "ringing").duration_s
    assert longest <= excerpt.BUDGET_SAMPLES
