"""
Optuna storages for studies shared by several workers (``--storage postgresql://...``, or any other database
URL SQLAlchemy knows), set up to survive the faults of a real cluster.

- **A killed worker loses nothing.** Every running trial records a heartbeat every ``heartbeat_interval``
  seconds. A trial whose heartbeat is older than ``grace_period`` is marked ``FAIL`` by the next worker that
  looks, and :class:`optuna.storages.RetryFailedTrialCallback` enqueues a copy of it (same hyperparameters,
  at most ``max_retry`` times), which the next free worker runs. A trial that Optuna marks ``FAIL`` because
  the database went away is retried the same way by its own worker (by any worker that has seen it owed a retry
  for ``grace_period`` seconds of the database's clock: its worker died first).
- **The total is exact** (``--max-total-trials``): a failed trial owed a retry keeps its slot
  (:func:`held_slots`), so a new trial cannot take it before the retry runs, and a trial started beyond the
  total, or a second retry of the same trial, is recorded ``FAIL`` as "surplus" and not run.
- **A dropped connection is survived.** Connections are checked before use (SQLAlchemy's ``pool_pre_ping``),
  so a worker reconnects after the server restarts. A heartbeat that cannot be written while the server is
  down is skipped, not fatal.
- **Bad input is one clear line**: an invalid URL, a missing driver (naming the extra to install), a server
  that cannot be reached or refuses the credentials.
"""

import copy
import datetime
import time
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import optuna
import sqlalchemy
import sqlalchemy.exc
from optuna.storages import RDBStorage
from optuna.storages._rdb import models as _models  # the trials and heartbeats tables, for never-beating trials
from optuna.storages._rdb.storage import _create_scoped_session

# Optuna >= 4.9 names the retry of heartbeat-stale trials on its own; older versions call it the failed-trial callback.
_OptunaRetryCallback: Any = getattr(optuna.storages, "RetryHeartbeatStaleTrialCallback", None)
_RETRY_ARGUMENT = "heartbeat_stale_trial_callback"
if _OptunaRetryCallback is None:  # pragma: no cover (Optuna < 4.9)
    _OptunaRetryCallback = optuna.storages.RetryFailedTrialCallback
    _RETRY_ARGUMENT = "failed_trial_callback"

#: User attributes that say a failed trial ended by itself (its own error) or never ran: it is not retried
_OUTCOME_ATTRS = ("error", "surplus")


def _ended_by_itself(trial: optuna.trial.FrozenTrial) -> bool:
    """Whether ``trial`` failed by its own error or never ran (one of ``_OUTCOME_ATTRS``): it is not retried."""
    return any(trial.user_attrs.get(name) for name in _OUTCOME_ATTRS)


class _RetryCallback(_OptunaRetryCallback):
    """
    Optuna's retry of a failed trial (the same hyperparameters, a WAITING copy, at most ``max_retry`` times),
    except for a trial that failed by its own error or never ran (``error``, ``surplus``): a trial marked so
    whose worker then lost the database before it could record the FAIL is found stale later, and must not be
    retried either. The failed trial is copied first (Optuna extends its retry history in place).
    """

    def __call__(self, study: optuna.Study, trial: optuna.trial.FrozenTrial) -> None:
        if _ended_by_itself(trial):
            return
        super().__call__(study, copy.deepcopy(trial))


