"""Time limits: bootstrapped with gamma * V(s_T) under a value baseline, terminal without one."""

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_reinforce import REINFORCE
from tests.envs import CountingEnv


class Check(BaseCallback):
    def __init__(self, gamma: float) -> None:
        super().__init__()
        self.gamma = gamma
        self.terminal_values: dict[tuple[float, float], float] = {}
        self.checked = 0

    def _on_step(self) -> bool:
        for done, info in zip(self.locals["dones"], self.locals["infos"], strict=True):
            if done:
                terminal = info["terminal_observation"]
                with th.no_grad():
                    value = self.model.policy.predict_values(th.as_tensor(terminal[None], dtype=th.float32)).item()
                self.terminal_values[(terminal[0], terminal[1])] = value if info.get("TimeLimit.truncated") else 0.0
        return True

    def _on_rollout_end(self) -> None:
        buffer = self.model.rollout_buffer
        obs, returns = buffer._batch["observations"], buffer.returns
        start = 0
        for length in buffer.episode_lengths:
            # the terminal observation's serial number follows the episode's last one
            bootstrap = self.terminal_values[(obs[start + length - 1, 0], obs[start + length - 1, 1] + 1)]
            for t in range(length):
                expected = sum(self.gamma ** (k - t) * (k + 1) for k in range(t, length))
                expected += self.gamma ** (length - t) * bootstrap
                np.testing.assert_allclose(returns[start + t], expected, rtol=1e-5)
                self.checked += 1
            start += length


@pytest.mark.parametrize("baseline", [None, "value"])
@pytest.mark.parametrize("truncate", [False, True])
def test_truncation(baseline: str | None, truncate: bool) -> None:
    gamma = 0.9
    env = DummyVecEnv([lambda i=i: CountingEnv(i, (4, 6), truncate=truncate) for i in range(2)])
    model = REINFORCE("MlpPolicy", env, gamma=gamma, baseline=baseline, seed=0)
    check = Check(gamma)
    model.learn(100, callback=check)
    assert check.checked >= 100
    bootstrapped = [v for v in check.terminal_values.values() if v != 0.0]
    # With a value baseline, truncated episodes get gamma * V(s_T); otherwise they are terminal.
    assert bool(bootstrapped) == (baseline == "value" and truncate)
