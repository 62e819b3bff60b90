"""Failing environments: the original error, which env and which call, and never a hang."""

import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

from sb3_reinforce import REINFORCE
from sb3_reinforce.safeguards.env_errors import EnvError, EnvWorkerDiedError, make_safe_vec_env
from tests.envs import CountingEnv

# fork: fast to start under pytest. It is also the hardest case for a dead worker: the other workers
# inherit its end of the pipe, so the pipe never reports EOF (see VecEnvErrorCheck).
SUBPROC = dict(start_method="fork")


class FailingEnv(CountingEnv):
    """Raises ``ZeroDivisionError`` at its ``when``-th call to ``where`` (``"step"``, ``"reset"`` or ``"sleep"``)."""

    def __init__(self, where: str, when: int):
        super().__init__(0, (4,))
        self.where, self.when = where, when
        self.calls = {"step": 0, "reset": 0}

    def step(self, action: int) -> tuple:
        self.calls["step"] += 1
        if self.calls["step"] == self.when:
            if self.where == "step":
                raise ZeroDivisionError("the env divided by zero in step")
            if self.where == "sleep":
                time.sleep(3600)
        return super().step(action)

    def reset(self, **kwargs) -> tuple:
        self.calls["reset"] += 1
        if self.where == "reset" and self.calls["reset"] == self.when:
            raise ZeroDivisionError("the env divided by zero in reset")
        return super().reset(**kwargs)


@pytest.mark.parametrize("vec_env_cls", [DummyVecEnv, SubprocVecEnv])
@pytest.mark.parametrize("where, when", [("step", 7), ("reset", 1), ("reset", 3)])
def test_env_error_names_env_and_call(vec_env_cls: type, where: str, when: int) -> None:
    """reset #1 is the first reset, reset #3 an automatic reset at the end of an episode (inside step)."""
    env_fns = [lambda: CountingEnv(0, (4,)), lambda: CountingEnv(1, (3,)), lambda: FailingEnv(where, when)]
    venv = make_safe_vec_env(env_fns, vec_env_cls, SUBPROC if vec_env_cls is SubprocVecEnv else None)
    model = REINFORCE("MlpPolicy", venv, n_episodes=2, seed=0)
    with pytest.raises(EnvError) as info:
        model.learn(200)
    error = info.value
    assert (error.env_index, error.call, error.original_type) == (2, where, "ZeroDivisionError")
    assert f"the env divided by zero in {where}" in str(error)
    assert "Environment 2 raised ZeroDivisionError" in str(error)
    assert "tests/envs.py" in error.original_traceback or "test_env_errors.py" in error.original_traceback
    venv.close()


def test_dummy_vec_env_error_keeps_cause() -> None:
    venv = make_safe_vec_env([lambda: FailingEnv("step", 2)])
    venv.reset()
    venv.step(np.zeros(1, dtype=int))
    with pytest.raises(EnvError, match="Environment 0 raised ZeroDivisionError in step"):
        venv.step(np.zeros(1, dtype=int))


def test_stuck_worker_times_out() -> None:
    venv = make_safe_vec_env([lambda: CountingEnv(0), lambda: FailingEnv("sleep", 2)], SubprocVecEnv, SUBPROC, timeout=1.0)
    venv.reset()
    venv.step(np.zeros(2, dtype=int))
    with pytest.raises(EnvWorkerDiedError, match=r"Environment 1 .* did not answer within 1.0 s"):
        venv.step(np.zeros(2, dtype=int))
    assert not venv.venv.processes[1].is_alive()
    venv.close()


KILL_SCENARIO = """
import os, signal, sys
sys.path.insert(0, {root!r})
import torch
torch.set_num_threads(1)
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import SubprocVecEnv
from sb3_reinforce import REINFORCE
from sb3_reinforce.safeguards.env_errors import EnvWorkerDiedError, make_safe_vec_env
from tests.envs import CountingEnv

class Kill(BaseCallback):
    def _on_step(self):
        if self.num_timesteps == 20 * self.training_env.num_envs:
            os.kill(self.training_env.venv.processes[{victim}].pid, signal.SIGKILL)
        return True

if __name__ == "__main__":
    venv = make_safe_vec_env([lambda: CountingEnv(i, (4,)) for i in range({n_envs})], SubprocVecEnv,
                             dict(start_method={start_method!r}))
    model = REINFORCE("MlpPolicy", venv, seed=0)
    try:
        model.learn(10_000, callback=Kill())
    except EnvWorkerDiedError as error:
        print("RAISED", error.env_index, error.call, model.num_timesteps, "|", error)
    venv.close()
    print("CLOSED")
"""


@pytest.mark.parametrize("n_envs, victim", [(1, 0), (3, 1)])
def test_killed_worker_clear_error_no_hang(n_envs: int, victim: int) -> None:
    """A worker killed mid-run: a clear error naming it, in bounded time (the harness's timeout stops a hang)."""
    root = str(__import__("pathlib").Path(__file__).resolve().parents[2])
    code = textwrap.dedent(KILL_SCENARIO).format(root=root, victim=victim, n_envs=n_envs, start_method="fork")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    raised = next(line for line in result.stdout.splitlines() if line.startswith("RAISED"))
    assert raised.startswith(f"RAISED {victim} step {20 * n_envs} |"), raised
    assert "killed by signal 9" in raised
    assert "CLOSED" in result.stdout
