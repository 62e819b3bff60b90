"""
Optuna storages for studies shared by several workers (``--storage postgresql://...``, or any SQLAlchemy URL), made to
survive a cluster's faults with Optuna's own machinery:

- A killed worker loses nothing: heartbeats fail its trial and :class:`optuna.storages.RetryHeartbeatStaleTrialCallback`
  queues a copy (at most ``max_retry`` times), see :meth:`FaultTolerantStorage.retry_failed_trials`.
- ``--max-total-trials`` is exact: a trial owed a retry keeps its slot (:func:`held_slots`); extra trials are recorded
  ``FAIL`` as surplus (:func:`surplus_reason`). A trial's own failure (``error``, ``surplus``) is not retried.
- Dropped connections are survived (``pool_pre_ping``); bad input (URL, driver, server, login) is one clear line.
"""

import copy
import time
import warnings
from collections.abc import Hashable, Iterable, Sequence
from dataclasses import dataclass

import optuna
import sqlalchemy
import sqlalchemy.exc
import sqlalchemy.orm
from optuna.storages import RDBStorage, RetryHeartbeatStaleTrialCallback

# Private (optuna below 5.1, bounded in pyproject.toml): Optuna's stale check skips trials without a heartbeat row
from optuna.storages._rdb.models import TrialHeartbeatModel, TrialModel
from optuna.trial import FrozenTrial, TrialState

__all__ = [
    "DATABASE_ERRORS",
    "SLOT_STATES",
    "FaultTolerance",
    "FaultTolerantStorage",
    "StorageError",
    "caused_by_database",
    "check_direction",
    "held_slots",
    "is_database_url",
    "open_database_storage",
    "owes_retry",
    "redact",
    "retried_trial_number",
    "retry_history",
    "surplus_reason",
]

#: Errors of a database that went away: a worker waits and reconnects. Optuna raises ``StorageInternalError`` on a
#: failed commit and ``UpdateFinishedTrialError`` for a trial failed meanwhile by another worker.
DATABASE_ERRORS = (
    sqlalchemy.exc.OperationalError,
    sqlalchemy.exc.InterfaceError,
    optuna.exceptions.StorageInternalError,
    optuna.exceptions.UpdateFinishedTrialError,
)

#: States in which a trial holds one of the ``--max-total-trials`` slots: finished, running, or queued to run.
SLOT_STATES = (TrialState.COMPLETE, TrialState.PRUNED, TrialState.RUNNING, TrialState.WAITING)

#: User attributes that say a failed trial ended by itself (its own error) or never ran: it is not retried.
_OUTCOME_ATTRS = ("error", "surplus")

#: The extra that installs each database's driver.
_DRIVER_EXTRAS = {"postgresql": "sb3-reinforce[postgresql]"}

# PostgreSQL's codes for a table or object (index, sequence) another session created first
_DUPLICATE_SQLSTATES = {"42P07", "42710"}


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


def caused_by_database(error: BaseException) -> bool:
    """Whether ``error`` is one of ``DATABASE_ERRORS``, or was raised while handling one (the database went away)."""
    seen: set[int] = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        if isinstance(current, DATABASE_ERRORS):
            return True
        seen.add(id(current))
        current = current.__cause__ or current.__context__
    return False


