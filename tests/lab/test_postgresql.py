"""
Distributed studies on a real PostgreSQL server (started for these tests, see ``tests/postgres.py``): several
``sb3-reinforce-zoo train --optimize`` workers share one study; a killed worker or a restarted server loses no
trial and counts none twice; bad ``--storage`` input is one line and exit status 2.

Outside CI the tests that need the server skip when it cannot be started here; under ``CI=true`` they fail.
"""

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import optuna
import pytest
import rl_zoo3.exp_manager
from optuna.trial import TrialState

from sb3_reinforce import REINFORCE
from sb3_reinforce.lab.zoo import main
from sb3_reinforce.lab.zoo.storage import (
    FaultTolerance,
    FaultTolerantStorage,
    StorageError,
    caused_by_database,
    held_slots,
    open_database_storage,
    owes_retry,
    retried_trial_number,
    surplus_reason,
)
from tests.postgres import PostgresServer, ServerUnavailable, postgres_server

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def postgres() -> Iterator[PostgresServer]:
    try:
        with postgres_server() as server:
            yield server
    except ServerUnavailable as error:
        if os.environ.get("CI") == "true":
            pytest.fail(f"CI must run the PostgreSQL tests, but the server could not be started: {error}")
        pytest.skip(f"no PostgreSQL server here: {error}")


def optimize_args(storage: str, study: str, budget: int, total: int, grace_period: int = 4) -> list[str]:
    args = ["train", "--algo", "reinforce", "--env", "CartPole-v1", "-optimize", "--n-trials", "100"]
    args += ["--max-total-trials", str(total), "-n", str(budget), "--n-evaluations", "1", "--eval-episodes", "2"]
    args += ["--sampler", "random", "--pruner", "none", "--no-optim-plots", "--num-threads", "1", "--verbose", "0"]
    heartbeat = ["--heartbeat-interval", "1", "--grace-period", str(grace_period)]
    return [*args, "--storage", storage, "--study-name", study, *heartbeat]


