"""A recording longer than the excerpt's budget is searched over what its leading excerpt
found worth fitting (search/excerpt.py, docs/diagnose-design.md "Long recordings").

The budget is lowered here so that a 30 s, 100 Hz recording counts as long (its first
12 s the excerpt): the mechanism is the same at any budget. What the project measures its
answers on (the battery's 30 s at up to 1 kHz, the real rigs) stays below the real budget."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hand_service.config.profile import load_profile
from hand_service.diagnose.concealed.generator import generate
from hand_service.diagnose.engine import diagnose
from hand_service.diagnose.report.sentence_checks import facts_of, failures
from hand_service.diagnose.search import excerpt
from hand_service.recording import read_recording
from tests.diagnose.truth import cases as cs

REAL = Path(__file__).parent / "real"
BUDGET_S = 12.0  # of a 30 s, 100 Hz recording: at most excerpt.MAX_SHARE of it


def _long(monkeypatch, hidden: dict[str, float | None], budget_s: float = BUDGET_S):
    """A concealed 30 s, 100 Hz recording diagnosed with the budget at its first `budget_s`: the
    result, the excerpt's diagnosis, and the progress lines said after the excerpt's."""
    monkeypatch.setattr(excerpt, "BUDGET_SAMPLES", int(budget_s * 100.0))
    model = load_profile(None).finger("index").model
    c = generate(model, hidden, "steps", noise_deg=0.5, seed=1, conceal_ratio=0.8)
    seen: list[tuple[int, list[str], object]] = []  # each run's samples, names and diagnosis
    run_excerpt = excerpt.searched_from_excerpt

    def spying(run, n_samples, rate_hz, search, asked, progress=None):
        def spied(part: slice, names: list[str], graded: bool):
            d = run(part, names, graded)
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
    assert (first_n, whole_n) == (1200, 3000)
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
    sentence = f"searched over the effects that gained on the first 12 s: {', '.join(whole_names)}"
    assert any(sentence in w for w in result.warnings), result.warnings
    assert not failures(sentence, facts_of(result))
    assert result.problem.measured_deg.size == 3000  # the report's figures are the whole's


def test_nothing_worth_fitting_leaves_the_plain_models_verdict(monkeypatch) -> None:
    result, seen, _ = _long(monkeypatch, {})
    (_, _, first), (_, whole_names, _) = seen
    assert whole_names == [] and not excerpt.worth_fitting(first)
    assert result.selection.rounds == [] and not result.effects
    assert result.verdict in ("consistent", "parameters_only", "unexplained")
    assert any("first 12 s: none, so only the plain model was fitted" in w for w in result.warnings)


def test_an_excerpt_that_cannot_decide_leaves_the_whole_search(monkeypatch) -> None:
    """The first 10 s bend the finger one way only: gravity and a cubic spring cannot be told
    apart there (insufficient_excitation), and the whole is searched over every effect."""
    result, seen, _ = _long(monkeypatch, {"gravity": None}, budget_s=10.0)
    (_, first_names, first), (_, whole_names, _) = seen
    assert first.verdict == "insufficient_excitation" and whole_names == first_names
    assert [e.name for e in result.effects] == ["gravity"]
    assert not any("searched over the effects" in w for w in result.warnings)


def test_below_the_budget_nothing_changes(monkeypatch) -> None:
    """The whole is run once, over every effect, and nothing is said of an excerpt."""
    calls: list[int] = []
    run_excerpt = excerpt.searched_from_excerpt

    def counting(run, n_samples, rate_hz, search, asked, progress=None):
        return run_excerpt(lambda part, names, graded: calls.append(len(names)) or run(part, names, graded),
                           n_samples, rate_hz, search, asked, progress)

    monkeypatch.setattr(excerpt, "searched_from_excerpt", counting)
    model = load_profile(None).finger("index").model
    c = generate(model, {"gravity": None}, "steps", duration_s=10.0, noise_deg=0.5, seed=1, conceal_ratio=0.8)
    result = diagnose(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, 100.0)
    assert len(calls) == 1 and calls[0] >= 9
    assert not any("first" in w and "searched over" in w for w in result.warnings)


def test_worth_fitting_takes_the_named_the_tied_and_what_gained() -> None:
    """Named, partial, accepted, carried and both of a tie, and any round's candidate over
    SIGNIFICANT_BIC; not a candidate that gained less."""
    from types import SimpleNamespace as NS

    from hand_service.diagnose.search.forward_selection import SIGNIFICANT_BIC

    def c(name: str, delta_bic: float = 0.0) -> NS:
        return NS(name=name, delta_bic=delta_bic)

    rounds = [NS(candidates=[c("dead_time", 500.0), c("gravity", SIGNIFICANT_BIC + 1.0),
                             c("cubic_stiffness", SIGNIFICANT_BIC)]),
              NS(candidates=[c("creep", SIGNIFICANT_BIC + 5.0), c("hysteresis", -3.0)])]
    selection = NS(accepted=[c("coulomb_friction")], carried=[c("dead_time")],
                   ambiguous=(c("dead_time"), c("valve_lag")), rounds=rounds)
    d = NS(effects=[c("coulomb_friction")], partial_effects=[c("contact")], selection=selection)
    assert excerpt.worth_fitting(d) == {"coulomb_friction", "contact", "dead_time", "valve_lag",
                                        "gravity", "creep"}


def test_the_excerpt_ungraded_then_the_whole_graded_over_its_names(monkeypatch) -> None:
    """The excerpt runs without the rivals that decide only the grade; the whole runs graded,
    over what the excerpt found, in the search's order, and says so; the seconds are both's."""
    from types import SimpleNamespace as NS

    monkeypatch.setattr(excerpt, "BUDGET_SAMPLES", 400)
    calls: list[tuple[int, list[str], bool]] = []

    def run(part: slice, names: list[str], graded: bool) -> NS:
        calls.append((part.stop, names, graded))
        rounds = [NS(candidates=[NS(name="gravity", delta_bic=50.0), NS(name="dead_time", delta_bic=3.0)])]
        selection = NS(accepted=[], carried=[], ambiguous=None, rounds=rounds)
        return NS(verdict="unexplained", effects=[], partial_effects=[], selection=selection, warnings=[],
                  seconds=1.0)

    search = ["dead_time", "coulomb_friction", "gravity", "cubic_stiffness"]
    result = excerpt.searched_from_excerpt(run, 1000, 100.0, search, ["cubic_stiffness"])
    assert calls == [(400, search, False), (1000, ["gravity", "cubic_stiffness"], True)]
    assert result.warnings == ["a long recording: searched over the effects that gained on the first "
                               "4 s: gravity (and cubic_stiffness, asked for)"]
    assert result.seconds == 2.0


def test_an_excerpt_past_its_share_is_not_taken(monkeypatch) -> None:
    """A recording only a little longer than the budget is searched whole: the excerpt's
    own diagnosis would cost more than the fewer candidates win back."""
    monkeypatch.setattr(excerpt, "BUDGET_SAMPLES", int(0.5 * 3000))  # half of 30 s at 100 Hz
    names: list[list[str]] = []
    result = excerpt.searched_from_excerpt(lambda part, search, graded: names.append(search) or part.stop,
                                           3000, 100.0, ["gravity", "coulomb_friction"], ())
    assert names == [["gravity", "coulomb_friction"]] and result == 3000


@pytest.mark.thorough  # two 60 s diagnoses
def test_physics_only_after_the_excerpt_is_unexplained_not_named(monkeypatch) -> None:
    """A contact at 50° reached only after the excerpt (the command's first 40 % at 0.4 of
    its level): the excerpt finds nothing worth fitting, and the whole's residual tests
    answer `unexplained`; searched over every effect, the contact is named."""
    from hand_service.config.profile import load_profile as profile
    from hand_service.diagnose.concealed.excitations import EXCITATIONS
    from hand_service.diagnose.concealed.generator import full_pressure_kpa, perturb, record

    model = profile(None).finger("index").model
    rng = np.random.default_rng(1)
    command = EXCITATIONS["steps"](full_pressure_kpa(model), 60.0, 100.0, rng)
    first = int(excerpt.MAX_SHARE * command.size)
    command[:first] *= 0.4
    truth = model.with_changes(effects={"contact": {"stiffness_nm_per_radn": 1.0, "onset_deg": 50.0}})
    measured, true = record(truth, command, 100.0, 0.5, 0.122, 1)
    assert true[:first].max() < 50.0 < true[first:].max()
    nominal = perturb(model, 0.1, rng)
    monkeypatch.setattr(excerpt, "BUDGET_SAMPLES", first)
    result = diagnose(nominal, np.arange(command.size) / 100.0, command, measured, 100.0)
    assert result.verdict == "unexplained" and not result.effects and not result.partial_effects
    assert any("first 24 s: none" in w for w in result.warnings), result.warnings


@pytest.mark.parametrize("fixture", sorted(p.name for p in REAL.glob("*.csv")))
def test_the_real_rigs_lie_below_the_budget(fixture: str) -> None:
    assert read_recording(REAL / fixture, None).t_s.size <= excerpt.BUDGET_SAMPLES


def test_the_batterys_recordings_lie_below_the_budget() -> None:
    longest = max(cs.RATES) * cs.CaseSpec("gravity", "steps", 0, "evident", "ringing").duration_s
    assert longest <= excerpt.BUDGET_SAMPLES
