"""Every broken variant on every link, with every check run (`make test-boardcheck`, marker
boardcheck; make test runs each variant once, on one link, test_broken_boards.py): the
broken rule fails its check whatever else runs before it, and nothing else fails but
the checks that follow from the same rule."""

from __future__ import annotations

from pathlib import Path

import pytest

from hand_service import cli
from hand_service.firmware.board import BROKEN
from tests.boardcheck.conftest import TEST_OPTIONS, board

FAILS = {  # the variant -> the checks it must fail (with every check run)
    "no-watchdog": {"watchdog"},
    "wrong-crc": {"handshake"},
    "stuck-sequence": {"sequence"},
    "echo-version": {"version-refusal"},
    "silent-reboot": {"reboot-announce"},
    "quiet-idle": {"report-rate", "sequence", "watchdog"},  # silent idle, and silent once vented
    "counts-rubbish": {"crc-and-garbage"},
    "zero-vents": {"zero-vent"},  # a zero command taken for a vent request
    # the plant through the board (zero-vent cannot see a vent where nothing rose: N/A)
    "valves-dead": {"plant"},
    "valve-stuck": {"plant"},
    "pressure-nan": {"plant"},
    "pressure-x2": {"plant"},
    "flex-stuck": {"plant"},
    "flex-x2": {"plant"},
}
# checks a variant may fail too, by chance: a doubled pressure reading of a chamber still
# venting can sit above zero-vent's 2 kPa after its 0.5 s
MAY_FAIL = {"pressure-x2": {"zero-vent"}}


@pytest.mark.boardcheck
@pytest.mark.parametrize("link", ["serial", "slcan", "virtual"])
@pytest.mark.parametrize("variant", sorted(BROKEN))
def test_each_broken_rule_fails_its_check_on_each_link(variant: str, link: str, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    with board(link, tmp_path, variant) as target:
        status = cli.main(["board-check", *target, *TEST_OPTIONS])
    out = capsys.readouterr().out
    assert status == 1, out
    failed = {line.split()[1] for line in out.splitlines() if line.startswith("FAIL  ")} - {"stopped"}
    assert FAILS[variant] <= failed <= FAILS[variant] | MAY_FAIL.get(variant, set()), out
