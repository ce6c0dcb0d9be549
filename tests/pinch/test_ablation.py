"""The ablation's plants: the mismatched plant with one part taken out each, and the PRBM."""

from __future__ import annotations

import dataclasses

import pytest

from hand_service.pinch.ablation import VARIANTS, main
from hand_service.pinch.mismatch import NONE, PAPER_MISMATCH


def test_each_variant_takes_out_one_part() -> None:
    full = dataclasses.asdict(PAPER_MISMATCH)
    parts = set()
    for name, mismatch in VARIANTS.items():
        if mismatch in (PAPER_MISMATCH, NONE):
            continue
        changed = [k for k, v in dataclasses.asdict(mismatch).items() if v != full[k]]
        assert len(changed) == 1, name
        parts.add(changed[0])
    # every part of the mismatch that the plant has is taken out once
    assert parts == {k for k, v in full.items() if v and k != "reference_kpa"}
    assert NONE in VARIANTS.values() and PAPER_MISMATCH in VARIANTS.values()


def test_the_release_time_is_checked_before_anything_runs() -> None:
    with pytest.raises(SystemExit):
        main(["--release-s", "-1"])
