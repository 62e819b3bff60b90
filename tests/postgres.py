"""
A throwaway PostgreSQL server on 127.0.0.1 for the distributed-study tests.

It runs Debian's PostgreSQL binaries (``initdb``, ``pg_ctl``; ``.ci/run`` installs the ``postgresql`` package
when they are missing), in a fresh data folder, on a free port, with password authentication, and is stopped
and removed afterwards. PostgreSQL refuses to run as root: as root, the server runs as the ``postgres`` system
user that the package creates.
"""

import contextlib
import glob
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

USER = "optuna"
PASSWORD = "optuna-test-password"
DATABASE = "optuna"


class ServerUnavailable(RuntimeError):
    """The server cannot be started here (no binaries, no user to run them as)."""


def _binaries() -> Path:
    found = shutil.which("pg_ctl")
    if found:
        return Path(found).parent
    candidates = sorted(glob.glob("/usr/lib/postgresql/*/bin/pg_ctl"), key=lambda p: int(Path(p).parts[-3]))
    if not candidates:
        raise ServerUnavailable("PostgreSQL is not installed (no pg_ctl): apt-get install postgresql")
    return Path(candidates[-1]).parent


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@dataclass
class PostgresServer:
    """A running server: ``url`` reaches its database as a password-authenticated user."""

    bin_dir: Path
    data_dir: Path
    port: int
    run_as: str | None

    @property
    def url(self) -> str:
        return f"postgresql+psycopg://{USER}:{PASSWORD}@127.0.0.1:{self.port}/{DATABASE}"

    def url_with(self, password: str | None = None, port: int | None = None) -> str:
        return f"postgresql+psycopg://{USER}:{password or PASSWORD}@127.0.0.1:{port or self.port}/{DATABASE}"

    def _run(self, *command: str) -> None:
        full = [str(self.bin_dir / command[0]), *command[1:]]
        if self.run_as is not None:
            full = ["runuser", "-u", self.run_as, "--", *full]
        done = subprocess.run(full, capture_output=True, text=True, timeout=120)
        if done.returncode != 0:
            raise ServerUnavailable(f"{' '.join(command[:2])} failed: {done.stdout}{done.stderr}")

    def start(self) -> None:
        options = f"-p {self.port} -c listen_addresses=127.0.0.1 -k {self.data_dir}"
        self._run(
            "pg_ctl", "-D", str(self.data_dir / "data"), "-o", options, "-l", str(self.data_dir / "server.log"), "-w", "start"
        )

    def stop(self, mode: str = "fast") -> None:
        self._run("pg_ctl", "-D", str(self.data_dir / "data"), "-m", mode, "-w", "stop")

    def restart(self) -> None:
        """Stop (closing every connection) and start again on the same port and data."""
        self.stop("fast")
        self.start()


@contextlib.contextmanager
def postgres_server() -> Iterator[PostgresServer]:
    """Start a server with an empty database ``DATABASE`` owned by ``USER``; stop and remove it on exit."""
    bin_dir = _binaries()
    run_as = None
    if os.geteuid() == 0:
        try:
            pwd.getpwnam("postgres")
        except KeyError:
            raise ServerUnavailable("running as root and there is no 'postgres' user to run the server as") from None
        run_as = "postgres"
    root = Path(tempfile.mkdtemp(prefix="sb3-reinforce-pg-", dir="/tmp"))
    try:
        root.chmod(0o755)
        password_file = root / "password"
        password_file.write_text(PASSWORD + "\n")
        if run_as is not None:
            shutil.chown(root, run_as)
            shutil.chown(password_file, run_as)
        server = PostgresServer(bin_dir, root, _free_port(), run_as)
        server._run(
            "initdb", "-D", str(root / "data"), "-U", USER, "--auth=scram-sha-256", f"--pwfile={password_file}", "-E", "UTF8"
        )
        server.start()
        try:
            import psycopg

            with psycopg.connect(server.url.replace("+psycopg", ""), dbname="postgres", autocommit=True) as connection:
                connection.execute(f"CREATE DATABASE {DATABASE}")
            yield server
        finally:
            with contextlib.suppress(ServerUnavailable):
                server.stop("immediate")
    finally:
        shutil.rmtree(root, ignore_errors=True)
