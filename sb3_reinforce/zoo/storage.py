"""
Optuna storages for studies shared by several workers (``--storage postgresql://...``, or any other database
URL SQLAlchemy knows), set up to survive the faults of a real cluster.

- **A killed worker loses nothing.** Every running trial records a heartbeat every ``heartbeat_interval``
  seconds. A trial whose heartbeat is older than ``grace_period`` is marked ``FAIL`` by the next worker that
  looks, and :class:`optuna.storages.RetryFailedTrialCallback` enqueues a copy of it (same hyperparameters,
  at most ``max_retry`` times), which the next free worker runs.
- **A dropped connection is survived.** Connections are checked before use (SQLAlchemy's ``pool_pre_ping``),
  so a worker reconnects after the server restarts. A heartbeat that cannot be written while the server is
  down is skipped, not fatal.
- **Bad input is one clear line**: an invalid URL, a missing driver (naming the extra to install), a server
  that cannot be reached or refuses the credentials.
"""

import time
import warnings
from dataclasses import dataclass
from typing import Any

import optuna
import sqlalchemy
import sqlalchemy.exc
from optuna.storages import RDBStorage

# Optuna >= 4.9 names the retry of heartbeat-stale trials on its own; older versions call it the failed-trial callback.
_RetryCallback: Any = getattr(optuna.storages, "RetryHeartbeatStaleTrialCallback", None)
_RETRY_ARGUMENT = "heartbeat_stale_trial_callback"
if _RetryCallback is None:  # pragma: no cover (Optuna < 4.9)
    _RetryCallback = optuna.storages.RetryFailedTrialCallback
    _RETRY_ARGUMENT = "failed_trial_callback"

__all__ = [
    "DATABASE_ERRORS",
    "FaultTolerance",
    "StorageError",
    "caused_by_database",
    "check_direction",
    "is_database_url",
    "open_database_storage",
    "redact",
    "retried_trial_number",
    "retry_failed_trials",
]

#: Errors of a database that went away (server restart, network): a worker waits and reconnects. Optuna reports
#: a failed commit as ``StorageInternalError``; a trial failed by another worker meanwhile (its heartbeats
#: could not be written for longer than the grace period) as ``UpdateFinishedTrialError``.
DATABASE_ERRORS = (
    sqlalchemy.exc.OperationalError,
    sqlalchemy.exc.InterfaceError,
    optuna.exceptions.StorageInternalError,
    optuna.exceptions.UpdateFinishedTrialError,
)

#: The extra that installs each database's driver.
_DRIVER_EXTRAS = {"postgresql": "sb3-reinforce[postgresql]"}


class StorageError(ValueError):
    """A ``--storage`` that cannot be used; the message says why and what to do."""


@dataclass(frozen=True)
class FaultTolerance:
    """
    How a database-backed study detects and replaces the trials of dead workers.

    :param heartbeat_interval: Seconds between two heartbeats of a running trial
    :param grace_period: Seconds without a heartbeat after which a running trial is failed (and retried); must
        exceed ``heartbeat_interval``, and should exceed the longest pause of a live worker (a database restart)
    :param max_retry: How many times a failed trial is retried (0: never)
    """

    heartbeat_interval: int = 60
    grace_period: int = 180
    max_retry: int = 3

    def __post_init__(self) -> None:
        if self.heartbeat_interval < 1:
            raise StorageError(f"--heartbeat-interval must be >= 1 second, got {self.heartbeat_interval}")
        if self.grace_period <= self.heartbeat_interval:
            raise StorageError(
                f"--grace-period ({self.grace_period} s) must exceed --heartbeat-interval ({self.heartbeat_interval} s): "
                "otherwise live trials would be failed"
            )
        if self.max_retry < 0:
            raise StorageError(f"--max-retry must be >= 0, got {self.max_retry}")


def is_database_url(storage: str | None) -> bool:
    """Whether ``--storage`` names a database (``dialect://...``), as opposed to a journal file or nothing."""
    return storage is not None and "://" in storage and not storage.startswith(("redis://", "rediss://"))


def redact(url: str) -> str:
    """The URL with its password hidden, for messages."""
    try:
        return sqlalchemy.engine.make_url(url).render_as_string(hide_password=True)
    except sqlalchemy.exc.ArgumentError:
        return url


class _ReconnectingRDBStorage(RDBStorage):
    """``RDBStorage`` whose heartbeats skip a beat while the database is unreachable instead of ending the thread."""

    def record_heartbeat(self, trial_id: int) -> None:
        try:
            super().record_heartbeat(trial_id)
        except DATABASE_ERRORS as error:
            warnings.warn(f"Trial {trial_id}: heartbeat not recorded, the database is unreachable ({_first_line(error)})")


