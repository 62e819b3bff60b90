"""
Dask ``distributed`` backend of ``sb3-reinforce compare`` and ``sb3-reinforce seed``: a ``LocalCluster`` on 127.0.0.1
(default, one worker process per ``--workers``) or a running cluster (``--scheduler tcp://HOST:PORT`` or ``tls://...``).
No filesystem is shared: a run's files come back through the scheduler (:meth:`RunChannel.send`) and a restarted run
gets them first. A run whose worker dies is restarted (``distributed.scheduler.allowed-failures``), one that raises is
retried :data:`RUN_RETRIES` times; Ctrl-C or SIGTERM stops the runs within a second, their last checkpoint kept.
"""

import contextlib
import logging
import os
import shutil
import signal
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import dask
from distributed import (
    Client,
    Event,
    LocalCluster,
    Nanny,
    NannyPlugin,
    Queue,
    Variable,
    Worker,
    WorkerPlugin,
    get_worker,
    wait,
)

__all__ = [
    "CONNECT_TIMEOUT_S",
    "RUN_RETRIES",
    "ClusterError",
    "Job",
    "LendThreadsAsCPUs",
    "RunChannel",
    "RunStopped",
    "StartWorkersForRuns",
    "open_client",
    "run_jobs",
    "sigterm_as_interrupt",
    "worker_versions",
]

#: Seconds to reach ``--scheduler`` before giving up.
CONNECT_TIMEOUT_S = 10
#: Retries of a run whose code raised an error (a worker that died is the scheduler's ``allowed-failures``).
RUN_RETRIES = 2
#: Seconds between two looks of a running run at the stop flag.
STOP_CHECK_S = 1.0
#: The packages a worker must have in the versions the command has (a run built with others would not be the same).
CHECKED_PACKAGES = ("sb3_reinforce", "stable_baselines3", "rl_zoo3", "gymnasium")
#: A worker's resource: the CPUs it lends to runs (``dask worker --resources CPU=N``).
CPU_RESOURCE = "CPU"


class ClusterError(Exception):
    """The cluster cannot run the comparison (unreachable, TLS refused, a worker unfit): a one-line message."""


class RunStopped(Exception):
    """Raised in a running run when the command was stopped."""


class IgnoreInterrupt(WorkerPlugin):
    """
    Make nanny-started worker processes ignore SIGINT, left to their parent (the command, or the nanny): otherwise the
    nanny kills a worker closing itself after 8 s (distributed 2026.8.0). ``--no-nanny`` workers keep Dask's handling.
    """

    def setup(self, worker: Worker) -> None:
        """
        Ignore SIGINT in the worker process (set up in its main thread).

        :param worker: The worker
        """
        if worker.nanny is not None:
            signal.signal(signal.SIGINT, signal.SIG_IGN)


class LendThreadsAsCPUs(WorkerPlugin):
    """Lend a worker's threads as ``CPU`` where it declares none (``--resources CPU=N`` keeps N); reaches later workers."""

    async def setup(self, worker: Worker) -> None:
        """
        Declare ``CPU`` = the worker's threads, unless it declares its own.

        :param worker: The worker
        """
        if CPU_RESOURCE not in worker.state.total_resources:
            await worker.set_resources(**{CPU_RESOURCE: worker.state.nthreads})