def start_worker(args: list[str], seed: int, cwd: Path) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]), CUDA_VISIBLE_DEVICES="")
    return subprocess.Popen(
        [sys.executable, "-m", "sb3_reinforce.lab.zoo", *args, "--seed", str(seed), "-f", str(cwd / f"logs{seed}")],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


def finish(worker: subprocess.Popen, timeout: float = 600) -> str:
    output, _ = worker.communicate(timeout=timeout)
    assert worker.returncode == 0, output[-3000:]
    return output


def wait_until(condition: Callable[[], bool], what: str, timeout: float = 60, interval: float = 0.2) -> None:
    """Poll ``condition`` until it holds; fail naming ``what`` after ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError(f"{what}: not after {timeout} s")
        time.sleep(interval)


def wait_for_running_trial(storage: str, study_name: str, pid: int | None = None, timeout: float = 120) -> None:
    def running() -> bool:
        try:
            trials = optuna.load_study(study_name=study_name, storage=storage).get_trials(states=(TrialState.RUNNING,))
        except KeyError:  # the study does not exist yet
            return False
        return any(pid is None or t.user_attrs.get("worker", "").endswith(f":{pid}") for t in trials)

    wait_until(running, f"a running trial{'' if pid is None else f' of worker {pid}'}", timeout)


def check_exact_total(study: optuna.Study, total: int, outputs: Sequence[str] = ()) -> list[optuna.trial.FrozenTrial]:
    """Exactly `total` finished trials, every failed one retried once by a finished trial."""
    try:
        return _check_exact_total(study, total)
    except AssertionError as error:
        trials = [(t.number, t.state.name, retried_trial_number(t), t.user_attrs) for t in study.get_trials()]
        shown = "\n".join(f"--- worker {i} ---\n{output[-4000:]}" for i, output in enumerate(outputs))
        raise AssertionError(f"{error}\ntrials: {trials}\n{shown}") from error


def _check_exact_total(study: optuna.Study, total: int) -> list[optuna.trial.FrozenTrial]:
    trials = study.get_trials()
    finished = [t for t in trials if t.state in (TrialState.COMPLETE, TrialState.PRUNED)]
    assert len(finished) == total, [(t.number, t.state) for t in trials]
    assert not [t for t in trials if t.state in (TrialState.RUNNING, TrialState.WAITING)]
    # a trial two workers started beyond the total at the same moment is recorded FAIL as surplus, and never run
    failed = [t for t in trials if t.state == TrialState.FAIL and not t.user_attrs.get("surplus")]
    for trial in failed:
        # a finished trial retries it, directly or through a retry of its retry (which failed in turn)
        retries = [t for t in finished if trial.number in t.system_attrs.get("retry_history", [])]
        assert retries, f"failed trial {trial.number} was not retried"
        # the retry keeps what the failed trial had sampled (killed early, it may not have sampled everything)
        assert trial.params.items() <= retries[0].params.items()
    return failed


def test_two_workers_one_study(postgres: PostgresServer, tmp_path: Path) -> None:
    args = optimize_args(postgres.url, "two-workers", 1000, total=4)
    workers = [start_worker(args, seed, tmp_path) for seed in (0, 1)]
    for worker in workers:
        finish(worker)
    study = optuna.load_study(study_name="two-workers", storage=postgres.url)
    assert study.direction == optuna.study.StudyDirection.MAXIMIZE
    assert not check_exact_total(study, 4)
    pids = {str(worker.pid) for worker in workers}
    assert all(t.user_attrs["worker"].split(":")[-1] in pids for t in study.trials)

    # The best trial trains with --trial-id, from the database
    best = study.best_trial.number
    args = ["train", "--algo", "reinforce", "--env", "CartPole-v1", "-n", "200", "--eval-freq", "-1", "--verbose", "0"]
    args += ["--storage", postgres.url, "--study-name", "two-workers", "--trial-id", str(best), "-f", str(tmp_path / "best")]
    assert main(args) == 0
    model = REINFORCE.load(tmp_path / "best" / "reinforce" / "CartPole-v1_1" / "CartPole-v1.zip", device="cpu")
    assert model.n_envs == study.best_trial.params["n_envs"]


def test_killed_worker_loses_no_trial(postgres: PostgresServer, tmp_path: Path) -> None:
    args = optimize_args(postgres.url, "killed-worker", 10_000, total=3)
    victim = start_worker(args, 0, tmp_path)
    wait_for_running_trial(postgres.url, "killed-worker", victim.pid)
    survivor = start_worker(args, 1, tmp_path)
    victim.send_signal(signal.SIGKILL)  # mid-trial: no chance to tell the study anything
    victim.wait(timeout=30)
    output = finish(survivor)
    study = optuna.load_study(study_name="killed-worker", storage=postgres.url)
    failed = check_exact_total(study, 3)
    assert [t.user_attrs["worker"].split(":")[-1] for t in failed] == [str(victim.pid)], output[-2000:]


def test_server_restart_during_trials(postgres: PostgresServer, tmp_path: Path) -> None:
    # Both workers reconnect and the total stays exact. Whether a trial fails and is retried depends on whether a
    # write fell into the pause; the retry paths themselves are tested on SQLite below, deterministically.
    # a grace period well above the restart's pause, so that no live trial is taken for a dead one on a busy machine
    args = optimize_args(postgres.url, "restarted-server", 20_000, total=4, grace_period=20)
    workers = [start_worker(args, seed, tmp_path) for seed in (0, 1)]
    for worker in workers:
        wait_for_running_trial(postgres.url, "restarted-server", worker.pid)
    postgres.restart()  # every connection of both workers is closed
    outputs = [finish(worker) for worker in workers]
    check_exact_total(optuna.load_study(study_name="restarted-server", storage=postgres.url), 4, outputs)


def sqlite_study(tmp_path: Path, max_retry: int = 3) -> tuple[optuna.Study, FaultTolerantStorage]:
    """A study on SQLite through the same storage as PostgreSQL's: heartbeat every 1 s, grace period 4 s."""
    storage = open_database_storage(f"sqlite:///{tmp_path / 'study.db'}", FaultTolerance(1, 4, max_retry))
    return optuna.create_study(storage=storage, direction="maximize"), storage


def add_trial(study: optuna.Study, state: TrialState, worker: str = "host:1") -> optuna.trial.FrozenTrial:
    trial = study.ask()
    trial.suggest_float("x", 0, 1)
    trial.set_user_attr("worker", worker)
    if state != TrialState.RUNNING:
        study.tell(trial, 1.0 if state == TrialState.COMPLETE else None, state=state)
    return study.trials[trial.number]


def waiting(study: optuna.Study) -> list[int | None]:
    """The trials queued to run, as the numbers of the trials they retry."""
    return [retried_trial_number(t) for t in study.get_trials(states=(TrialState.WAITING,))]


def test_a_trial_failed_by_a_lost_connection_is_retried_once(tmp_path: Path) -> None:
    # Optuna marks a trial FAIL when the database error reaches it: the worker queues its retry (not a stale trial)
    study, storage = sqlite_study(tmp_path)
    mine, _ = add_trial(study, TrialState.FAIL, "host:1"), add_trial(study, TrialState.FAIL, "host:2")
    storage.retry_failed_trials(study, "host:1", orphaned_after=60)
    storage.retry_failed_trials(study, "host:1", orphaned_after=60)  # once only
    assert waiting(study) == [mine.number]  # the other worker's failure is recent
    assert study.get_trials(states=(TrialState.WAITING,))[0].params == mine.params


def test_an_orphaned_failure_is_retried_by_any_worker(tmp_path: Path) -> None:
    # A worker that died between the failure of its trial and the retry: another worker queues it after the delay
    study, storage = sqlite_study(tmp_path)
    orphan = add_trial(study, TrialState.FAIL, "host:2")
    storage.retry_failed_trials(study, "host:1")  # no delay given: only this worker's own failures; first seen owed now
    storage.retry_failed_trials(study, "host:1", orphaned_after=3)  # seen owed for less than 3 s
    assert not waiting(study)
    # timed by this process's clock, from when it first saw the trial owed
    wait_until(lambda: storage.retry_failed_trials(study, "host:1", orphaned_after=3) or bool(waiting(study)), "orphan queued")
    assert waiting(study) == [orphan.number]


def test_an_orphaned_failure_is_timed_per_study(tmp_path: Path) -> None:
    # Looking for the owed retries of another study of the same storage does not restart an orphan's clock
    study, storage = sqlite_study(tmp_path)
    other = optuna.create_study(storage=storage, direction="maximize")
    orphan = add_trial(study, TrialState.FAIL, "host:2")

    def look_at_both() -> bool:
        storage.retry_failed_trials(other, "host:1", orphaned_after=1)
        storage.retry_failed_trials(study, "host:1", orphaned_after=1)
        return bool(waiting(study))

    wait_until(look_at_both, "orphan queued while another study is looked at", interval=0.1)
    assert waiting(study) == [orphan.number]


def test_a_failed_trial_keeps_its_slot_for_its_retry(tmp_path: Path) -> None:
    # In the order the database numbers them: 0 done, 1 failed (owed a retry), 2 running; a total of 3
    study, storage = sqlite_study(tmp_path)
    add_trial(study, TrialState.COMPLETE)
    failed = add_trial(study, TrialState.FAIL)
    add_trial(study, TrialState.RUNNING)
    assert owes_retry(failed, study.trials, max_retry=3)
    assert held_slots(study.trials, max_retry=3) == 3
    # A new trial started now is surplus: it would take the failed trial's slot and leave its retry none
    fresh = add_trial(study, TrialState.RUNNING, "host:2")
    assert surplus_reason(fresh.number, study.trials, total=3, max_retry=3) == "the study already has its 3 trials"
    study._storage.set_trial_user_attr(fresh._trial_id, "surplus", True)
    study.tell(fresh.number, state=TrialState.FAIL)
    # The retry, queued after that trial, takes the slot that was kept for it
    storage.retry_failed_trials(study, "host:1")
    retry = study.ask()  # the waiting retry is run first
    assert retried_trial_number(study.trials[retry.number]) == failed.number
    assert not owes_retry(failed, study.trials, max_retry=3)
    assert surplus_reason(retry.number, study.trials, total=3, max_retry=3) is None
    assert held_slots(study.trials, max_retry=3) == 3
    # A second retry of the same trial (two workers queued one at the same moment) does not run
    queue_retry(storage, study, failed)
    duplicate = study.ask()
    assert retried_trial_number(study.trials[duplicate.number]) == failed.number
    assert surplus_reason(duplicate.number, study.trials, total=10, max_retry=3) == f"trial {failed.number} is already retried"


def queue_retry(storage: FaultTolerantStorage, study: optuna.Study, failed: optuna.trial.FrozenTrial) -> None:
    """What a worker does for a failed trial it owes a retry: the storage's retry callback."""
    callback = storage.get_heartbeat_stale_trial_callback()
    assert callback is not None
    callback(study, study.trials[failed.number])


def test_a_duplicate_retry_does_not_cancel_the_retry_of_the_retry(tmp_path: Path) -> None:
    # Two workers queued the retry of one orphan at the same moment; the first copy runs and loses the database
    study, storage = sqlite_study(tmp_path)
    failed = add_trial(study, TrialState.FAIL, "host:1")
    queue_retry(storage, study, failed)
    queue_retry(storage, study, failed)
    retry = study.ask()
    study._storage.set_trial_user_attr(retry._trial_id, "worker", "host:2")
    study.tell(retry, state=TrialState.FAIL)
    retry, duplicate = study.trials[retry.number], study.get_trials(states=(TrialState.WAITING,))[0]
    assert retried_trial_number(duplicate) == failed.number
    assert owes_retry(retry, study.trials, max_retry=3)  # the duplicate retries trial 0, not this retry
    assert not owes_retry(study.trials[failed.number], study.trials, max_retry=3)
    # The duplicate, run now, is surplus whatever happened to the first copy: it would add a retry to the chain
    assert surplus_reason(duplicate.number, study.trials, total=10, max_retry=3) == f"trial {failed.number} is already retried"
    storage.retry_failed_trials(study, "host:2")
    (retry_of_retry,) = [t for t in study.get_trials(states=(TrialState.WAITING,)) if t.number != duplicate.number]
    assert retry_of_retry.system_attrs["retry_history"] == [failed.number, retry.number]


def test_a_stale_trial_that_had_failed_by_itself_is_not_retried(tmp_path: Path) -> None:
    # Its error was recorded, then its worker lost the database before it could record the FAIL: found stale later
    study, storage = sqlite_study(tmp_path)
    for attribute in ("error", "surplus"):
        trial = add_trial(study, TrialState.RUNNING)
        study._storage.set_trial_user_attr(trial._trial_id, attribute, "ValueError: a bug" if attribute == "error" else True)
        study._storage.set_trial_state_values(trial._trial_id, state=TrialState.FAIL)
        queue_retry(storage, study, trial)
    assert not study.get_trials(states=(TrialState.WAITING,))
    # the same callback does queue a trial that failed by no error of its own
    queue_retry(storage, study, add_trial(study, TrialState.FAIL))
    assert len(waiting(study)) == 1


def test_a_retry_left_waiting_in_a_full_study_is_recorded_surplus(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # Two workers queued one retry; the first copy filled the study: the last worker out runs the other, as surplus
    def no_training(self: Any, trial: optuna.Trial) -> float:
        raise AssertionError(f"trial {trial.number} trained in a full study")

    monkeypatch.setattr(rl_zoo3.exp_manager.ExperimentManager, "objective", no_training)
    url = f"sqlite:///{tmp_path / 'study.db'}"
    storage = open_database_storage(url, FaultTolerance(1, 4, 3))
    study = optuna.create_study(storage=storage, study_name="full", direction="maximize")
    failed = add_trial(study, TrialState.FAIL, "host:1")
    queue_retry(storage, study, failed)
    queue_retry(storage, study, failed)
    retry = study.ask()
    study.tell(retry, 1.0)
    assert main([*optimize_args(url, "full", 100, total=1), "-f", str(tmp_path / "logs")]) == 0
    trials = optuna.load_study(study_name="full", storage=url).trials
    assert [(t.state, t.user_attrs.get("surplus")) for t in trials] == [
        (TrialState.FAIL, None),
        (TrialState.COMPLETE, None),
        (TrialState.FAIL, True),
    ]


def test_a_trial_that_never_beat_is_failed_and_retried(tmp_path: Path) -> None:
    # A worker that died (or lost the database) before its heartbeat thread wrote once: Optuna alone never fails it
    study, storage = sqlite_study(tmp_path)  # heartbeat every 1 s, grace period 4 s
    silent = add_trial(study, TrialState.RUNNING)  # asked, no heartbeat thread
    beating = add_trial(study, TrialState.RUNNING)

    def look_for_stale_trials() -> bool:
        storage.record_heartbeat(beating._trial_id)
        optuna.storages.fail_stale_trials(study)
        return study.trials[silent.number].state == TrialState.FAIL

    assert not look_for_stale_trials()  # first seen silent now
    assert not look_for_stale_trials()  # not silent for the grace period yet
    wait_until(look_for_stale_trials, "the silent trial failed")
    assert study.trials[beating.number].state == TrialState.RUNNING
    assert waiting(study) == [silent.number]


def test_a_silent_trial_is_timed_per_study(tmp_path: Path) -> None:
    # Looking for the stale trials of another study of the same storage does not restart a silent trial's clock
    study, storage = sqlite_study(tmp_path)  # heartbeat every 1 s, grace period 4 s
    other = optuna.create_study(storage=storage, direction="maximize")
    silent = add_trial(study, TrialState.RUNNING)

    def look_at_both() -> bool:
        optuna.storages.fail_stale_trials(other)
        optuna.storages.fail_stale_trials(study)
        return study.trials[silent.number].state == TrialState.FAIL

    wait_until(look_at_both, "the silent trial failed while another study is looked at", interval=0.1)
    assert waiting(study) == [silent.number] and not waiting(other)


def test_a_trial_failed_by_its_own_error_is_not_retried(tmp_path: Path) -> None:
    # The objective records the error of a trial that failed by itself: retrying it would only fail again
    study, storage = sqlite_study(tmp_path)
    trial = study.ask()
    trial.set_user_attr("worker", "host:1")
    trial.set_user_attr("error", "ValueError: a bug")
    study.tell(trial, state=TrialState.FAIL)
    assert not owes_retry(study.trials[0], study.trials, max_retry=3)
    storage.retry_failed_trials(study, "host:1", orphaned_after=0)
    assert not study.get_trials(states=(TrialState.WAITING,))


def test_a_trial_out_of_retries_frees_its_slot(tmp_path: Path) -> None:
    study, storage = sqlite_study(tmp_path, max_retry=1)
    failed = add_trial(study, TrialState.FAIL)
    storage.retry_failed_trials(study, "host:1")
    retry = study.ask()
    study.tell(retry, state=TrialState.FAIL)  # the retry fails in turn: no retry is left
    storage.retry_failed_trials(study, "host:1")
    assert not study.get_trials(states=(TrialState.WAITING,))
    assert not owes_retry(study.trials[retry.number], study.trials, max_retry=1)
    assert held_slots(study.trials, max_retry=1) == 0
    fresh = add_trial(study, TrialState.RUNNING)
    assert surplus_reason(fresh.number, study.trials, total=1, max_retry=1) is None
    assert retried_trial_number(study.trials[retry.number]) == failed.number


def run_main(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str]]:
    status = main(args)
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip() and "Warning" not in line]
    return status, lines


