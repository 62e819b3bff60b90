"""
Record one deterministic episode of a shipped agent as an animated GIF (for the README and the docs), with the
agent's own test environment as ``sb3-reinforce-zoo enjoy`` builds it (its config and VecNormalize statistics).

    python benchmarks/agents/animate.py --env LunarLander-v3 --seed 10000 --out docs/images/reinforce_lunarlander.gif
    MUJOCO_GL=egl python benchmarks/agents/animate.py --env HalfCheetah-v4 --max-steps 300 --camera track --out ...
"""

import argparse
from pathlib import Path

import numpy as np
from PIL import Image
from rl_zoo3.utils import create_test_env, get_saved_hyperparams
from stable_baselines3.common.vec_env import VecNormalize

from sb3_reinforce import REINFORCE


def record(
    folder: Path, env_id: str, seed: int, every: int, scale: float, max_steps: int | None = None, camera: str | None = None
) -> tuple[list[Image.Image], float]:
    """
    The frames of one deterministic episode (every ``every``-th, scaled by ``scale``; its first ``max_steps`` steps
    only, if given) and its return (of those steps, where cut); ``camera``: a MuJoCo env's camera by name.
    """
    log_path = folder / "reinforce" / f"{env_id}_1"
    hyperparams, stats_path = get_saved_hyperparams(str(log_path / env_id), norm_reward=False, test_mode=True)
    env = create_test_env(
        env_id,
        n_envs=1,
        stats_path=stats_path,
        seed=seed,
        log_dir=None,
        should_render=False,
        hyperparams=hyperparams,
        env_kwargs={"render_mode": "rgb_array", **({} if camera is None else {"camera_name": camera})},
    )
    model = REINFORCE.load(log_path / f"{env_id}.zip", device="cpu")
    env.seed(seed)
    obs = env.reset()
    frames, total, done, step = [], 0.0, False, 0
    while not done and (max_steps is None or step < max_steps):
        if step % every == 0:
            image = Image.fromarray(np.asarray(env.render()))
            frames.append(image.resize((int(image.width * scale), int(image.height * scale)), Image.Resampling.LANCZOS))
        action, _ = model.predict(obs, deterministic=True)  # type: ignore[arg-type]
        obs, reward, dones, _ = env.step(action)
        done, step = bool(dones[0]), step + 1
        total += float((env.get_original_reward() if isinstance(env, VecNormalize) else reward)[0])
    env.close()
    return frames, total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--folder", type=Path, default=Path("rl-trained-agents"))
    parser.add_argument("--env", required=True)
    parser.add_argument("--seed", type=int, default=10_000, help="an evaluation seed no training episode used")
    parser.add_argument("--every", type=int, default=2, help="keep one frame in this many")
    parser.add_argument("--scale", type=float, default=0.5)
    parser.add_argument("--fps", type=int, default=25)
    parser.add_argument("--max-steps", type=int, default=None, help="the episode's first steps only (default: all)")
    parser.add_argument("--camera", default=None, help="a MuJoCo env's camera, e.g. track (default: the env's)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    frames, total = record(args.folder, args.env, args.seed, args.every, args.scale, args.max_steps, args.camera)
    palette = [frame.convert("P", palette=Image.Palette.ADAPTIVE, colors=64) for frame in frames]
    palette[0].save(args.out, save_all=True, append_images=palette[1:], duration=1000 * args.every // args.fps, loop=0)
    cut = "" if args.max_steps is None else f" (its first {args.max_steps} steps at most)"
    print(f"{args.out}: {len(frames)} frames, return {total:.1f}{cut}, {args.out.stat().st_size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
