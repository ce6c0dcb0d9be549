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


def test_nested_maps_never_run_more_items_than_the_threads() -> None:
    """A map inside a map's item (a round's effects, each effect's starts, each start's
    Jacobian columns) shares the one pool: at most threads() leaves run at once, the
    results keep their order, and no pool thread waits for an item nobody runs."""
    import threading
    import time

    running, most = 0, 0
    lock = threading.Lock()

    def leaf(x: int) -> int:
        nonlocal running, most
        with lock:
            running += 1
            most = max(most, running)
        time.sleep(0.002)
        with lock:
            running -= 1
        return x

    def middle(x: int) -> list[int]:
        return workers.ordered_map(leaf, [10 * x + i for i in range(4)])

    def outer(x: int) -> list[list[int]]:
        return workers.ordered_map(middle, [10 * x + i for i in range(3)])

    with workers.using(2):
        got = workers.ordered_map(outer, range(4))
    assert got == [[[100 * a + 10 * b + c for c in range(4)] for b in range(3)] for a in range(4)]
    assert 1 <= most <= 2
    pool_threads = [t for t in threading.enumerate() if t.name.startswith("diagnose")]
    assert len(pool_threads) <= 1  # one shared pool of threads() − 1
    workers.shutdown()
    assert not [t for t in threading.enumerate() if t.name.startswith("diagnose") and t.is_alive()]


def test_a_caller_waiting_for_a_running_item_runs_the_queued_ones() -> None:
    """The caller's own item done, it waits for the pool's, whose nested items it runs
    meanwhile: no core idles while an item is queued."""
    import threading
    import time

    leaves_ran_on: set[int] = set()

    def leaf(x: int) -> int:
        leaves_ran_on.add(threading.get_ident())
        time.sleep(0.01)
        return x

    def item(x: int) -> list[int]:
        if x == 0:
            time.sleep(0.05)  # the pool's thread takes item 1 meanwhile
            return []
        return workers.ordered_map(leaf, range(8))

    with workers.using(2):
        assert workers.ordered_map(item, range(2)) == [[], list(range(8))]
    assert threading.get_ident() in leaves_ran_on and len(leaves_ran_on) == 2
    workers.shutdown()


def test_another_number_of_threads_replaces_the_pool() -> None:
    def nested(x: int) -> list[int]:
        return workers.ordered_map(lambda y: x * y, range(5))

    for jobs in (2, 3, 2):
        with workers.using(jobs):
            assert workers.ordered_map(nested, range(4)) == [[x * y for y in range(5)] for x in range(4)]
    workers.shutdown()


def test_a_map_whose_item_raises_raises_and_runs_nothing_more() -> None:
    done: list[int] = []

    def item(x: int) -> int:
        if x == 0:
            raise RuntimeError("first")
        done.append(x)
        return x

    with workers.using(2), pytest.raises(RuntimeError, match="first"):
        workers.ordered_map(item, range(50))
    workers.shutdown()
    assert len(done) < 49  # those not yet started were withdrawn


def test_the_command_takes_jobs() -> None:
    parser = argparse.ArgumentParser()
    command.add_arguments(parser)
    assert parser.parse_args(["r.csv", "--model", "m.yaml"]).jobs is None
    assert parser.parse_args(["r.csv", "--model", "m.yaml", "--jobs", "2"]).jobs == 2
    for wrong in ("0", "-1", "two"):
        with pytest.raises(SystemExit):
            parser.parse_args(["r.csv", "--model", "m.yaml", "--jobs", wrong])