def test_wrong_credentials(postgres: PostgresServer, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status, lines = run_main(optimize_args(postgres.url_with(password="wrong"), "any", 100, 1), capsys)
    assert status == 2 and len(lines) == 1, lines
    assert "password authentication failed" in lines[0] and "wrong" not in lines[0]  # the password is not shown


def test_study_with_the_other_direction(postgres: PostgresServer, capsys: pytest.CaptureFixture[str]) -> None:
    optuna.create_study(study_name="minimizing", storage=postgres.url, direction="minimize")
    status, lines = run_main(optimize_args(postgres.url, "minimizing", 100, 1), capsys)
    assert status == 2 and len(lines) == 1 and "minimize" in lines[0], lines
    assert not optuna.load_study(study_name="minimizing", storage=postgres.url).trials


def test_unreachable_server(capsys: pytest.CaptureFixture[str]) -> None:
    # Port 1 on the loopback: nothing listens there
    url = "postgresql+psycopg://user:secret@127.0.0.1:1/optuna"
    status, lines = run_main(optimize_args(url, "any", 100, 1), capsys)
    assert status == 2 and len(lines) == 1, lines
    assert "cannot use the database" in lines[0] and "secret" not in lines[0]


def test_missing_driver(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "psycopg", None)  # as if the [postgresql] extra were not installed
    status, lines = run_main(optimize_args("postgresql+psycopg://user:pw@127.0.0.1:5432/optuna", "any", 100, 1), capsys)
    assert status == 2 and len(lines) == 1, lines
    assert "pip install 'sb3-reinforce[postgresql]'" in lines[0]


def test_fault_tolerance_flags_are_checked(capsys: pytest.CaptureFixture[str]) -> None:
    args = optimize_args("postgresql+psycopg://user:pw@127.0.0.1:1/optuna", "any", 100, 1)
    status, lines = run_main([*args, "--grace-period", "1"], capsys)
    assert status == 2 and len(lines) == 1 and "--grace-period" in lines[0], lines
    with pytest.raises(StorageError, match="max-retry"):
        FaultTolerance(max_retry=-1)


def test_usage_documents_the_defaults(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--help"]) == 0
    usage = capsys.readouterr().out
    defaults = FaultTolerance()
    for flag, value in [
        ("--heartbeat-interval", defaults.heartbeat_interval),
        ("--grace-period", defaults.grace_period),
        ("--max-retry", defaults.max_retry),
    ]:
        line = next(line for line in usage.splitlines() if line.strip().startswith(flag))
        assert f"(default: {value})" in line


def test_errors_raised_while_handling_a_database_error_count_as_database_errors() -> None:
    import sqlalchemy.exc

    try:
        try:
            raise sqlalchemy.exc.OperationalError("SELECT 1", {}, Exception("server closed the connection"))
        except sqlalchemy.exc.OperationalError:
            raise UnboundLocalError("as in Optuna's _run_trial when get_trial fails")  # noqa: B904
    except UnboundLocalError as error:
        assert caused_by_database(error)
    assert not caused_by_database(ValueError("a bug of ours"))
