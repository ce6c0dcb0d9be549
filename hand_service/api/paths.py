"""The daemon's data directory, and the paths a request may name: only inside it,
symlinks resolved first, never a directory created for a request (docs/api.md)."""

from __future__ import annotations

import logging
import os
import stat
from pathlib import Path

from hand_service.config.textfile import show
from hand_service.errors import UserError

log = logging.getLogger(__name__)


class PathRefused(UserError):
    """A path a request may not use; the message is the reply's error."""


SETS_IT = "run --data-dir or the profile's recording.data_dir sets it"


def choose_data_dir(flag: Path | None, profile_key: Path | None, record: Path | None) -> tuple[Path, str]:
    """The data directory and what chose it: `run --data-dir`, else the profile's
    `recording.data_dir`, else the directory of `run --record FILE`, else
    $XDG_DATA_HOME/hand-service/recordings (by default ~/.local/share/hand-service/recordings)."""
    if flag is not None:
        return flag, "--data-dir"
    if profile_key is not None:
        return profile_key, "the profile's recording.data_dir"
    if record is not None:
        return Path(os.path.abspath(record)).parent, "the directory of --record"
    data = os.environ.get("XDG_DATA_HOME", "")
    base = Path(data) if os.path.isabs(data) else Path.home() / ".local" / "share"
    return base / "hand-service" / "recordings", "the default"


def prepare_record_dir(path: Path) -> Path:
    """Create the data directory, mode 0700, if it is absent; its real path (every
    symlink resolved). A UserError of one line if it cannot be made or is not a directory."""
    try:
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"{path}: cannot create the data directory ({SETS_IT}): "
                        f"{exc.strerror or exc}") from None
    real = Path(os.path.realpath(path))
    info = os.stat(real)
    if not stat.S_ISDIR(info.st_mode):
        raise UserError(f"{path}: the data directory ({SETS_IT}) is not a directory")
    if info.st_mode & 0o022:
        log.warning("the data directory %s is writable by other users: requests record and read "
                    "there (docs/api.md)", real)
    return real


def _shown(path: str) -> str:
    return path if path.isprintable() and len(path) <= 200 else show(path, 200)


def confine(cmd: str, path: str, root: Path | None) -> str:
    """The real path (symlinks and `..` resolved) of `path` if it lies in the data
    directory `root`; else PathRefused, naming the directory."""
    if root is None:
        raise PathRefused(f"{cmd}: this daemon has no data directory (it serves no socket), so it "
                          "takes no path")
    if not os.path.isabs(path):
        raise PathRefused(f"{cmd}: the path must be absolute, in the data directory {root} (the daemon "
                          "has its own working directory)")
    real = os.path.realpath(path)
    if os.path.commonpath([real, str(root)]) != str(root):
        raise PathRefused(f"{cmd}: {_shown(path)} is outside the data directory {root} "
                          f"(symlinks resolved; copy it there, or {SETS_IT})")
    return real


def new_file_in(cmd: str, path: str, root: Path | None) -> str:
    """The real path of a file a request creates: in the data directory, in a
    directory that exists already (none is made for a request), each directory below the
    data directory owned by the daemon's user and writable by no one else (so that
    nobody can swap one for a symlink between this check and the file's creation)."""
    real = confine(cmd, path, root)
    assert root is not None
    parent = Path(real).parent
    if not parent.is_dir():
        raise PathRefused(f"{cmd}: {_shown(path)}: its directory does not exist (the daemon creates "
                          f"no directory for a request; the data directory is {root})")
    uid = os.geteuid()
    for folder in (parent, *parent.parents):
        if folder == root or len(folder.parts) <= len(root.parts):
            break
        info = os.lstat(folder)
        if info.st_uid != uid or info.st_mode & 0o022:
            raise PathRefused(f"{cmd}: {_shown(path)}: the directory {folder} in the data directory "
                              f"{root} is not private to the daemon's user (owner uid {info.st_uid}, "
                              f"mode {stat.S_IMODE(info.st_mode):04o})")
    return real