def retried_trial_number(trial: optuna.trial.FrozenTrial) -> int | None:
    """The number of the failed trial that ``trial`` retries, or None if it is no retry."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        return _RetryCallback.retried_trial_number(trial)


def caused_by_database(error: BaseException) -> bool:
    """
    Whether ``error`` comes from a database that went away: one of ``DATABASE_ERRORS``, or any error raised
    while handling one (Optuna's own error handling can fail in turn when the database is gone).
    """
    seen: set[int] = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        if isinstance(current, DATABASE_ERRORS):
            return True
        seen.add(id(current))
        current = current.__cause__ or current.__context__
    return False


def retry_failed_trials(study: optuna.Study, worker: str) -> None:
    """
    Queue a retry of every FAIL trial of ``worker`` that has none yet, as the storage does for stale trials (the
    same callback, so ``max_retry`` holds). For a trial that Optuna marked FAIL because the database went away.

    :param study: The study
    :param worker: The ``worker`` user attribute of the trials to retry
    """
    storage: Any = study._storage
    getter = getattr(storage, "get_heartbeat_stale_trial_callback", None) or storage.get_failed_trial_callback
    callback = getter()
    if callback is None:
        return
    trials = study.get_trials(deepcopy=False)
    retried = {retried_trial_number(trial) for trial in trials}
    for trial in trials:
        failed = trial.state == optuna.trial.TrialState.FAIL and not trial.user_attrs.get("surplus")
        if failed and trial.user_attrs.get("worker") == worker:
            if trial.number not in retried:
                callback(study, trial)


def _first_line(error: BaseException) -> str:
    cause = getattr(error, "orig", None) or error
    return str(cause).strip().splitlines()[0] if str(cause).strip() else type(cause).__name__


def open_database_storage(url: str, fault_tolerance: FaultTolerance) -> RDBStorage:
    """
    Connect to a database storage with heartbeats, retries of failed trials and reconnection.

    :param url: An SQLAlchemy database URL (``postgresql://user:password@host:5432/db``, ``sqlite:///file.db``)
    :param fault_tolerance: Heartbeat and retry settings
    :return: The storage (tables created if the database is empty)
    :raises StorageError: for an invalid URL, a missing driver, or a database that cannot be reached
    """
    shown = redact(url)
    try:
        parsed = sqlalchemy.engine.make_url(url)
        dialect = parsed.get_dialect()
        dialect.import_dbapi()
    except sqlalchemy.exc.ArgumentError as error:
        raise StorageError(f"--storage {shown}: not a database URL ({error})") from None
    except (ImportError, sqlalchemy.exc.NoSuchModuleError) as error:
        extra = _DRIVER_EXTRAS.get(url.split("://")[0].split("+")[0])
        install = f"pip install '{extra}'" if extra else "install the database driver SQLAlchemy names"
        raise StorageError(f"--storage {shown}: the database driver is not installed ({error}): {install}") from None
    for attempt in range(3):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
                return _ReconnectingRDBStorage(
                    url,
                    engine_kwargs={"pool_pre_ping": True},
                    heartbeat_interval=fault_tolerance.heartbeat_interval,
                    grace_period=fault_tolerance.grace_period,
                    **{_RETRY_ARGUMENT: _RetryCallback(max_retry=fault_tolerance.max_retry)},
                )
        except sqlalchemy.exc.IntegrityError:
            # Workers creating the tables of an empty database at the same moment collide: the first one wins,
            # the others find the tables when they try again.
            time.sleep(1.0 + attempt)
        except (*DATABASE_ERRORS, sqlalchemy.exc.DatabaseError) as error:
            # At start-up, an unreachable server or refused credentials are a usage error, not a pause
            raise StorageError(f"--storage {shown}: cannot use the database: {_first_line(error)}") from None
    raise StorageError(f"--storage {shown}: could not create the study's tables (other workers kept colliding)")


def check_direction(study: optuna.Study, direction: optuna.study.StudyDirection) -> None:
    """
    Refuse to join a study that optimizes the other way (Optuna itself would load it silently).

    :raises StorageError: naming the study and both directions
    """
    if study.direction != direction:
        raise StorageError(
            f"--study-name {study.study_name}: the study in this storage is set to {study.direction.name.lower()}, "
            f"the zoo {direction.name.lower()}s the evaluation reward: use another study name"
        )
