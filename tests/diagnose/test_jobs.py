"""`jobs`: a diagnosis on several threads is the one-thread diagnosis, bit for bit (the
whole report, every number in it), and `hand-service diagnose --jobs` sets the number."""

from __future__ import annotations

import argparse
import json

import pytest

from hand_service.commands import diagnose as command
from hand_service.config.profile import load_model
from hand_service.diagnose import workers
from hand_service.diagnose.engine import diagnose
from hand_service.diagnose.recording.timebase import regular_grid
from hand_service.recording import read_recording
from tests.diagnose.truth import cases as cs


def _recording(excitation: str, family: str, tmp_path):
    """One of the speed bench's recordings: dry friction missing, 30 s at 100 Hz."""
    spec = cs.CaseSpec("coulomb_friction", excitation, 0, "evident", family, 100.0)
    rec_path, model_path = cs.write(cs.build(spec), tmp_path)
    rec = read_recording(rec_path, None)
    return load_model(model_path, None), regular_grid(rec.t_s, rec.pressure_kpa, rec.angle_deg, rec_path)


def _report(model, grid, jobs: int) -> dict:
    result = diagnose(model, grid.t_s, grid.pressure_kpa, grid.angle_deg, grid.rate_hz, jobs=jobs)
    report = result.to_json()
    report.pop("seconds")  # the one field that is the clock's
    return report


# chirp: dry friction named; vent_release: structure left beside every pick, so pairs and
# triples are fitted side by side (search/set_search.py) before `unexplained` (the costlier:
# in test-thorough)
@pytest.mark.parametrize(("excitation", "family", "verdict"), [
    ("chirp", "overdamped", "missing_physics"),
    pytest.param("vent_release", "ringing", "unexplained", marks=pytest.mark.thorough)])
def test_two_threads_give_the_one_thread_report(excitation: str, family: str, verdict: str,
                                                tmp_path) -> None:
    model, grid = _recording(excitation, family, tmp_path)
    one, two = (_report(model, grid, jobs) for jobs in (1, 2))
    assert one["verdict"] == verdict
    assert json.dumps(one, sort_keys=True) == json.dumps(two, sort_keys=True)


def test_using_sets_the_threads_for_the_block_and_restores_them() -> None:
    before = workers.threads()
    with workers.using(2) as two:
        assert two == workers.threads() == 2
        with workers.using(None) as unchanged:
            assert unchanged == 2
    with workers.using(10 * workers.MOST_THREADS) as most:
        assert most == workers.MOST_THREADS
    assert workers.threads() == before
    with pytest.raises(ValueError, match="jobs=0"), workers.using(0):
        pass


def test_one_thread_maps_in_the_calling_thread_and_keeps_the_order() -> None:
    import threading

    seen: set[int] = set()

    def square(x: int) -> int:
        seen.add(threading.get_ident())
        return x * x

    with workers.using(1):
        assert workers.ordered_map(square, range(6)) == [0, 1, 4, 9, 16, 25]
    assert seen == {threading.get_ident()}
    with workers.using(2):
        assert workers.ordered_map(square, range(6)) == [0, 1, 4, 9, 16, 25]


def test_the_command_takes_jobs() -> None:
    parser = argparse.ArgumentParser()
    command.add_arguments(parser)
    assert parser.parse_args(["r.csv", "--model", "m.yaml"]).jobs is None
    assert parser.parse_args(["r.csv", "--model", "m.yaml", "--jobs", "2"]).jobs == 2
    for wrong in ("0", "-1", "two"):
        with pytest.raises(SystemExit):
            parser.parse_args(["r.csv", "--model", "m.yaml", "--jobs", wrong])
