"""The fuzz tests' documents and settings.

Each reader gets one test of QUICK_EXAMPLES inputs (in `make test`) and one of
FULL_EXAMPLES marked `fuzz` (`make fuzz`); both assert that bad input is a one-line
UserError (or the API's error reply), never another exception.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hand_service.config.profile import DEFAULT_PROFILE, PROFILE_DIR
from hand_service.errors import UserError

QUICK_EXAMPLES = 200  # make test's share; `make fuzz` runs FULL_EXAMPLES
FULL_EXAMPLES = 5000
_SETTINGS = settings(deadline=None, database=None, print_blob=True,
                     suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                            HealthCheck.filter_too_much, HealthCheck.large_base_example,
                                            HealthCheck.function_scoped_fixture])


def fuzz_tests(strategy: st.SearchStrategy[Any], check: Callable[[Any, Any], None],
               fixture: str = "fuzz_dir") -> tuple[Any, Any]:
    """Two tests of check(<the fixture's value>, data): QUICK_EXAMPLES inputs, and
    FULL_EXAMPLES marked fuzz."""
    def quick(request: pytest.FixtureRequest, data: Any) -> None:
        check(request.getfixturevalue(fixture), data)

    def full(request: pytest.FixtureRequest, data: Any) -> None:
        check(request.getfixturevalue(fixture), data)

    return (settings(_SETTINGS, max_examples=QUICK_EXAMPLES)(given(data=strategy)(quick)),
            pytest.mark.fuzz(settings(_SETTINGS, max_examples=FULL_EXAMPLES)(given(data=strategy)(full))))


def refused_in_one_line(call: Callable[[], object]) -> None:
    """call() succeeds or raises a UserError of one non-empty line; anything else escapes."""
    try:
        call()
    except UserError as exc:
        message = str(exc)
        assert message and "\n" not in message and "\r" not in message, repr(message)


# -- the documents mutated ------------------------------------------------------------------
def _compact_profile() -> dict[str, Any]:
    """sim.yaml with one finger: quick to load, every section present."""
    doc = yaml.safe_load(DEFAULT_PROFILE.read_text())
    doc["hand"] = {"index": doc["hand"]["index"]}
    doc["safety"].update(target_angle_min_deg=0.0, target_angle_max_deg=180.0, target_force_max_n=10.0)
    return doc


PROFILE_DOC = _compact_profile()
PROFILE_TEXT = yaml.safe_dump(PROFILE_DOC, sort_keys=False)
BUS_PROFILE_DOC = {
    "profile": "bus", "description": "a serial board", "protocol_version": 1, "include": "base.yaml",
    "transport": {"kind": "serial", "port": "/dev/ttyACM0", "baudrate_bps": 921600,
                  "handshake_timeout_ms": 1000, "sensor_min_mv": 0, "sensor_max_mv": 5000},
}
BUS_PROFILE_TEXT = yaml.safe_dump(BUS_PROFILE_DOC, sort_keys=False)
CAN_PROFILE_TEXT = yaml.safe_dump({**BUS_PROFILE_DOC, "transport": {
    "kind": "can", "interface": "virtual", "channel": "fuzz", "bitrate_bps": 500000, "dbc": "can-v1.dbc"}},
    sort_keys=False)

MODEL_TEXT = """\
finger: index                      # optional; must match a recording's `# finger:`
inertia_kgm2: 1.617e-4             # A
damping_nms_per_rad: 0.0031        # B
stiffness_nm_per_rad: 0.570        # k
pressure_gain_nm_per_kpa: 8.954e-3 # N
mass_kg: 0.050
length_m: 0.095
gamma: 0.85
lever_arm_m: 0.040
effects:
  valve_lag: {tau_s: 0.03}
  dead_time: {delay_s: 0.005}
"""
MODEL_DOC = yaml.safe_load(MODEL_TEXT)
GEOMETRY_MODEL_TEXT = "mass_kg: 0.05\nlength_m: 0.095\ngamma: 0.85\nstiffness_nm_per_rad: 0.57\n"


def _recording_text(n: int = 110) -> str:
    t = np.arange(n) / 100.0
    lines = ["# finger: index", "# sample_rate_hz: 100", "t,pressure_kpa,angle_deg,sensor_mv,state"]
    lines += [f"{t[k]:.4f},{10 * np.sin(t[k]):.6g},{20 * np.sin(t[k]):.6g},{500 + k},RUNNING"
              for k in range(n)]
    return "\n".join(lines) + "\n"


def _daemon_recording_text(n: int = 105) -> str:
    header = ["t", "state"] + [f"{q}_{f}" for f in ("thumb", "index") for q in
                               ("angle_ref_deg", "pressure_kpa", "angle_deg", "mode", "flags")]
    lines = ["# fingers: thumb index", ",".join(header)]
    for k in range(n):
        per = [f"{k * 0.3:.6g}", f"{k * 0.1:.6g}", f"{k * 0.29:.6g}", "position", "0"]
        lines.append(",".join([f"{k / 100:.4f}", "RUNNING", *per, *per]))
    return "\n".join(lines) + "\n"


RECORDING_TEXT = _recording_text()
DAEMON_RECORDING_TEXT = _daemon_recording_text()
TRAJECTORY_TEXT = ("# a pinch\nt,angle_ref_deg_thumb,angle_ref_deg_index,force_ref_n_index\n"
                   "0.00,0,0,\n0.50,60,90,\n0.75,60,,1.0\n1.00,60,,1.0\n1.25,0,0,\n")


@pytest.fixture(scope="session")
def fuzz_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with what the bus profiles include (base.yaml, sim.yaml, can-v1.dbc)."""
    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "base.yaml").write_text(PROFILE_TEXT)
    shutil.copy(DEFAULT_PROFILE, folder / "sim.yaml")
    shutil.copy(PROFILE_DIR / "can-v1.dbc", folder / "can-v1.dbc")
    return folder
