"""Who may talk to the daemon: the socket's directory must be private to the daemon's
user, a peer on the Unix socket must be that user or root (SO_PEERCRED), and a client
of the TCP port must show the token the daemon writes, mode 0600, beside its socket
(docs/api.md)."""

from __future__ import annotations

import contextlib
import hmac
import os
import secrets
import socket
import stat
import struct
from pathlib import Path

from hand_service.errors import UserError

TOKEN_BYTES = 32  # written as 64 hex digits
_CREDENTIALS = struct.Struct("3i")  # struct ucred: pid, uid, gid


def token_path(socket_path: Path) -> Path:
    """The token file of the daemon whose socket is socket_path: api.sock -> api.token
    (a socket named x.token: x.token.token)."""
    name = socket_path.stem + ".token"
    return socket_path.with_name(name if name != socket_path.name else name + ".token")


def check_private_dir(path: Path) -> None:
    """path must be a directory owned by this user and writable by no one else, and each
    directory above it owned by this user or root and writable by others only with the
    sticky bit (as /tmp): else another user could move the socket or the token away and
    put their own in its place. A UserError of one line if not."""
    uid = os.geteuid()
    real = Path(os.path.realpath(path))
    try:
        info = os.stat(real)
    except OSError as exc:
        raise UserError(f"{path}: cannot use it for the control socket: {exc.strerror or exc}") from None
    if not stat.S_ISDIR(info.st_mode):
        raise UserError(f"{path}: not a directory; the control socket needs one of its own")
    if info.st_uid != uid or info.st_mode & 0o022:
        raise UserError(
            f"{path}: the control socket's directory must be owned by uid {uid} and writable by no "
            f"one else; it is owned by uid {info.st_uid} with mode {stat.S_IMODE(info.st_mode):04o} "
            "(choose another --socket, or chmod go-w)")
    for parent in real.parents:
        try:
            info = os.stat(parent)
        except OSError as exc:
            raise UserError(f"{path}: cannot check the directory {parent} above it: "
                            f"{exc.strerror or exc}") from None
        shared = info.st_mode & 0o022 and not info.st_mode & stat.S_ISVTX
        if info.st_uid not in (uid, 0) or shared:
            raise UserError(
                f"{path}: the directory {parent} above the control socket is owned by uid "
                f"{info.st_uid} with mode {stat.S_IMODE(info.st_mode):04o}: another user could "
                "replace the socket's directory (choose another --socket)")


def write_token(path: Path) -> str:
    """A new random token in a new file, mode 0600 (the directory is private: checked)."""
    token = secrets.token_hex(TOKEN_BYTES)
    with contextlib.suppress(FileNotFoundError):
        path.unlink()  # left by a daemon that died: the socket beside it was stale too
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600)
    except OSError as exc:
        raise UserError(f"{path}: cannot write the TCP port's token: {exc.strerror or exc}") from None
    with os.fdopen(fd, "w") as f:
        os.fchmod(f.fileno(), 0o600)
        f.write(token + "\n")
    return token


def read_token(path: Path) -> str:
    """The token a daemon wrote; a ConnectionError of one line if it cannot be read."""
    try:
        with open(path, encoding="ascii") as f:
            token = f.read(4 * TOKEN_BYTES).strip()
    except (OSError, UnicodeDecodeError) as exc:
        why = getattr(exc, "strerror", None) or str(exc)
        raise ConnectionError(
            f"cannot read the daemon's token {path}: {why} (the TCP port needs the token the daemon "
            "writes beside its socket: give that socket with --socket, or the file with --token-file)"
        ) from None
    if not token:
        raise ConnectionError(f"{path}: empty; not a token the daemon wrote")
    return token


def token_matches(given: object, token: str | None) -> bool:
    """In constant time: whether `given` is the daemon's token."""
    if token is None or not isinstance(given, str):
        return False
    return hmac.compare_digest(given.encode("utf-8", "surrogatepass"), token.encode())


def peer(sock: socket.socket) -> tuple[int | None, int | None]:
    """(pid, uid) of the process at the other end of a Unix socket (Linux SO_PEERCRED):
    (None, None) where the system has no such option (the socket's mode 0600 alone then
    keeps others out), (None, -1) if the system fails to say (refused)."""
    option = getattr(socket, "SO_PEERCRED", None)
    if option is None:
        return None, None
    try:
        pid, uid, _gid = _CREDENTIALS.unpack(sock.getsockopt(socket.SOL_SOCKET, option, _CREDENTIALS.size))
    except OSError:
        return None, -1
    return pid, uid


def uid_allowed(uid: int | None) -> bool:
    """The daemon's own user and root may command the hand; nobody else."""
    return uid is None or uid in (os.geteuid(), 0)
