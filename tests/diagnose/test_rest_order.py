"""The search again with the noise filter's order at rest (search/rest_order.py): when its
answer is kept, on stand-ins for the fits (cheap), and the measured case on the truth
generator (thorough)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest

from hand_service.diagnose.search import rest_order
from hand_service.diagnose.search.forward_selection import Selection

REST_NOISE_DEG = 0.2  # the residual at rest, RMS


@dataclass
class FakeNoise:
    order: int


@dataclass
class FakeFit:
    raw_deg: float  # its raw RMS error, the stand-in's whole angle

    @property
    def angle_deg(self) -> float:
        return self.raw_deg

    def residual(self, problem):
        return np.zeros(4)

    finger: None = None


@dataclass
class FakeProblem:
    noise: FakeNoise
    pressure_kpa: np.ndarray = field(default_factory=lambda: np.zeros(4))
    rate_hz: float = 100.0

    def misfit(self, angle_deg):
        return np.zeros(4)


@dataclass
class FakeCandidate:
    name: str


def selection(names: list[str], raw_deg: float) -> Selection:
    return Selection(accepted=[FakeCandidate(n) for n in names], final=FakeFit(raw_deg))


@pytest.fixture
def stand_ins(monkeypatch):
    """The first order 7, the order at rest 2; the second search's answer set by the test."""
    state = {"again": selection([], 1.0), "searched": 0, "rest_order": 2}

    def again(problem, refit, names, progress=None):
        state["searched"] += 1
        assert problem.noise.order == state["rest_order"]
        return state["again"]

    monkeypatch.setattr(rest_order.noise_bound, "rest_noise",
                        lambda *a: np.full(400, REST_NOISE_DEG))
    monkeypatch.setattr(rest_order.noise_bound, "bounded_order",
                        lambda model, *a: FakeNoise(state["rest_order"]))
    monkeypatch.setattr(rest_order.raw_error, "raw_rms_deg", lambda problem, angle, fitting, scored: angle)
    monkeypatch.setattr(rest_order, "replace", lambda problem, noise: FakeProblem(noise))
    monkeypatch.setattr(rest_order, "select", again)
    monkeypatch.setattr(rest_order.set_search, "search", lambda *a: None)
    monkeypatch.setattr(rest_order.tie_revisit, "revisit", lambda *a: None)
    return state


def run(first: Selection) -> rest_order.AtRest | None:
    masks = (np.ones(4, dtype=bool), np.zeros(4, dtype=bool))
    return rest_order.search(FakeProblem(FakeNoise(7)), FakeFit(1.3), first, ["valve_lag"],
                             np.ones(4, dtype=bool), masks)


def test_a_richer_set_at_the_noise_is_kept(stand_ins):
    stand_ins["again"] = selection(["valve_lag", "pressure_deadzone", "quadratic_damping"], 0.22)
    got = run(selection(["valve_lag"], 1.3))
    assert got is not None
    assert [c.name for c in got.selection.accepted] == ["valve_lag", "pressure_deadzone", "quadratic_damping"]
    assert got.noise.order == 2 and got.order_before == 7
    assert "AR 7" in got.sentence() and "AR 2" in got.sentence()


def test_a_richer_set_short_of_the_noise_is_not_kept(stand_ins):
    """Friction's static peak left out of the library form: the richer set still misses."""
    stand_ins["again"] = selection(["valve_lag", "pressure_deadzone", "coulomb_friction"], 0.4)
    assert run(selection(["valve_lag", "pressure_deadzone"], 0.6)) is None


def test_a_set_that_drops_a_name_is_not_kept(stand_ins):
    stand_ins["again"] = selection(["pressure_deadzone", "quadratic_damping"], 0.22)
    assert run(selection(["valve_lag"], 1.3)) is None


def test_no_second_search_where_the_first_model_is_at_the_noise(stand_ins):
    assert run(selection(["valve_lag", "dead_time"], 0.21)) is None
    assert stand_ins["searched"] == 0


def test_no_second_search_where_the_order_at_rest_is_not_lower(stand_ins):
    stand_ins["rest_order"] = 7
    assert run(selection(["valve_lag"], 1.3)) is None
    assert stand_ins["searched"] == 0


@pytest.mark.thorough
def test_valve_lag_quadratic_damping_and_a_dead_zone_on_steps(tmp_path):
    """The measured case (100 Hz): the AR order 8 chosen on the plain model's misfit lets
    only the valve lag be named; at the order at rest the three follow the raw angle to
    the noise and are named."""
    from tests.diagnose.truth import combinations

    effects = ("valve_lag", "quadratic_damping", "pressure_deadzone")
    row = combinations.run(effects, "steps", 0, tmp_path)
    assert row["observable"]
    assert set(effects) <= set(row["named"])
