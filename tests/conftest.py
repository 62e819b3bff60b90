import os

import pytest
import torch as th

from tests.alone import run_alone_when_marked  # noqa: F401 (a fixture: every test takes its lock)

# Two cores in CI: keep torch from oversubscribing them when pytest-xdist runs workers side by side.
th.set_num_threads(1)
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
# MuJoCo renders (record-video of a shipped MuJoCo agent) offscreen with EGL: CI has no display for its default GLFW
os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture(autouse=True)
def _no_cuda(monkeypatch: pytest.MonkeyPatch) -> None:
    # The suite is meant for the CPU: same numbers everywhere.
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "")