__all__ = [
    "DATABASE_ERRORS",
    "SLOT_STATES",
    "FaultTolerance",
    "StorageError",
    "caused_by_database",
    "check_direction",
    "held_slots",
    "is_database_url",
    "open_database_storage",
    "original_trial_number",
    "owes_retry",
    "redact",
    "retried_trial_number",
    "retry_failed_trials",
    "surplus_reason",
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
    """
    ``RDBStorage`` whose heartbeats skip a beat while the database is unreachable instead of ending the thread,
    and that finds stale the running trials that never recorded a heartbeat.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        #: Per study, its running trials without a heartbeat, with the database time they were first seen so
        self._silent_since: dict[int, dict[int, datetime.datetime]] = {}
        #: Per study, its failed trials owed a retry, with the database time they were first seen so
        self._owed_since: dict[int, dict[int, datetime.datetime]] = {}

    def _database_now(self) -> datetime.datetime:
        """The database's clock (every worker reads the same one, whatever its own clock or time zone)."""
        with _create_scoped_session(self.scoped_session, True) as session:
            return session.execute(sqlalchemy.func.now()).scalar_one().replace(tzinfo=None)

    def _seconds_seen(
        self, first_seen: dict[int, dict[int, datetime.datetime]], study_id: int, trial_ids: Iterable[int]
    ) -> dict[int, float]:
        """
        How long each of ``trial_ids`` (trials of study ``study_id``) has been seen in some state by this storage,
        in seconds of the database's clock: 0 for a trial seen for the first time; the study's trials no longer
        given are forgotten, those of other studies kept. ``first_seen`` is updated in place.
        """
        now = self._database_now()
        seen = first_seen.get(study_id, {})
        first_seen[study_id] = {trial_id: seen.get(trial_id, now) for trial_id in trial_ids}
        return {trial_id: (now - since).total_seconds() for trial_id, since in first_seen[study_id].items()}

    def seconds_owed(self, study_id: int, trial_ids: Iterable[int]) -> dict[int, float]:
        """How long each of ``trial_ids``, failed trials of the study owed a retry, has been seen so (seconds)."""
        return self._seconds_seen(self._owed_since, study_id, trial_ids)

    def _get_stale_trial_ids(self, study_id: int) -> list[int]:
        """
        Optuna's stale trials (a heartbeat older than the grace period), and the running trials that have had no
        heartbeat for the grace period since this storage first saw them: their worker died, or lost the
        database, before its heartbeat thread wrote once (Optuna alone would leave them running forever).
        """
        stale = super()._get_stale_trial_ids(study_id)
        grace_period = self.grace_period if self.grace_period is not None else 2 * (self.heartbeat_interval or 0)
        with _create_scoped_session(self.scoped_session, True) as session:
            silent = session.query(_models.TrialModel.trial_id).filter(
                _models.TrialModel.study_id == study_id,
                _models.TrialModel.state == optuna.trial.TrialState.RUNNING,
                ~_models.TrialModel.heartbeats.any(),
            )
            silent_ids = [row[0] for row in silent.all()]
        seconds_silent = self._seconds_seen(self._silent_since, study_id, silent_ids)
        overdue = [trial_id for trial_id, seconds in seconds_silent.items() if seconds > grace_period]
        return stale + [trial_id for trial_id in overdue if trial_id not in stale]

    def record_heartbeat(self, trial_id: int) -> None:
        try:
            super().record_heartbeat(trial_id)
        except DATABASE_ERRORS as error:
            warnings.warn(f"Trial {trial_id}: heartbeat not recorded, the database is unreachable ({_first_line(error)})")


def retried_trial_number(trial: optuna.trial.FrozenTrial) -> int | None:
    """The number of the failed trial that ``trial`` retries, or None if it is no retry."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        return _OptunaRetryCallback.retried_trial_number(trial)


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


#: States in which a trial holds one of the ``--max-total-trials`` slots: finished, running, or queued to run.
SLOT_STATES = (
    optuna.trial.TrialState.COMPLETE,
    optuna.trial.TrialState.PRUNED,
    optuna.trial.TrialState.RUNNING,
    optuna.trial.TrialState.WAITING,
)


def original_trial_number(trial: optuna.trial.FrozenTrial) -> int:
    """The number of the trial that ``trial`` retries (through any chain of retries), or its own number."""
    retried = retried_trial_number(trial)
    return trial.number if retried is None else retried


def owes_retry(trial: optuna.trial.FrozenTrial, trials: Sequence[optuna.trial.FrozenTrial], max_retry: int) -> bool:
    """
    Whether ``trial`` failed by no error of its own (its worker died or lost the database; not a surplus trial,
    no ``error`` user attribute), may still be retried (fewer than ``max_retry`` retries of its original so far)
    and no trial of ``trials`` retries it yet (directly, or through a retry of its retry). Only the retries of this
    very trial count: a duplicate retry of the trial it retries (refused as surplus) does not.
    """
    if trial.state != optuna.trial.TrialState.FAIL or _ended_by_itself(trial):
        return False
    if len(trial.system_attrs.get("retry_history", [])) >= max_retry:
        return False
    return not any(trial.number in other.system_attrs.get("retry_history", []) for other in trials)


def held_slots(trials: Sequence[optuna.trial.FrozenTrial], max_retry: int, exclude_original: int | None = None) -> int:
    """
    How many of a study's ``--max-total-trials`` slots ``trials`` hold: each finished, running or waiting trial
    holds one, and so does each failed trial that is owed a retry (its slot is kept for the retry, so that no
    new trial takes it first and the retry finds the study full).

    :param trials: The trials to count (all the study's, or those numbered before a trial that just started)
    :param max_retry: How many times a failed trial is retried
    :param exclude_original: Leave out the trials of this original trial and its retries (a retry checking
        whether its own slot is free)
    :return: The number of slots held
    """
    return sum(
        original_trial_number(trial) != exclude_original
        and (trial.state in SLOT_STATES or owes_retry(trial, trials, max_retry))
        for trial in trials
    )


def _directly_retried(trial: optuna.trial.FrozenTrial) -> int | None:
    """The number of the failed trial that ``trial`` is the retry of (the last of its retry history), or None."""
    history = trial.system_attrs.get("retry_history", [])
    return history[-1] if history else None


def surplus_reason(number: int, trials: Sequence[optuna.trial.FrozenTrial], total: int, max_retry: int) -> str | None:
    """
    Why trial ``number``, just started, must not run in a study of ``total`` trials, or None if it may. Trial
    numbers are given out by the database in order, so the trials numbered before it decide (whatever the
    timing of the workers): it is surplus if they hold every slot (:func:`held_slots`; a retry takes the slot
    its failed trial kept for it), if an earlier trial is a retry of the same failed trial (two workers queued
    one at the same moment), or if a trial of the same original is still running, queued or finished.

    :param number: The number of the trial
    :param trials: The study's trials, this one among them
    :param total: ``--max-total-trials``
    :param max_retry: How many times a failed trial is retried
    :return: The reason, for the message, or None
    """
    this = next(trial for trial in trials if trial.number == number)
    original = original_trial_number(this)
    retried = _directly_retried(this)
    earlier = [trial for trial in trials if trial.number < number]
    if retried is not None and any(_directly_retried(trial) == retried for trial in earlier):
        return f"trial {retried} is already retried"
    if any(original_trial_number(trial) == original and trial.state in SLOT_STATES for trial in earlier):
        return f"trial {original} is already retried"
    if held_slots(earlier, max_retry, exclude_original=original) >= total:
        return f"the study already has its {total} trials"
    return None


def retry_failed_trials(study: optuna.Study, worker: str, max_retry: int, orphaned_after: float | None = None) -> None:
    """
    Queue the retry of every failed trial of ``worker`` that is owed one (:func:`owes_retry`), as the storage
    does for stale trials (the same callback): a trial Optuna marked FAIL because the database went away. With
    ``orphaned_after``, the retries owed to any worker that this process has seen owed for longer than that many
    seconds of the database's clock too (their worker died before it could queue them).

    :param study: The study
    :param worker: The ``worker`` user attribute of the trials to retry
    :param max_retry: How many times a failed trial is retried
    :param orphaned_after: Seconds after which anyone's owed retry is queued (None: never)
    """
    storage: Any = study._storage
    getter = getattr(storage, "get_heartbeat_stale_trial_callback", None) or storage.get_failed_trial_callback
    callback = getter()
    if callback is None:
        return
    trials = study.get_trials(deepcopy=False)
    owed = [trial for trial in trials if owes_retry(trial, trials, max_retry)]
    backend = getattr(storage, "_backend", storage)  # Optuna wraps a database storage in a cache
    if isinstance(backend, _ReconnectingRDBStorage):
        seconds_owed = backend.seconds_owed(study._study_id, [trial._trial_id for trial in owed])
    else:  # another storage: the workers' clocks, from the trial's end
        now = datetime.datetime.now()
        seconds_owed = {trial._trial_id: (now - (trial.datetime_complete or now)).total_seconds() for trial in owed}
    for trial in owed:
        orphaned = orphaned_after is not None and seconds_owed[trial._trial_id] > orphaned_after
        if trial.user_attrs.get("worker") == worker or orphaned:
            callback(study, trial)


def _first_line(error: BaseException) -> str:
    cause = getattr(error, "orig", None) or error
    return str(cause).strip().splitlines()[0] if str(cause).strip() else type(cause).__name__


# PostgreSQL's codes for a table or object (index, sequence) another session created first
_DUPLICATE_SQLSTATES = {"42P07", "42710"}


def _created_by_another_worker(error: Exception) -> bool:
    """Whether creating the tables failed only because another worker created them at the same moment."""
    if isinstance(error, sqlalchemy.exc.IntegrityError):
        return True
    original = getattr(error, "orig", None)
    sqlstate = getattr(original, "sqlstate", None) or getattr(original, "pgcode", None)
    return sqlstate in _DUPLICATE_SQLSTATES


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
        except (*DATABASE_ERRORS, sqlalchemy.exc.DatabaseError) as error:
            if _created_by_another_worker(error):
                # Workers creating the tables of an empty database at the same moment collide: the first one
                # wins, the others find the tables when they try again.
                time.sleep(1.0 + attempt)
                continue
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
