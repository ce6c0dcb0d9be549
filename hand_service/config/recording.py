"""What a recording failure does (a profile's `recording:` block), typed.

RECORDING_SECTION validates the block and documents it (docs/profiles.md);
RecordingSettings holds the validated values. The block is the profile's own: `include`
does not bring it in.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hand_service.config.schema import Key, Section, expect_mapping, validate

ON_FAILURE = ("warning", "fault")
FILE_MODES = ("0600", "0640", "0660", "0644", "0664")

RECORDING_SECTION = Section(
    "Recording", "`recording:` — what the daemon does when a recording stops reaching its file "
    "(not taken from an included profile).", (
        Key("on_failure", "a failed write, a full disk or a writer that died: `warning` logs an "
            "error and shows it in `status` while control goes on; `fault` latches FAULT, which "
            "vents, and faults again at every arm until the recording is stopped (docs/service.md)",
            "choice", default="warning", choices=ON_FAILURE),
        Key("data_dir", "the daemon's data directory: the only one `ctl load` reads and `ctl "
            "record-start` writes in, relative to the profile's own directory; `run --data-dir` "
            "overrides it (default: the directory of `run --record`, else "
            "$XDG_DATA_HOME/hand-service/recordings, docs/api.md)", "str", default=None),
        Key("file_mode", "the permissions a recording's file is created with, whatever the "
            "daemon's umask: owner read-write, the group read (`0640`), nobody else unless the lab "
            "says so", "choice", default="0640", choices=FILE_MODES),
    ))


@dataclass(frozen=True)
class RecordingSettings:
    """The validated `recording:` block (RECORDING_SECTION documents each key)."""

    on_failure: str = "warning"  # warning | fault
    data_dir: Path | None = None  # the profile's data directory, made absolute against its own
    file_mode: str = "0640"  # octal, one of FILE_MODES

    @classmethod
    def from_values(cls, values: dict[str, Any]) -> RecordingSettings:
        return cls(**{f.name: values[f.name] for f in dataclasses.fields(cls)})

    @classmethod
    def from_profile(cls, data: Any, source: Path) -> RecordingSettings:
        """The `recording:` block of a profile's top-level mapping (absent: the defaults)."""
        block = data.get("recording")
        block = {} if block is None else expect_mapping(block, source, data, "recording", "recording")
        values = validate(block, RECORDING_SECTION, source, "recording")
        if values["data_dir"] is not None:
            values["data_dir"] = Path(source).parent / Path(values["data_dir"]).expanduser()
        return cls.from_values(values)

    @property
    def file_mode_bits(self) -> int:
        return int(self.file_mode, 8)

    @property
    def faults(self) -> bool:
        """A recording failure latches FAULT."""
        return self.on_failure == "fault"


__all__ = ["FILE_MODES", "ON_FAILURE", "RECORDING_SECTION", "RecordingSettings"]
