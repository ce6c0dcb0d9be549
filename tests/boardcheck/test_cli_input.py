"""board-check's bad input: one line on stderr, exit status 2, before any port is opened
(or naming the port that cannot be); --help explains every check."""

from __future__ import annotations

from pathlib import Path

import pytest

from hand_service import cli


def one_line_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and err.count("\n") == 0, err
    assert err.startswith("hand-service board-check: error: "), err
    return err


@pytest.mark.parametrize(("argv", "words"), [
    ([], "give a serial PORT, or --can"),
    (["/dev/null", "--can", "virtual:x"], "not both"),
    (["--can", "virtual"], "--can must be INTERFACE:CHANNEL"),
    (["--can", "nonsense:x"], "python-can has no interface 'nonsense'"),
    (["/dev/null", "--profile", "can-v1-slcan.yaml"], "this link needs a serial profile"),
    (["--can", "virtual:x", "--profile", "serial-v1.yaml"], "this link needs a can profile"),
    (["/dev/null", "--pressure-kpa", "1000"], "above the lowest finger limit"),
    (["/dev/null", "--pressure-kpa", "nan"], "--pressure-kpa must be a positive number"),
    (["/dev/null", "--seconds", "0"], "--seconds must be a positive number"),
    (["/dev/null", "--latency-ms", "-1"], "--latency-ms must be 0 or more"),
    (["/dev/null", "--only", "watchdog,nap"], "--only: no check nap"),
])
def test_bad_input_is_one_line(argv: list[str], words: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert words in one_line_error(capsys, ["board-check", *argv])


def test_a_port_that_cannot_be_opened_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "no-such-tty"
    assert f"cannot open serial port {missing}" in one_line_error(capsys, ["board-check", str(missing)])


def test_help_names_every_check(capsys: pytest.CaptureFixture[str]) -> None:
    from hand_service.boardcheck.runner import CHECKS

    with pytest.raises(SystemExit) as exit_:
        cli.main(["board-check", "--help"])
    assert exit_.value.code == 0
    out = capsys.readouterr().out
    assert all(f"\n  {name} " in out for name in CHECKS), out
