import sys

import pytest
from stable_baselines3.common.envs import IdentityEnv

from sb3_reinforce import REINFORCE
from sb3_reinforce.reinforce.native_memory import HeapTrimmer, trim_heap

HAS_MALLOC_TRIM = trim_heap()  # glibc: True (a harmless call); elsewhere nothing happens


def test_trim_heap_available_on_linux_glibc() -> None:
    import platform

    if sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc":
        assert HAS_MALLOC_TRIM
    else:
        assert not HAS_MALLOC_TRIM


@pytest.mark.skipif(not HAS_MALLOC_TRIM, reason="no malloc_trim in this C library")
def test_heap_trimmer_interval() -> None:
    trimmer = HeapTrimmer(100)
    for step in (0, 50, 99):
        trimmer.step(step)
    assert trimmer.n_trims == 0
    trimmer.step(100)
    trimmer.step(150)
    assert trimmer.n_trims == 1
    trimmer.step(205)
    assert trimmer.n_trims == 2
    # learn(reset_num_timesteps=True) restarts the step counter: trimming goes on from there
    trimmer.step(10)
    trimmer.step(110)
    assert trimmer.n_trims == 3
    never = HeapTrimmer(None)
    for step in range(0, 10_000, 100):
        never.step(step)
    assert never.n_trims == 0


@pytest.mark.skipif(not HAS_MALLOC_TRIM, reason="no malloc_trim in this C library")
def test_reinforce_trims_the_heap_during_learn(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(REINFORCE, "heap_trim_interval", 100)
    model = REINFORCE("MlpPolicy", IdentityEnv(4), seed=0).learn(1000)  # IdentityEnv: 100-step episodes
    assert model._heap_trimmer.n_trims >= 8
    # The trimmer is run-time state: not saved, rebuilt on load
    model.save(tmp_path / "model.zip")
    loaded = REINFORCE.load(tmp_path / "model.zip")
    assert loaded._heap_trimmer.n_trims == 0 and loaded._heap_trimmer.interval == 100
