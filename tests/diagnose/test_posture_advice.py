"""When gravity and a cubic spring explain a recording equally well, diagnose says why
(the finger bent one way only) and what recording would tell them apart."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from hand_service.diagnose.search.posture_stability import posture_advice

GRAVITY, CUBIC, FRICTION = (SimpleNamespace(name=name)
                            for name in ("gravity", "cubic_stiffness", "coulomb_friction"))


def test_a_one_sided_recording_is_told_to_bend_both_ways() -> None:
    one_way = np.linspace(0.0, 75.0, 500)
    (advice,) = posture_advice((GRAVITY, CUBIC), one_way)  # type: ignore[arg-type]
    assert "bent one way only here (1° to 74°)" in advice and "both ways" in advice  # 1st, 99th pct
    assert posture_advice((CUBIC, GRAVITY), -one_way)  # type: ignore[arg-type]


def test_no_such_advice_where_it_bent_both_ways_or_for_another_pair() -> None:
    both_ways = np.linspace(-40.0, 75.0, 500)
    assert posture_advice((GRAVITY, CUBIC), both_ways) == []  # type: ignore[arg-type]
    assert posture_advice((GRAVITY, FRICTION), np.linspace(0.0, 75.0, 500)) == []  # type: ignore[arg-type]
