"""diagnose searches the library's searched effects; `--search` adds one it leaves out by
default (pressure_stiffening, creep), judged by the same tests."""

from __future__ import annotations

import pytest

from hand_service.config import effects as fx
from hand_service.config.profile import load_profile
from hand_service.diagnose.concealed.generator import generate
from hand_service.diagnose.engine import diagnose, searched
from hand_service.errors import UserError


def test_the_default_search_is_the_searched_effects() -> None:
    assert searched(()) == [e.name for e in fx.SEARCHED]
    assert "pressure_stiffening" not in searched(())
    assert searched(["pressure_stiffening", "pressure_stiffening"])[-1:] == ["pressure_stiffening"]
    with pytest.raises(UserError, match="--search stiffening: unknown effect"):
        searched(["stiffening"])


def test_a_concealed_pressure_stiffening_is_named_when_searched() -> None:
    """Concealed at 0.8 times the noise on the project's generator: named first, its gain
    within 10 % (without it searched, the eight's nearest stand-in is named: docs/results.md)."""
    model = load_profile(None).finger("index").model
    c = generate(model, {"pressure_stiffening": None}, "steps", noise_deg=0.5, seed=1, conceal_ratio=0.8)
    true = c.hidden["pressure_stiffening"]["gain"]
    found = diagnose(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, 100.0, also=("pressure_stiffening",))
    assert found.effects[0].name == "pressure_stiffening"
    assert found.effects[0].value == pytest.approx(true, rel=0.1)
