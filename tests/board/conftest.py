"""The HIL rigs with the reference firmware's host build (board/) in place of the Python
mock: built once per session into a tmp dir, each test with a pty and a process of its own."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.board.firmware import WIRES, BoardRig, build


@pytest.fixture(scope="session")
def board_binary(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build(tmp_path_factory.mktemp("board-build"))


@pytest.fixture(params=sorted(WIRES))
def rig(request: pytest.FixtureRequest, tmp_path: Path, board_binary: Path) -> Iterator[BoardRig]:
    with BoardRig(request.param, tmp_path) as bench_rig:
        bench_rig.binary = board_binary
        yield bench_rig


# What make test runs of the HIL suite against the C firmware (about 20 s on two cores):
# the handshake and refusal, the closed loop, a fault of the board's own, the watchdog vent
# after the host's SIGKILL, the C tests and the command line. The rest (every injected
# fault, the daemon over the board, the 30-trial watchdog measurement) carries the `board`
# marker: make test-board-host.
QUICK = {"test_handshake_reports_the_firmware": "", "test_wrong_protocol_is_refused": "",
         "test_closed_loop_step_to_a_target_angle": "", "test_firmware_vents_when_the_host_dies": "",
         "test_injected_fault_is_detected": "firmware_fault",
         "test_core_and_plant_c_tests_pass_under_sanitizers": "",
         "test_help_explains_and_bad_input_is_one_line": "",
         "test_default_hand_is_the_shipped_profiles_hand": ""}


def quick(name: str) -> bool:
    """Does make test run this test (name with its parameters, "test_x[serial-drop]")?"""
    base, _, params = name.partition("[")
    return base in QUICK and (not QUICK[base] or QUICK[base] in params.rstrip("]").split("-"))


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    here = Path(__file__).parent
    for item in items:
        if here in Path(str(item.fspath)).parents and not quick(item.name):
            item.add_marker(pytest.mark.board)
