"""The control API's listening sockets: the Unix socket (mode 0600, in a directory private
to the daemon's user) and the TCP port on the loopback."""

from __future__ import annotations

import logging
import os
import socket
from pathlib import Path

from hand_service.api.access import check_private_dir
from hand_service.errors import UserError

log = logging.getLogger(__name__)

LOOPBACK = "127.0.0.1"
BACKLOG = 128  # connections the kernel holds until the loop's slack accepts them


def default_socket_path() -> Path:
    """$HAND_SERVICE_SOCKET, else $XDG_RUNTIME_DIR/hand-service/api.sock, else
    /tmp/hand-service-<uid>/api.sock."""
    if os.environ.get("HAND_SERVICE_SOCKET"):
        return Path(os.environ["HAND_SERVICE_SOCKET"])
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    base = Path(runtime) / "hand-service" if runtime else Path(f"/tmp/hand-service-{os.getuid()}")
    return base / "api.sock"


def private_dir(path: Path) -> None:
    """Create the directory of `path` (mode 0700) if it is absent; it must be private
    (access.py)."""
    folder = path.parent
    if not folder.exists():
        try:
            folder.mkdir(mode=0o700, parents=True)
        except OSError as exc:
            raise UserError(f"{path}: cannot create its directory: {exc.strerror or exc}") from None
    check_private_dir(folder)


def unix_listener(path: Path) -> tuple[socket.socket, os.stat_result]:
    """A new socket at `path`, mode 0600, and what it is on disk (so that only this socket
    is removed at the end). A socket left by a daemon that died is replaced; a live
    daemon's, or anything else at the path, is refused."""
    private_dir(path)
    if path.is_socket():
        probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            probe.connect(str(path))
        except ConnectionRefusedError:
            path.unlink()  # left by a daemon that died: nobody answers
        except OSError as exc:
            raise UserError(f"{path}: a socket that cannot be probed: {exc.strerror or exc}") from None
        else:
            raise UserError(f"{path}: another hand-service daemon is listening there")
        finally:
            probe.close()
    elif path.exists() or path.is_symlink():
        raise UserError(f"{path}: exists and is not a socket; the control socket is never "
                        "created over a file (choose another --socket path)")
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    old = os.umask(0o177)  # the socket is created 0600: only this user may connect
    try:
        sock.bind(str(path))
    except OSError as exc:
        sock.close()
        raise UserError(f"{path}: cannot create the control socket: {exc.strerror}") from None
    finally:
        os.umask(old)
    made = os.stat(path)
    os.chmod(path, 0o600)
    sock.listen(BACKLOG)
    log.info("control API on %s (0600)", path)
    return sock, made


def tcp_listener(port: int) -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((LOOPBACK, port))
    except (OSError, OverflowError) as exc:  # in use, or no such port (OverflowError)
        sock.close()
        raise UserError(f"cannot listen on {LOOPBACK}:{port}: "
                        f"{getattr(exc, 'strerror', None) or exc}") from None
    sock.listen(BACKLOG)
    return sock


def same_file(path: Path, made: os.stat_result) -> bool:
    """Whether `path` is still the file `made` describes (not one put there since)."""
    try:
        now = os.lstat(path)
    except OSError:
        return False
    return (now.st_dev, now.st_ino) == (made.st_dev, made.st_ino)