def _interrupt_once(signum: int, frame: object) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    raise KeyboardInterrupt


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Inside, SIGTERM acts as Ctrl-C (``KeyboardInterrupt``); repeats are then ignored so the shutdown is not cut short."""
    previous = signal.signal(signal.SIGTERM, _interrupt_once)
    stopping = False
    try:
        yield
    except KeyboardInterrupt:
        stopping = True
        raise
    finally:
        if not stopping:
            signal.signal(signal.SIGTERM, previous)


#: Set to 65536 by Dask's nanny (``distributed.nanny.pre-spawn-environ``); any value turns off glibc's dynamic mmap
#: threshold, and CarRacing's training runs 2x slower (``benchmarks/results/malloc_trim.csv``).
MALLOC_TRIM = "MALLOC_TRIM_THRESHOLD_"


class StartWorkersForRuns(NannyPlugin):
    """
    Have a nanny start its worker process as runs need it, whatever the worker's Dask configuration: not daemonic
    (``--vec-env subproc`` starts processes there) and without :data:`MALLOC_TRIM`. A running worker process started
    otherwise is restarted once; the nanny reads ``restart`` after ``setup`` (distributed 2026.8).
    """

    restart = False

    def setup(self, nanny: Nanny) -> None:
        """
        Change the nanny's settings for its next worker process; restart the running one if they were not so.

        :param nanny: The nanny
        """
        started_otherwise = bool(dask.config.get("distributed.worker.daemon", default=True)) or any(
            MALLOC_TRIM in environ for environ in (nanny.pre_spawn_env, nanny.env, os.environ)
        )
        dask.config.set({"distributed.worker.daemon": False})  # in the nanny's process, read at each start
        for environ in (nanny.pre_spawn_env, nanny.env, os.environ):  # the nanny's copies (the last: set at a start)
            environ.pop(MALLOC_TRIM, None)
        self.restart = started_otherwise and nanny.process is not None


@contextlib.contextmanager
def open_client(scheduler: str | None, n_workers: int, worker_cpus: int, dashboard: str | None = None) -> Iterator[Client]:
    """
    A client of a ``LocalCluster`` on 127.0.0.1 started (and closed) here, or of the cluster at ``scheduler``.

    :param scheduler: ``tcp://HOST:PORT`` or ``tls://HOST:PORT`` (TLS: ``distributed.comm.tls``), None: local
    :param n_workers: The local cluster's worker processes (one run each at a time)
    :param worker_cpus: The ``CPU`` resource of each local worker
    :param dashboard: The local cluster's dashboard address (None: no dashboard)
    :return: The client
    :raises ClusterError: if ``scheduler`` cannot be reached
    """
    if scheduler is None:
        with (
            dask.config.set(
                {
                    # --vec-env subproc starts processes in the worker
                    "distributed.worker.daemon": False,
                    # None unsets Dask's MALLOC_TRIM_THRESHOLD_=65536 (see MALLOC_TRIM), as Dask documents
                    f"distributed.nanny.pre-spawn-environ.{MALLOC_TRIM}": None,
                }
            ),
            LocalCluster(
                host="127.0.0.1",
                n_workers=n_workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=dashboard,
                # Scheduler HTTP runs without a dashboard too: a free port, not 8787, so commands can share a machine
                scheduler_kwargs={"dashboard_address": dashboard or "127.0.0.1:0"},
                resources={CPU_RESOURCE: worker_cpus},
                silence_logs=logging.ERROR,
            ) as cluster,
            Client(cluster, set_as_default=True) as client,
        ):
            client.register_plugin(IgnoreInterrupt())
            yield client
        return
    try:
        client = Client(scheduler, timeout=CONNECT_TIMEOUT_S, set_as_default=True)
    except (OSError, TypeError, ValueError) as error:  # refused, timed out, no TLS settings for tls://
        reason = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise ClusterError(f"cannot connect to the scheduler at {scheduler}: {reason}") from None
    with client:
        yield client


def worker_versions() -> dict[str, str | None]:
    """
    On a worker: the versions of :data:`CHECKED_PACKAGES` it imports (None: not installed). Not
    ``Client.get_versions``, which reads installed metadata and only warns (distributed 2026.8).

    :return: Package -> version
    """
    import importlib

    versions: dict[str, str | None] = {}
    for package in CHECKED_PACKAGES:
        try:
            versions[package] = str(importlib.import_module(package).__version__)
        except ImportError:
            versions[package] = None
    return versions


def check_workers(client: Client, cpus: int, scheduler: str) -> None:
    """
    Refuse a cluster without a fit worker (none, other package versions, too few CPUs), then set the workers up for runs.

    :param client: The cluster's client
    :param cpus: The CPUs the largest run asks for
    :param scheduler: The scheduler's address, for the messages
    :raises ClusterError: naming the worker and what differs
    """
    workers = client.scheduler_info(n_workers=-1)["workers"]
    if not workers:
        raise ClusterError(f"the scheduler at {scheduler} has no worker: start one with `dask worker {scheduler}`")
    ours = worker_versions()
    # A worker without the package cannot unpickle worker_versions: that error is its answer
    answers = client.run(worker_versions, on_error="return")
    for address, answer in sorted(answers.items()):
        name = f"{workers.get(address, {}).get('name', address)} ({address}) of {scheduler}"
        if isinstance(answer, BaseException):
            raise ClusterError(f"worker {name} cannot run sb3-reinforce: {type(answer).__name__}: {answer}")
        differ = [f"{pkg} {answer.get(pkg)} (here {version})" for pkg, version in ours.items() if answer.get(pkg) != version]
        if differ:
            raise ClusterError(f"worker {name} has other versions: {', '.join(differ)}")
    # Every worker has the package now, so it can unpickle the plugins (which reach later workers too)
    client.register_plugin(StartWorkersForRuns())
    client.register_plugin(LendThreadsAsCPUs())
    client.register_plugin(IgnoreInterrupt())
    workers = client.scheduler_info(n_workers=-1)["workers"]
    most = max(float(info.get("resources", {}).get(CPU_RESOURCE, 0)) for info in workers.values())
    if most < cpus:
        raise ClusterError(
            f"no worker of {scheduler} lends {cpus} CPU(s) (the most: {most:g}): start a worker with "
            f"`dask worker {scheduler} --nthreads {cpus}` (its threads are the CPUs it lends) or "
            f"`--resources {CPU_RESOURCE}={cpus}`"
        )


class RunChannel:
    """
    A run's link to the command, on its worker: its folder, its files sent back, the stop flag.

    :param token: The command's token (names its queue, variables and stop flag on the scheduler)
    :param name: The run's name
    :param pattern: The glob of the run's files in its folder (relative to it)
    """

    def __init__(self, token: str, name: str, pattern: str) -> None:
        self.name = name
        self.pattern = pattern
        self.folder = Path(get_worker().local_directory) / f"sb3-reinforce-{token}" / name
        self._files = Variable(_variable_name(token, name))
        self._messages = Queue(_queue_name(token))
        self._stop = Event(_stop_name(token))
        self._next_check = 0.0

    def restore(self) -> None:
        """Write the files last sent back (a checkpoint to resume from) into a fresh folder."""
        shutil.rmtree(self.folder, ignore_errors=True)  # what a run that died here left
        self.folder.mkdir(parents=True)
        for relative, data in self._files.get(timeout=60).items():
            path = self.folder / relative
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)

    def files(self) -> dict[str, bytes]:
        """The run's files in its folder, by path relative to it (those being written, ``*.tmp``, left out)."""
        return {
            path.relative_to(self.folder).as_posix(): path.read_bytes()
            for path in sorted(self.folder.glob(self.pattern))
            if ".tmp" not in path.name
        }

    def send(self, steps: int) -> None:
        """
        Send the run's files back to the command, and keep them for a restart of the run.

        :param steps: The environment steps done so far (the command's progress bar)
        """
        files = self.files()
        self._files.set(files)
        self._messages.put([self.name, steps, files])

    def check_stop(self) -> None:
        """Raise :class:`RunStopped` if the command was stopped (looked up once per :data:`STOP_CHECK_S`)."""
        now = time.monotonic()
        if now < self._next_check:
            return
        self._next_check = now + STOP_CHECK_S
        if self._stop.is_set():
            raise RunStopped(self.name)


