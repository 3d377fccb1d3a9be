"""The tests' own PostgreSQL server: Debian's ``postgresql`` binaries (``.ci/run`` installs them),
``initdb`` into a fresh directory of the system's temp dir, listening on a free loopback port,
its unix socket in that directory, stopped and removed at the end. No server of the machine is
used or touched.

``initdb`` and ``postgres`` refuse to run as root: as root they run as the ``postgres`` user
(made by the Debian package) through ``runuser``, and the directory is that user's.

Without the binaries or psycopg the tests that need them are skipped with the way to get them,
except under CI (``CI=true``), where they fail: CI must run them.
"""

from __future__ import annotations

import glob
import importlib.util
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest
from required import missing

HOW_TO_GET_IT = (
    "the PostgreSQL tests need PostgreSQL's server binaries (initdb, pg_ctl; Debian: "
    "`apt-get install postgresql`) and psycopg (`pip install -e '.[test]'`)."
)
START_TIMEOUT_S = 60
# The server's own account when the tests run as root.
SERVER_USER = "postgres"
ROLE = "zeromode"


def binaries() -> Path | None:
    """The directory of the newest installed ``initdb`` and ``pg_ctl`` (Debian keeps them under
    /usr/lib/postgresql/<major>/bin, off PATH), else the ones on PATH, else None."""
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"), key=lambda p: int(Path(p).parent.parent.name))
    if found:
        return Path(found[-1]).parent
    on_path = shutil.which("initdb")
    return Path(on_path).parent if on_path and shutil.which("pg_ctl") else None


def require_postgres() -> Path:
    """The binaries' directory; without them (or without psycopg) a skip, or a failure under CI."""
    bindir = binaries()
    if bindir is None or importlib.util.find_spec("psycopg") is None:
        missing("the PostgreSQL tests", HOW_TO_GET_IT)
    if os.geteuid() == 0 and (shutil.which("runuser") is None or _account() is None):
        missing("the PostgreSQL tests", f"as root they run the server as the `{SERVER_USER}` user "
                "(made by Debian's postgresql package) through runuser, and one of the two is missing.")
    return bindir


def _account() -> pwd.struct_passwd | None:
    try:
        return pwd.getpwnam(SERVER_USER)
    except KeyError:
        return None


@dataclass(frozen=True)
class Server:
    host: str
    port: int

    def url(self, database: str = "postgres") -> str:
        """The SQLAlchemy URL of ``database`` on this server (psycopg 3)."""
        return f"postgresql+psycopg://{ROLE}@{self.host}:{self.port}/{database}"

    def new_database(self, name: str | None = None) -> str:
        """The URL of a new, empty database of its own (``name``, else a fresh one)."""
        import psycopg

        name = name or f"zm_{uuid.uuid4().hex[:16]}"
        with psycopg.connect(host=self.host, port=self.port, user=ROLE, dbname="postgres", autocommit=True) as conn:
            conn.execute(f"CREATE DATABASE {name}")
        return self.url(name)


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@contextmanager
def postgres_server() -> Iterator[Server]:
    """A running server on 127.0.0.1 (role ``zeromode``, trusted, no password) for the block."""
    bindir = require_postgres()
    as_root = os.geteuid() == 0
    run_as = ["runuser", "-u", SERVER_USER, "--"] if as_root else []
    home = Path(tempfile.mkdtemp(prefix="zeromode-postgres-"))
    if as_root:
        account = _account()
        os.chown(home, account.pw_uid, account.pw_gid)
    data, log = home / "data", home / "server.log"
    port = _free_port()

    def run(*args: str) -> None:
        done = subprocess.run([*run_as, *args], capture_output=True, text=True, timeout=START_TIMEOUT_S, check=False)
        if done.returncode != 0:
            extra = log.read_text() if log.exists() else ""
            pytest.fail(f"{' '.join(args)} failed:\n{done.stdout}{done.stderr}{extra}")

    try:
        run(str(bindir / "initdb"), "-D", str(data), "-U", ROLE, "--auth=trust", "-E", "UTF8", "--no-locale",
            "--no-sync")
        # Loopback TCP only; the socket in the server's own directory, not /var/run/postgresql.
        # fsync off: what is tested is replicas dying, not this server (a throwaway database).
        options = f"-c listen_addresses=127.0.0.1 -p {port} -k {home} -c max_connections=200 -c fsync=off"
        run(str(bindir / "pg_ctl"), "-D", str(data), "-l", str(log), "-o", options, "-w", "-t",
            str(START_TIMEOUT_S), "start")
        try:
            yield Server("127.0.0.1", port)
        finally:
            subprocess.run([*run_as, str(bindir / "pg_ctl"), "-D", str(data), "-m", "fast", "-w", "stop"],
                           capture_output=True, timeout=START_TIMEOUT_S, check=False)
    finally:
        shutil.rmtree(home, ignore_errors=True)
