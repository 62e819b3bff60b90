"""
``sb3-reinforce compare --scheduler``: a comparison on a Dask cluster started by the test (``dask scheduler`` and two
``dask worker`` processes, each in a folder of its own, on 127.0.0.1 only), no filesystem shared with the command:
each run's files come back into ``--out`` through the scheduler.
"""

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd
import psutil
import pytest
from distributed import Client

from sb3_reinforce.lab.compare.folder import PER_RUN_DIR, RESULT_COLUMNS

REPO = Path(__file__).resolve().parents[2]
DASK = str(Path(sys.executable).parent / "dask")
#: A tiny comparison: CartPole, a few thousand steps, evaluated every 1,000
TINY = ["--env", "CartPole-v1", "--eval-episodes", "2", "--no-progress"]
#: Their HTTP servers (health, metrics) listen on every interface unless told otherwise, dashboard or not
LOCAL_HTTP = ["--no-dashboard", "--dashboard-address", "127.0.0.1:0"]


@dataclass
class Cluster:
    """A scheduler and its workers, started by a test: each a process group of its own."""

    address: str
    scheduler: subprocess.Popen
    workers: dict[str, subprocess.Popen]
    tls_args: list[str]


def _environment() -> dict[str, str]:
    # The workers import this checkout's package, as the command does
    return dict(os.environ, PYTHONPATH=str(REPO), OMP_NUM_THREADS="1")


def _stop(process: subprocess.Popen) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGKILL)
    process.wait(timeout=30)