def _workers(client: Client) -> dict[str, dict[str, Any]]:
    """The cluster's workers, as the scheduler knows them now (all of them, not the first five)."""
    return dict(client.scheduler_info(n_workers=-1)["workers"])


def _variable_name(token: str, name: str) -> str:
    return f"sb3-reinforce-{token}-files-{name}"


def _queue_name(token: str) -> str:
    return f"sb3-reinforce-{token}-messages"


def _stop_name(token: str) -> str:
    return f"sb3-reinforce-{token}-stop"


@dataclass
class Job:
    """
    One run to submit.

    :param name: Its name (unique in the command)
    :param fn: Called on a worker as ``fn(channel, *args)`` in ``channel.folder``; its result comes back with the files
    :param args: The arguments after the channel
    :param cpus: The CPUs it keeps busy (the ``CPU`` resource it asks for)
    :param pattern: The glob of the run's files in its folder (sent back, and sent to a run that starts again)
    :param files: The files it starts with (a checkpoint to resume from), by name
    """

    name: str
    fn: Callable[..., Any]
    args: tuple[Any, ...]
    cpus: int
    pattern: str
    files: dict[str, bytes] = field(default_factory=dict)


@dataclass
class JobResult:
    """
    A finished run.

    :param value: What the job's function returned
    :param files: The run's files at its end
    :param worker: The name of the worker it ended on
    """

    value: Any
    files: dict[str, bytes]
    worker: str


