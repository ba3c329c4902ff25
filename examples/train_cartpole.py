"""Train PPO on simbridge/CartPole-v0 on one engine, on CPU, and export the policy.

    pip install -e ".[rl]"          # stable-baselines3 and the CPU build of torch
    python examples/train_cartpole.py --backend mujoco --timesteps 60000 --out runs/cartpole

writes, under --out: ``ppo.zip`` (Stable-Baselines3's own file), ``cartpole_ppo.npz`` (the
actor's layers for :mod:`simbridge.envs.policy`, run in NumPy without torch: the mean action) and
``cartpole_ppo.onnx`` where the ``onnx`` package is installed. The NumPy policy is checked
against Stable-Baselines3's deterministic ``predict`` on 256 observations, then run for
--episodes episodes on the training engine (success with a 95% Wilson interval). One thread,
one process: a few minutes on one core.

With --vecnormalize the training env is wrapped in Stable-Baselines3's ``VecNormalize``
(observations and rewards) and its statistics are saved beside the zip as
``vec_normalize.pkl``: the exported actor then acts on normalised observations, and
``simbridge sim2sim OUT/ppo.zip`` finds and applies the file (docs/sim2sim.md).
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np


def actor_layers(model) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The deterministic actor of an SB3 PPO MlpPolicy: its hidden layers, then action_net,
    as (in, out) matrices and biases."""
    import torch

    linears = [m for m in model.policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
    linears.append(model.policy.action_net)
    weights = [m.weight.detach().cpu().numpy().T.copy() for m in linears]
    biases = [m.bias.detach().cpu().numpy().copy() for m in linears]
    return weights, biases


def export_onnx(model, path: Path, obs_size: int) -> bool:
    """The actor (mean action, unclipped) as ONNX; False where torch's exporter cannot run."""
    import torch

    try:
        import onnx  # noqa: F401
    except ImportError:
        return False
    actor = torch.nn.Sequential(model.policy.mlp_extractor.policy_net, model.policy.action_net)
    dummy = torch.zeros(1, obs_size)
    try:
        torch.onnx.export(
            actor,
            (dummy,),
            str(path),
            input_names=["obs"],
            output_names=["action"],
            dynamic_axes={"obs": {0: "batch"}, "action": {0: "batch"}},
            dynamo=False,
        )
    except Exception as exc:  # the exporter's own dependencies (onnxscript) may be missing
        print(f"ONNX export skipped: {exc}")
        return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--backend", default="mujoco", choices=["pybullet", "mujoco", "physx"])
    ap.add_argument("--timesteps", type=int, default=60_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--envs", type=int, default=4, help="worlds stepped together while training")
    ap.add_argument("--episodes", type=int, default=50, help="evaluation episodes (0: none)")
    ap.add_argument("--out", type=Path, default=Path("runs/cartpole"))
    ap.add_argument(
        "--vecnormalize",
        action="store_true",
        help="train under VecNormalize; its statistics saved as OUT/vec_normalize.pkl",
    )
    args = ap.parse_args()

    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    import simbridge.envs  # registers simbridge/CartPole-v0
    from simbridge.envs.evaluate import success_rate
    from simbridge.envs.policy import save_mlp

    torch.set_num_threads(1)
    args.out.mkdir(parents=True, exist_ok=True)
    venv = make_vec_env(
        "simbridge/CartPole-v0",
        n_envs=args.envs,
        seed=args.seed,
        env_kwargs={"backend": args.backend},
    )
    if args.vecnormalize:
        from stable_baselines3.common.vec_env import VecNormalize

        venv = VecNormalize(venv)
    model = PPO(
        "MlpPolicy",
        venv,
        seed=args.seed,
        n_steps=512,
        batch_size=128,
        n_epochs=10,
        gamma=0.99,
        gae_lambda=0.95,
        learning_rate=1e-3,
        policy_kwargs={"net_arch": [32, 32]},
        device="cpu",
        verbose=0,
    )
    start = time.perf_counter()
    model.learn(total_timesteps=args.timesteps)
    seconds = time.perf_counter() - start
    model.save(args.out / "ppo.zip")
    stats = args.out / "vec_normalize.pkl"
    if args.vecnormalize:
        venv.save(str(stats))
    venv.close()
    print(f"trained {args.timesteps} steps on {args.backend} in {seconds:.0f} s")

    weights, biases = actor_layers(model)
    meta = {
        "task": "cartpole",
        "algorithm": "PPO (Stable-Baselines3), MlpPolicy net_arch [32, 32], deterministic",
        "trained_on": args.backend,
        "timesteps": args.timesteps,
        "seed": args.seed,
        "train_seconds": round(seconds, 1),
        "observation": "normalised by vec_normalize.pkl" if args.vecnormalize else "as the env's",
        "command": "python " + shlex.join(sys.argv),
    }
    policy = save_mlp(args.out / "cartpole_ppo.npz", weights, biases, meta=meta)

    task = simbridge.envs.load_task("cartpole")
    if args.vecnormalize:  # the env normalises as VecNormalize did (simbridge.envs.vecnormalize)
        from simbridge.envs.vecnormalize import resolve

        task, _ = resolve(task, str(args.out / "ppo.zip"), stats)
    env = simbridge.envs.SimEnv(task, backend=args.backend)
    obs = np.stack([env.observation_space.sample() * 0.2 for _ in range(256)]).astype(np.float32)
    ref, _ = model.predict(obs, deterministic=True)
    ours = np.stack([policy(o) for o in obs])
    print(f"NumPy policy against SB3's predict: max |difference| {np.abs(ours - ref).max():.2e}")
    if export_onnx(model, args.out / "cartpole_ppo.onnx", obs.shape[1]):
        print(f"wrote {args.out / 'cartpole_ppo.onnx'}")
    if args.episodes:
        rate, eps = success_rate(env, policy, range(args.episodes))
        print(
            f"{args.backend}: {rate.successes}/{rate.n} episodes balanced "
            f"(95% Wilson {rate.low:.2f}-{rate.high:.2f}), mean steps "
            f"{np.mean([e.steps for e in eps]):.0f}"
        )
    env.close()


if __name__ == "__main__":
    main()
