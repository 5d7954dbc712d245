"""A throw-away PostgreSQL server for tests: Debian's ``postgresql`` binaries, a cluster in a temporary
folder, on a free port of 127.0.0.1, stopped when the test ends. Skipped, saying why, where the
binaries are missing (``.ci/setup.sh`` installs them for the tests)."""

from __future__ import annotations

import contextlib
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest


def server_binaries() -> Path | None:
    """The folder of ``initdb`` and ``pg_ctl`` (the newest Debian cluster version), or None."""
    versions = sorted(Path("/usr/lib/postgresql").glob("*/bin"), key=lambda p: int(p.parent.name), reverse=True)
    for folder in versions:
        if (folder / "initdb").exists() and (folder / "pg_ctl").exists():
            return folder
    found = shutil.which("initdb")
    return Path(found).parent if found and shutil.which("pg_ctl") else None


def _free_port() -> int:
    with contextlib.closing(socket.socket()) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _as_server_user(cmd: list[str]) -> list[str]:
    """PostgreSQL refuses to run as root: run as Debian's ``postgres`` user then."""
    if os.geteuid() != 0:
        return cmd
    return ["runuser", "-u", "postgres", "--", *cmd]


def _start(bindir: Path, data: Path, sock: Path, run: dict[str, Any]) -> int:
    """Start the cluster on a free port; the port it listens on. A port found free can be taken by
    another process (a parallel test worker) before the server binds it: then try another."""
    for attempt in range(3):
        port = _free_port()
        opts = f"-p {port} -k {sock} -c listen_addresses=127.0.0.1 -c fsync=off"
        start = [str(bindir / "pg_ctl"), "-D", str(data), "-l", str(sock / "log"), "-o", opts, "-w", "start"]
        try:
            subprocess.run(_as_server_user(start), **run)
            return port
        except subprocess.CalledProcessError:
            if attempt == 2:
                raise
    raise AssertionError("unreachable")


class Server:
    """A running throw-away server: its SQLAlchemy URL (psycopg2 driver), and :meth:`stop` and :meth:`start` to
    take it away and bring it back on the same port (a study's database lost mid-study, then back)."""

    def __init__(self, bindir: Path, data: Path, sock: Path, port: int, database: str) -> None:
        self.bindir, self.data, self.sock, self.port = bindir, data, sock, port
        self.url = f"postgresql+psycopg2://nhsim@127.0.0.1:{port}/{database}"

    def stop(self) -> None:
        """Stop the server now (``pg_ctl -m fast``: its clients' connections are closed)."""
        stop = [str(self.bindir / "pg_ctl"), "-D", str(self.data), "-m", "fast", "-w", "stop"]
        subprocess.run(_as_server_user(stop), check=True, capture_output=True, timeout=120)

    def start(self) -> None:
        """Start it again, on its port."""
        opts = f"-p {self.port} -k {self.sock} -c listen_addresses=127.0.0.1 -c fsync=off"
        log = str(self.sock / "log")
        start = [str(self.bindir / "pg_ctl"), "-D", str(self.data), "-l", log, "-o", opts, "-w", "start"]
        subprocess.run(_as_server_user(start), check=True, capture_output=True, timeout=120)


@contextlib.contextmanager
def postgres_server(database: str = "nhsim") -> Iterator[str]:
    """Start a server with a database; yield its SQLAlchemy URL (psycopg2 driver)."""
    with postgres_cluster(database) as server:
        yield server.url


@contextlib.contextmanager
def postgres_cluster(database: str = "nhsim") -> Iterator[Server]:
    """Start a server with a database; yield it (:class:`Server`).

    The cluster lives in a folder of its own under the system's temporary folder (pytest's are
    private to their owner, and the server runs as ``postgres`` when the tests run as root)."""
    reason = "the PostgreSQL driver psycopg2 is not installed (pip install psycopg2-binary)"
    pytest.importorskip("psycopg2", reason=reason)
    bindir = server_binaries()
    if bindir is None:
        pytest.skip("PostgreSQL server binaries not found: apt-get install postgresql")
    if os.geteuid() == 0:
        try:
            pg = pwd.getpwnam("postgres")
        except KeyError:
            pytest.skip("running as root and there is no 'postgres' user to run the server as")
    folder = Path(tempfile.mkdtemp(prefix="nhsim-pg-"))
    data, sock = folder / "pgdata", folder / "pgsock"
    sock.mkdir()
    if os.geteuid() == 0:
        os.chmod(folder, 0o755)
        os.chown(sock, pg.pw_uid, pg.pw_gid)
        data.mkdir()
        os.chown(data, pg.pw_uid, pg.pw_gid)
    run = {"check": True, "capture_output": True, "text": True, "timeout": 120}
    try:
        initdb = [str(bindir / "initdb"), "-D", str(data), "-U", "nhsim", "--auth=trust"]
        subprocess.run(_as_server_user(initdb), **run)
        port = _start(bindir, data, sock, run)
        subprocess.run([str(bindir / "createdb"), "-h", "127.0.0.1", "-p", str(port), "-U", "nhsim", database], **run)
        yield Server(bindir, data, sock, port, database)
    finally:
        if (data / "postmaster.pid").exists():
            subprocess.run(_as_server_user([str(bindir / "pg_ctl"), "-D", str(data), "-m", "immediate", "stop"]),
                           capture_output=True, timeout=120)  # fmt: skip
        shutil.rmtree(folder, ignore_errors=True)