def _execute(job: Job, token: str) -> JobResult | None:
    """On a worker: run ``job`` in its folder (its files restored first); None if the command was stopped."""
    channel = RunChannel(token, job.name, job.pattern)
    channel.restore()
    try:
        value = job.fn(channel, *job.args)
    except RunStopped:
        return None
    result = JobResult(value, channel.files(), str(get_worker().name))
    shutil.rmtree(channel.folder)
    return result


class _Submissions:
    """
    The runs of one :func:`run_jobs` call: those waiting, in the given (seed-major) order, and those submitted.

    Dask assigns a task that asks for resources to a worker when it is submitted (its scheduler-side queuing skips such
    tasks: distributed 2026.8.0), so submitting every run at once left workers idle at the end while runs queued on
    busy ones. Runs are therefore submitted one at a time, each once the cluster's CPUs have room for it.
    """

    def __init__(self, client: Client, jobs: Sequence[Job], token: str) -> None:
        self.client = client
        self.token = token
        self.waiting = list(jobs)
        self.cpus = {job.name: job.cpus for job in jobs}
        self.names: dict[Any, str] = {}  # future -> run name
        self.pending: set[Any] = set()

    def submit_what_fits(self) -> None:
        """Submit the next waiting runs while the cluster's lent CPUs have room for them (always one, if none runs)."""
        if not self.waiting:
            return
        lent = sum(float(info.get("resources", {}).get(CPU_RESOURCE, 0)) for info in _workers(self.client).values())
        busy = sum(self.cpus[self.names[future]] for future in self.pending)
        while self.waiting and (not self.pending or busy + self.waiting[0].cpus <= lent):
            job = self.waiting.pop(0)
            future = self.client.submit(
                _execute,
                replace(job, files={}),  # they travel in its Variable (not twice, nor in the task graph)
                self.token,
                key=f"{job.name}-{self.token}",
                resources={CPU_RESOURCE: job.cpus},
                retries=RUN_RETRIES,
                pure=False,
            )
            self.names[future] = job.name
            self.pending.add(future)
            busy += job.cpus

    def done(self) -> list[tuple[str, Any]]:
        """The runs that ended since the last call: (name, future)."""
        ended = [future for future in self.pending if future.done()]
        self.pending.difference_update(ended)
        return [(self.names[future], future) for future in ended]


def _failure(error: BaseException) -> str:
    """A failed run's one-line reason."""
    return f"{type(error).__name__}: {str(error).strip().splitlines()[0] if str(error) else ''}"


def run_jobs(
    client: Client,
    jobs: Sequence[Job],
    on_files: Callable[[str, int, dict[str, bytes]], None],
    on_result: Callable[[str, JobResult], None],
) -> dict[str, str]:
    """
    Run ``jobs`` on the cluster and hand their files to the command as they come.

    :param client: The cluster's client
    :param jobs: The runs
    :param on_files: Called with a run's name, steps and files each time a running run sends them
    :param on_result: Called once per finished run
    :return: The runs that failed (a worker died too often, or their code raised): name -> one-line reason
    :raises KeyboardInterrupt: if the command is stopped; the runs are stopped first (their last files kept)
    """
    token = uuid.uuid4().hex[:12]
    variables = [Variable(_variable_name(token, job.name), client=client) for job in jobs]
    for variable, job in zip(variables, jobs, strict=True):
        variable.set(job.files)
    messages = Queue(_queue_name(token), client=client)
    stop = Event(_stop_name(token), client=client)
    submissions = _Submissions(client, jobs, token)
    failures: dict[str, str] = {}
    finished: set[str] = set()
    try:
        submissions.submit_what_fits()
        while submissions.pending:
            with contextlib.suppress(TimeoutError):
                wait(list(submissions.pending), timeout=0.5, return_when="FIRST_COMPLETED")
            for name, steps, files in messages.get(batch=True):
                if name not in finished:  # a finished run's files are its result's
                    on_files(name, int(steps), files)
            for name, future in submissions.done():
                finished.add(name)
                if future.status == "error":
                    failures[name] = _failure(future.exception())
                elif (result := future.result()) is not None:  # None: stopped (by another command of this token)
                    on_result(name, result)
            submissions.submit_what_fits()
    except BaseException:
        stop.set()  # running runs stop within STOP_CHECK_S, their last files already sent
        with contextlib.suppress(Exception):
            wait(list(submissions.pending), timeout=5 * STOP_CHECK_S + 5)
        client.cancel(list(submissions.pending))
        raise
    finally:
        for variable in variables:
            variable.delete()
        messages.close()
    return failures
