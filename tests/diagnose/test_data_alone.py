"""An effect favoured only while the nominal's prior holds k, B and N is not named
(prior_evidence.data_alone_bic, in engine.py): the truth's hysteresis on a slow ramp, which a
recording cannot pin k, B, N from, lags the finger; with the eight alone searched the prior
keeps B from taking that lag, and a valve lag takes it instead. The default search names
the loop (hysteresis, behind the screen)."""

from __future__ import annotations

from pathlib import Path

import pytest

import hand_service.diagnose.engine as engine
import hand_service.diagnose.outside_library.checks as outside
from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.battery import diagnose_in_process

HYSTERESIS_RAMP = cs.CaseSpec("hysteresis", "ramp", 0, "concealed", "stiff", 100.0)


def _eight_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    """The default search without the four searched behind the screen (hysteresis among them)."""
    from hand_service.config import effects as fx
    from hand_service.diagnose import requested

    monkeypatch.setattr(engine, "searched", lambda also: [
        name for name in requested.searched(()) if not fx.BY_NAME[name].admitted_by_screen])


def _diagnose(tmp_path: Path) -> dict:
    return diagnose_in_process(*cs.write(cs.build(HYSTERESIS_RAMP), tmp_path), tmp_path)


@pytest.mark.thorough
def test_the_loop_is_named_by_default(tmp_path: Path) -> None:
    """hysteresis, searched behind the screen, names the truth's loop (no valve lag)."""
    result = _diagnose(tmp_path)
    assert [e["name"] for e in result["effects"]] == ["hysteresis"], result["warnings"]


def test_a_lag_the_prior_alone_asks_for_is_not_named(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """With the eight alone searched, the valve lag the prior asks for is refused."""
    _eight_alone(monkeypatch)
    result = _diagnose(tmp_path)
    assert not result["effects"], result["effects"]
    assert any("only while k, B and N are held near the nominal" in w for w in result["warnings"])
    assert result["verdict"] in ("insufficient_excitation", "unexplained")


@pytest.mark.thorough  # the checks shown load-bearing: in make test-thorough, with the rest
def test_without_the_check_the_rate_test_still_refuses_the_lag(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """A second line: the valve lag's delay does not grow with the ramps' rates, and a loop
    along the command's path explains the residual better (outside_library/rate_independent_loop.py)."""
    _eight_alone(monkeypatch)
    monkeypatch.setattr(engine, "data_alone_bic", lambda *args: float("inf"))
    result = _diagnose(tmp_path)
    assert not result["effects"], result["effects"]
    assert result["loop"] is not None and result["loop"]["replaces"] == "valve_lag"


@pytest.mark.thorough  # the checks shown load-bearing: in make test-thorough, with the rest
def test_without_either_check_the_loop_rival_leaves_the_lag_unnamed(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """A third line: the Dahl loop fitted in place of the valve lag follows the raw angle
    better beyond the recording's fluctuation (search/rival_check.py, `Rival.better`), so
    nothing is named."""
    _eight_alone(monkeypatch)
    monkeypatch.setattr(engine, "data_alone_bic", lambda *args: float("inf"))
    monkeypatch.setattr(outside, "loop_check", lambda *args: None)
    result = _diagnose(tmp_path)
    assert result["verdict"] == "unexplained" and not result["effects"], result["verdict"]
    assert [e["name"] for e in result["partial_effects"]] == ["valve_lag"]
    assert result["rival"]["name"] == "hysteresis_loop" and result["rival"]["better"]


@pytest.mark.thorough  # the checks shown load-bearing: in make test-thorough, with the rest
def test_without_the_three_the_hysteresis_is_named_a_valve_lag(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    _eight_alone(monkeypatch)
    monkeypatch.setattr(engine, "data_alone_bic", lambda *args: float("inf"))
    monkeypatch.setattr(outside, "loop_check", lambda *args: None)
    monkeypatch.setattr(engine.loop_rival, "closer", lambda library, *args: library)
    result = _diagnose(tmp_path)
    assert [e["name"] for e in result["effects"]] == ["valve_lag"], result["verdict"]