def retry_history(trial: FrozenTrial) -> list[int]:
    """The numbers of the failed trials that ``trial`` retries, the original first (Optuna's; [] for no retry)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        return RetryHeartbeatStaleTrialCallback.retry_history(trial)


def retried_trial_number(trial: FrozenTrial) -> int | None:
    """The number of the original failed trial that ``trial`` retries, or None if it is no retry."""
    history = retry_history(trial)
    return history[0] if history else None


def _original(trial: FrozenTrial) -> int:
    """The number of the trial that ``trial`` retries (through any chain of retries), or its own number."""
    return (retry_history(trial) or [trial.number])[0]


def _ended_by_itself(trial: FrozenTrial) -> bool:
    """Whether ``trial`` failed by its own error or never ran (one of ``_OUTCOME_ATTRS``): it is not retried."""
    return any(trial.user_attrs.get(name) for name in _OUTCOME_ATTRS)


def _owes(trial: FrozenTrial, retried: set[int], max_retry: int) -> bool:
    """:func:`owes_retry`, given the numbers of the trials that some trial retries."""
    if trial.state != TrialState.FAIL or _ended_by_itself(trial) or trial.number in retried:
        return False
    return len(retry_history(trial)) < max_retry


def _retried_numbers(trials: Iterable[FrozenTrial]) -> set[int]:
    """The numbers of the trials that some trial of ``trials`` retries (directly or through a chain)."""
    return {number for trial in trials for number in retry_history(trial)}


def owes_retry(trial: FrozenTrial, trials: Sequence[FrozenTrial], max_retry: int) -> bool:
    """
    Whether ``trial`` failed by no error of its own, has fewer than ``max_retry`` retries, and no trial of ``trials``
    retries it yet (only retries of this very trial count).
    """
    return _owes(trial, _retried_numbers(trials), max_retry)


def held_slots(trials: Sequence[FrozenTrial], max_retry: int, exclude_original: int | None = None) -> int:
    """
    Slots of ``--max-total-trials`` that ``trials`` hold: one per retry chain done, running, waiting or owed a retry.

    :param trials: The trials to count (all the study's, or those numbered before a trial that just started)
    :param max_retry: How many times a failed trial is retried
    :param exclude_original: Leave out the chain of this original trial (a retry checking whether its own slot is free)
    :return: The number of slots held
    """
    retried = _retried_numbers(trials)
    holding = {_original(trial) for trial in trials if trial.state in SLOT_STATES or _owes(trial, retried, max_retry)}
    return len(holding - {exclude_original})


def surplus_reason(number: int, trials: Sequence[FrozenTrial], total: int, max_retry: int) -> str | None:
    """
    Why trial ``number``, just started, must not run in a study of ``total`` trials, or None. The trials numbered before
    it decide: an earlier retry of the same trial, or every slot held (:func:`held_slots`).

    :param number: The number of the trial
    :param trials: The study's trials, this one among them
    :param total: ``--max-total-trials``
    :param max_retry: How many times a failed trial is retried
    :return: The reason, for the message, or None
    """
    this = next(trial for trial in trials if trial.number == number)
    history, original = retry_history(this), _original(this)
    earlier = [trial for trial in trials if trial.number < number]
    for trial in earlier:
        if history and _original(trial) == original and (trial.state in SLOT_STATES or retry_history(trial) == history):
            return f"trial {history[-1]} is already retried"
    if held_slots(earlier, max_retry, exclude_original=original) >= total:
        return f"the study already has its {total} trials"
    return None


class _RetryCallback(RetryHeartbeatStaleTrialCallback):
    """Optuna's retry, skipping trials with ``error``/``surplus``; copies the trial (Optuna extends its history in place)."""

    def __call__(self, study: optuna.Study, trial: FrozenTrial) -> None:
        if not _ended_by_itself(trial):
            super().__call__(study, copy.deepcopy(trial))


class _Sightings:
    """How long this process has seen trials in some condition, per study (seconds of its monotonic clock)."""

    def __init__(self) -> None:
        self._since: dict[Hashable, dict[int, float]] = {}

    def seconds(self, study: Hashable, trials: Iterable[int]) -> dict[int, float]:
        """
        Record that ``trials`` (ids or numbers) of ``study`` are seen now, forgetting the study's others.

        :return: For each, the seconds since it was first seen so (0 for a first sighting)
        """
        now, seen = time.monotonic(), self._since.get(study, {})
        self._since[study] = {trial: seen.get(trial, now) for trial in trials}
        return {trial: now - since for trial, since in self._since[study].items()}


class FaultTolerantStorage(RDBStorage):
    """
    Optuna's ``RDBStorage`` with heartbeats, retries and reconnection; heartbeats skip while the database is away.

    :param url: An SQLAlchemy database URL
    :param fault_tolerance: Heartbeat and retry settings
    """

    def __init__(self, url: str, fault_tolerance: FaultTolerance) -> None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            super().__init__(
                url,
                engine_kwargs={"pool_pre_ping": True},
                heartbeat_interval=fault_tolerance.heartbeat_interval,
                grace_period=fault_tolerance.grace_period,
                heartbeat_stale_trial_callback=_RetryCallback(max_retry=fault_tolerance.max_retry),
            )
        self.fault_tolerance = fault_tolerance
        self._silent = _Sightings()  # running trials without a heartbeat, by trial id
        self._owed = _Sightings()  # failed trials owed a retry, by trial number

    def record_heartbeat(self, trial_id: int) -> None:
        try:
            super().record_heartbeat(trial_id)
        except DATABASE_ERRORS as error:
            warnings.warn(f"Trial {trial_id}: heartbeat not recorded, the database is unreachable ({_first_line(error)})")

    def _get_stale_trial_ids(self, study_id: int) -> list[int]:
        """Optuna's stale trials, and the running trials this process has seen without a heartbeat for the grace period."""
        stale = super()._get_stale_trial_ids(study_id)
        never_beat = sqlalchemy.select(TrialModel.trial_id).where(
            TrialModel.study_id == study_id,
            TrialModel.state == TrialState.RUNNING,
            ~sqlalchemy.exists().where(TrialHeartbeatModel.trial_id == TrialModel.trial_id),
        )
        with sqlalchemy.orm.Session(self.engine) as session:
            silent = session.scalars(never_beat).all()
        seconds = self._silent.seconds(study_id, silent)
        grace_period = self.fault_tolerance.grace_period
        return stale + [trial_id for trial_id in silent if seconds[trial_id] > grace_period and trial_id not in stale]

    def retry_failed_trials(self, study: optuna.Study, worker: str, orphaned_after: float | None = None) -> None:
        """
        Queue the retries owed to ``worker``'s failed trials (:func:`owes_retry`), e.g. those failed by a lost database.

        :param study: The study
        :param worker: The ``worker`` user attribute of the trials to retry
        :param orphaned_after: Also queue anyone's retry seen owed for longer than this, in seconds (None: never)
        """
        callback = self.get_heartbeat_stale_trial_callback()
        assert callback is not None
        trials = study.get_trials(deepcopy=False)
        retried = _retried_numbers(trials)
        owed = [trial for trial in trials if _owes(trial, retried, self.fault_tolerance.max_retry)]
        seconds = self._owed.seconds(study.study_name, [trial.number for trial in owed])
        for trial in owed:
            orphaned = orphaned_after is not None and seconds[trial.number] > orphaned_after
            if trial.user_attrs.get("worker") == worker or orphaned:
                callback(study, trial)


def _first_line(error: BaseException) -> str:
    cause = getattr(error, "orig", None) or error
    return str(cause).strip().splitlines()[0] if str(cause).strip() else type(cause).__name__


def _created_by_another_worker(error: Exception) -> bool:
    """Whether creating the tables failed only because another worker created them at the same moment."""
    if isinstance(error, sqlalchemy.exc.IntegrityError):
        return True
    original = getattr(error, "orig", None)
    sqlstate = getattr(original, "sqlstate", None) or getattr(original, "pgcode", None)
    return sqlstate in _DUPLICATE_SQLSTATES


def open_database_storage(url: str, fault_tolerance: FaultTolerance) -> FaultTolerantStorage:
    """
    Connect to a database storage with heartbeats, retries of failed trials and reconnection.

    :param url: An SQLAlchemy database URL (``postgresql://user:password@host:5432/db``, ``sqlite:///file.db``)
    :param fault_tolerance: Heartbeat and retry settings
    :return: The storage (tables created if the database is empty)
    :raises StorageError: for an invalid URL, a missing driver, or a database that cannot be reached
    """
    shown = redact(url)
    try:
        sqlalchemy.engine.make_url(url).get_dialect().import_dbapi()
    except sqlalchemy.exc.ArgumentError as error:
        raise StorageError(f"--storage {shown}: not a database URL ({error})") from None
    except (ImportError, sqlalchemy.exc.NoSuchModuleError) as error:
        extra = _DRIVER_EXTRAS.get(url.split("://")[0].split("+")[0])
        install = f"pip install '{extra}'" if extra else "install the database driver SQLAlchemy names"
        raise StorageError(f"--storage {shown}: the database driver is not installed ({error}): {install}") from None
    for attempt in range(3):
        try:
            return FaultTolerantStorage(url, fault_tolerance)
        except (*DATABASE_ERRORS, sqlalchemy.exc.DatabaseError) as error:
            if _created_by_another_worker(error):
                # Workers creating the tables at the same moment collide: the others find them on the next try
                time.sleep(1.0 + attempt)
                continue
            # At start-up, an unreachable server or refused credentials are a usage error
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