@contextlib.contextmanager
def dask_cluster(
    folder: Path, tls_args: list[str] | None = None, worker_args: tuple[str, ...] = ("--nthreads", "1", "--resources", "CPU=1")
) -> Iterator[Cluster]:
    """
    ``dask scheduler`` on 127.0.0.1 and two ``dask worker`` processes (w1, w2), each in its own folder, with
    ``worker_args`` (default: one thread, lending one CPU).
    """
    tls_args = tls_args or []
    scheduler_file = folder / "scheduler.json"
    (folder / "scheduler").mkdir()
    protocol = ["--protocol", "tls"] if tls_args else []
    command = [DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", *LOCAL_HTTP, *protocol, *tls_args]
    scheduler = subprocess.Popen(
        [*command, "--scheduler-file", str(scheduler_file)],
        cwd=folder / "scheduler",
        env=_environment(),
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    workers: dict[str, subprocess.Popen] = {}
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists():
            assert time.monotonic() < deadline and scheduler.poll() is None, "the scheduler did not start"
            time.sleep(0.2)
        time.sleep(0.5)  # written whole
        address = json.loads(scheduler_file.read_text())["address"]
        assert address.split("://")[1].startswith("127.0.0.1:"), address
        worker_env = _environment()  # Dask's defaults: daemonic worker processes with MALLOC_TRIM_THRESHOLD_=65536
        for name in ("w1", "w2"):
            (folder / name).mkdir()
            command = [DASK, "worker", address, "--host", "127.0.0.1", "--nworkers", "1", *worker_args]
            command += ["--name", name, *LOCAL_HTTP, "--local-directory", str(folder / name)]
            with (folder / f"{name}.log").open("w") as log:  # the worker's log (Dask logs to stderr)
                workers[name] = subprocess.Popen(
                    [*command, *tls_args],
                    cwd=folder / name,
                    env=worker_env,
                    start_new_session=True,
                    stdout=subprocess.DEVNULL,
                    stderr=log,
                )
        yield Cluster(address, scheduler, workers, tls_args)
    finally:
        for process in [*workers.values(), scheduler]:
            _stop(process)


def _process_settings() -> tuple[str | None, bool]:
    """On a worker: its process's MALLOC_TRIM_THRESHOLD_ and whether it is daemonic."""
    import multiprocessing

    return os.environ.get("MALLOC_TRIM_THRESHOLD_"), multiprocessing.current_process().daemon


def _wait_for_workers(cluster: Cluster, security: object = None) -> None:
    with Client(cluster.address, security=security, timeout=30, set_as_default=False) as client:
        client.wait_for_workers(2, timeout=120)


def _compare(
    out: Path, scheduler: str, *args: str, env: dict[str, str] | None = None, stderr: int = subprocess.STDOUT
) -> subprocess.Popen:
    command = [sys.executable, "-m", "sb3_reinforce.lab.compare", *TINY, "--out", str(out), "--scheduler", scheduler, *args]
    return subprocess.Popen(
        command, cwd=out.parent, env=env or _environment(), stdout=subprocess.PIPE, stderr=stderr, text=True
    )


def _refused(out: Path, scheduler: str) -> str:
    """Run a compare that must be refused: exit 2 and one line on stderr naming the scheduler; return that line."""
    compare = _compare(out, scheduler, "--algos", "reinforce", "--seeds", "1", "--budget", "2000", stderr=subprocess.PIPE)
    _, errors = compare.communicate(timeout=180)  # a hang guard only: a loaded CI machine imports slowly
    assert compare.returncode == 2, errors
    lines = errors.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("sb3-reinforce compare: error: ") and scheduler in lines[0], errors
    assert not list((out / PER_RUN_DIR).glob("*.csv")), "nothing trained"
    return lines[0]


def _check_every_row(out: Path, names: list[str]) -> list[dict]:
    summaries = [json.loads((out / PER_RUN_DIR / f"{name}.json").read_text()) for name in names]
    results = pd.read_csv(out / "results.csv")
    assert list(results.columns) == RESULT_COLUMNS
    for name in names:
        algo, seed = name.split("_seed")
        run = results[(results["algo"] == algo) & (results["seed"] == int(seed))]
        assert list(run["eval_index"]) == list(range(len(run))) and run["steps"].iloc[-1] >= run["steps"].max()
    assert not list((out / PER_RUN_DIR).glob("*.checkpoint*")), "a finished run leaves no checkpoint"
    return summaries


def assert_localhost_only(pids: list[int]) -> None:
    """Every socket of these processes and of those below them listens and connects on 127.0.0.1 only."""
    for pid in pids:
        with contextlib.suppress(psutil.NoSuchProcess):
            for process in [psutil.Process(pid), *psutil.Process(pid).children(recursive=True)]:
                for connection in process.net_connections(kind="inet"):
                    assert connection.laddr.ip == "127.0.0.1", connection
                    assert not connection.raddr or connection.raddr.ip == "127.0.0.1", connection


def test_compare_on_a_cluster_uses_both_workers(tmp_path: Path) -> None:
    with dask_cluster(tmp_path) as cluster:
        _wait_for_workers(cluster)
        out = tmp_path / "out"
        with Client(cluster.address, timeout=30, set_as_default=False) as client:
            before = set(client.run(_process_settings).values())
        compare = _compare(out, cluster.address, "--algos", "reinforce,ppo", "--seeds", "2", "--budget", "2000")
        assert_localhost_only([cluster.scheduler.pid, *(w.pid for w in cluster.workers.values())])
        output, _ = compare.communicate(timeout=600)
        assert compare.returncode == 0, output
        with Client(cluster.address, timeout=30, set_as_default=False) as client:
            after = set(client.run(_process_settings).values())
    # Workers started as Dask documents them: the command restarted their processes as runs need them (2x slower
    # CarRacing training with Dask's MALLOC_TRIM_THRESHOLD_; --vec-env subproc needs a process that is not daemonic)
    assert before == {("65536", True)} and after == {(None, False)}, (before, after)
    names = ["reinforce_seed0", "ppo_seed0", "reinforce_seed1", "ppo_seed1"]
    summaries = _check_every_row(out, names)
    # Each run's JSON names its worker: both ran at least one, in folders of their own (none is --out)
    assert {summary["worker"] for summary in summaries} == {"w1", "w2"}
    assert (out / "summary.md").exists() and (out / "learning_curve.png").exists()


def test_workers_started_as_dask_documents_lend_their_threads(tmp_path: Path) -> None:
    # `dask worker ADDRESS` without --resources (its default threads: one per core): each lends its threads as CPUs;
    # and without any setting of Dask's for the runs' environment processes (--vec-env subproc)
    with dask_cluster(tmp_path, worker_args=()) as cluster:
        _wait_for_workers(cluster)
        out = tmp_path / "out"
        args = ["--algos", "reinforce", "--seeds", "2", "--budget", "2000", "--vec-env", "subproc"]
        compare = _compare(out, cluster.address, *args)
        output, _ = compare.communicate(timeout=600)
        assert compare.returncode == 0, output
        with Client(cluster.address, timeout=30, set_as_default=False) as client:
            workers = client.scheduler_info(n_workers=-1)["workers"].values()
            lent = {info["name"]: (info["resources"].get("CPU"), info["nthreads"]) for info in workers}
        # Ctrl-C on a worker that has trained (SIGINT to its process group, as a terminal sends it): it stops
        # cleanly, before its nanny's 8 s limit ("Worker process still alive after 8.0 seconds, killing"). The nanny's
        # log decides, not a clock of ours: ours also counts the nanny's own shutdown (8.08 s once on a loaded
        # machine, the worker having stopped by itself).
        stopped_at = time.monotonic()
        os.killpg(cluster.workers["w1"].pid, signal.SIGINT)
        cluster.workers["w1"].wait(timeout=60)
        seconds = time.monotonic() - stopped_at
        log = (tmp_path / "w1.log").read_text()
    assert lent == {"w1": (os.cpu_count(), os.cpu_count()), "w2": (os.cpu_count(), os.cpu_count())}, lent
    _check_every_row(out, ["reinforce_seed0", "reinforce_seed1"])
    assert cluster.workers["w1"].returncode == 0, (seconds, log)
    assert "killing" not in log and "Traceback" not in log, (seconds, log)


def _worker_process(nanny: subprocess.Popen) -> psutil.Process:
    """The worker process a ``dask worker`` (its nanny) started."""
    deadline = time.monotonic() + 60
    while True:
        children = psutil.Process(nanny.pid).children()
        workers = [p for p in children if "spawn_main" in " ".join(p.cmdline()) or "dask" in p.name()]
        if workers:
            return workers[0]
        assert time.monotonic() < deadline, "no worker process"
        time.sleep(0.2)


def test_killed_worker_resumes_its_run_and_a_lost_one_hands_its_runs_over(tmp_path: Path) -> None:
    with dask_cluster(tmp_path) as cluster:
        _wait_for_workers(cluster)
        out = tmp_path / "out"
        args = ["--algos", "reinforce", "--seeds", "2", "--budget", "30000", "--eval-freq", "2000"]
        compare = _compare(out, cluster.address, *args)
        try:
            # Both runs are training (one per worker) and have sent a checkpoint back to --out
            deadline = time.monotonic() + 300
            while len(list((out / PER_RUN_DIR).glob("*.checkpoint.json"))) < 2:
                assert compare.poll() is None, compare.stdout.read() if compare.stdout else ""
                assert time.monotonic() < deadline, "no checkpoints after 300 s"
                time.sleep(0.2)
            # w1's worker process killed mid-run (its nanny starts another); w2 lost for good, nanny and all
            _worker_process(cluster.workers["w1"]).kill()
            _stop(cluster.workers["w2"])
            output, _ = compare.communicate(timeout=600)
        finally:
            compare.kill()
        assert compare.returncode == 0, output
    summaries = _check_every_row(out, ["reinforce_seed0", "reinforce_seed1"])
    # Both runs went on from a checkpoint, and both finished on w1, the worker left
    assert all(summary["resumed_at_steps"][0] > 0 for summary in summaries), summaries
    assert {summary["worker"] for summary in summaries} == {"w1"}


SAN = ["-addext", "subjectAltName=IP:127.0.0.1"]


def _self_signed_certificate(folder: Path) -> tuple[Path, Path]:
    """A certificate for 127.0.0.1 and its key, made here with the openssl command."""
    cert, key = folder / "cert.pem", folder / "key.pem"
    command = ["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1", "-subj", "/CN=127.0.0.1", *SAN]
    subprocess.run(
        [*command, "-keyout", str(key), "-out", str(cert)],
        check=True,
        capture_output=True,
    )
    return cert, key


def test_compare_over_tls_and_a_client_without_the_certificate(tmp_path: Path) -> None:
    from distributed.security import Security

    cert, key = _self_signed_certificate(tmp_path)
    tls_args = ["--tls-ca-file", str(cert), "--tls-cert", str(cert), "--tls-key", str(key)]
    with dask_cluster(tmp_path, tls_args) as cluster:
        assert cluster.address.startswith("tls://127.0.0.1:"), cluster.address
        security = Security(tls_ca_file=str(cert), tls_client_cert=str(cert), tls_client_key=str(key), require_encryption=True)
        _wait_for_workers(cluster, security)
        # The command reads its TLS files from Dask's configuration (here its environment variables)
        env = _environment()
        env.update(
            DASK_DISTRIBUTED__COMM__TLS__CA_FILE=str(cert),
            DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT=str(cert),
            DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY=str(key),
        )
        out = tmp_path / "out"
        compare = _compare(out, cluster.address, "--algos", "reinforce", "--seeds", "2", "--budget", "2000", env=env)
        output, _ = compare.communicate(timeout=600)
        assert compare.returncode == 0, output
        _check_every_row(out, ["reinforce_seed0", "reinforce_seed1"])
        # Without the certificate: one line naming the address, exit 2, before any training
        _refused(tmp_path / "other", cluster.address)


def _free_port() -> int:
    with socket.socket() as listening:
        listening.bind(("127.0.0.1", 0))
        return int(listening.getsockname()[1])


@pytest.mark.parametrize("protocol", ["tcp", "tls"])
def test_unreachable_scheduler_is_one_line(tmp_path: Path, protocol: str) -> None:
    _refused(tmp_path / "out", f"{protocol}://127.0.0.1:{_free_port()}")  # nothing listens there


def test_a_worker_with_another_package_is_named(tmp_path: Path) -> None:
    # A third worker imports another sb3_reinforce (an old release, 0.0.1): the command names it before any training
    other = tmp_path / "other_release"
    (other / "sb3_reinforce").mkdir(parents=True)
    (other / "sb3_reinforce" / "__init__.py").write_text('__version__ = "0.0.1"\n')
    with dask_cluster(tmp_path) as cluster:
        (tmp_path / "w3").mkdir()
        command = [DASK, "worker", cluster.address, "--host", "127.0.0.1", "--nworkers", "1", "--nthreads", "1"]
        command += ["--name", "w3-other-release", *LOCAL_HTTP, "--local-directory", str(tmp_path / "w3")]
        third = subprocess.Popen(
            command,
            cwd=tmp_path / "w3",
            env=dict(_environment(), PYTHONPATH=str(other)),
            start_new_session=True,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        try:
            with Client(cluster.address, timeout=30, set_as_default=False) as client:
                client.wait_for_workers(3, timeout=120)
            line = _refused(tmp_path / "out", cluster.address)
        finally:
            _stop(third)
    assert "worker w3-other-release" in line and "has other versions: sb3_reinforce 0.0.1 (here " in line, line


def test_the_local_cluster_starts_its_workers_for_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    # The command's own cluster: not Dask's MALLOC_TRIM_THRESHOLD_=65536 (2x slower CarRacing training), not daemonic
    from sb3_reinforce.lab.cluster import open_client

    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "")  # as in a fresh command: not left here by another test's nanny
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_")
    with open_client(None, 1, 1) as client:
        assert set(client.run(_process_settings).values()) == {(None, False)}


def test_two_local_clusters_at_once_share_no_port() -> None:
    # Two commands at once on one machine: neither cluster's scheduler takes Dask's default HTTP port 8787 (the
    # second would warn that it is in use), and both listen on 127.0.0.1 only
    import warnings

    from sb3_reinforce.lab.cluster import open_client

    with warnings.catch_warnings(record=True) as caught, open_client(None, 1, 1), open_client(None, 1, 1):
        warnings.simplefilter("always")
        assert_localhost_only([os.getpid()])
        ports = {c.laddr.port for c in psutil.Process().net_connections(kind="inet") if c.status == psutil.CONN_LISTEN}
    assert 8787 not in ports, ports
    assert not [w for w in caught if "already in use" in str(w.message)], [str(w.message) for w in caught]


def test_a_resumed_runs_checkpoint_is_not_in_the_task_graph() -> None:
    # A run's files (its checkpoint: 10 MB for CarRacing) reach its worker through a Variable; the task itself does
    # not carry them too (Dask warned of a large graph on each resumed CarRacing run)
    import warnings

    from sb3_reinforce.lab.cluster import Job, JobResult, open_client, run_jobs

    def restored_size(channel: Any) -> tuple[int, bytes]:  # on the worker, in the run's folder
        data = (channel.folder / "run.checkpoint.zip").read_bytes()
        return len(data), data[:4]

    checkpoint = b"PK\x03\x04" + os.urandom(12 * 2**20)  # over Dask's 10 MB large-graph-warning-threshold
    results: dict[str, JobResult] = {}
    with warnings.catch_warnings(record=True) as caught, open_client(None, 1, 1) as client:
        warnings.simplefilter("always")
        job = Job("run", restored_size, (), 1, "run.*", {"run.checkpoint.zip": checkpoint})
        failures = run_jobs(client, [job], lambda *_: None, lambda name, result: results.update({name: result}))
    assert failures == {}
    assert results["run"].value == (len(checkpoint), b"PK\x03\x04")
    assert not [w for w in caught if "large graph" in str(w.message)], [str(w.message) for w in caught]


def _sleep(channel: Any, seconds: float) -> float:  # a run, on its worker: when it started
    started = time.time()
    time.sleep(seconds)
    return started


def test_runs_are_submitted_as_cpus_free_up() -> None:
    # One long run and four short ones on two workers of one CPU each: the short ones all go to the worker that is free,
    # one after another, as a pool would run them. Submitted all at once, Dask shared them out up front (a task with
    # resources skips its queue), and the worker of the long run had short runs left when the other was done.
    from sb3_reinforce.lab.cluster import Job, JobResult, open_client, run_jobs

    results: dict[str, JobResult] = {}
    jobs = [Job("long", _sleep, (4.0,), 1, "none"), *(Job(f"short{i}", _sleep, (0.5,), 1, "none") for i in range(4))]
    with open_client(None, 2, 1) as client:
        client.wait_for_workers(2, timeout=60)
        failures = run_jobs(client, jobs, lambda *_: None, lambda name, result: results.update({name: result}))
    assert failures == {}
    short_workers = {results[f"short{i}"].worker for i in range(4)}
    assert len(short_workers) == 1 and results["long"].worker not in short_workers, results
    starts = [results[f"short{i}"].value for i in range(4)]
    assert starts == sorted(starts)  # in the given order
