"""A rig's shipped profile with a sample-age bound five times its own, for the HIL tests
that test something else (holding a target, a fault's attribution): one stall of the mock's
process on a loaded CI machine (107 ms, 108 ms beside the CPU-bound tests) faulted
sample_late under the profile's 100 ms and failed a run. The bound itself is tested by the
fault matrix (tests/hil/matrix.py) and tests/hil/test_link_checks.py."""

from __future__ import annotations

from pathlib import Path

import yaml

from hand_service.config.profile import PROFILE_DIR
from hand_service.firmware.rig import RIG_PROFILES

SAMPLE_AGE_MAX_MS = 500


def tolerant_profile(name: str, tmp_path: Path) -> Path:
    """The rig's shipped profile with SAMPLE_AGE_MAX_MS in its safety section, written to
    `tmp_path`: the mock and the host both read it from that file."""
    shipped = PROFILE_DIR / RIG_PROFILES[name]
    data = yaml.safe_load(shipped.read_text())
    included = PROFILE_DIR / data["include"]
    safety = dict(yaml.safe_load(included.read_text())["safety"])
    safety["sample_age_max_ms"] = SAMPLE_AGE_MAX_MS
    data.update(include=str(included), safety=safety)
    if "dbc" in data["transport"]:  # relative to the profile, like the include
        data["transport"]["dbc"] = str(PROFILE_DIR / data["transport"]["dbc"])
    path = tmp_path / RIG_PROFILES[name]
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path
