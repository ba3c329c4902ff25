"""What the environments add, in ratios measured side by side in one run (issue 34, item 5).

    python bench/envs.py                               # every table, 5 rounds
    python bench/envs.py --rounds 3 --backends mujoco  # one engine
    python bench/envs.py --skip-vector                 # the env step alone

Table 1, per engine: ``SimEnv("cartpole").step`` (action checked and clipped, held over 5
physics steps as a force, the observation, reward, terminations and success read) against a
hand-written :class:`~simbridge.Sim` loop doing the same commands and reads (joint indices
looked up once; per control step ``set_joint_torque`` and ``step()`` five times, then one
``joint_states`` of cart and pole: the observation, and the two limits checked on it). Both
run the same seeded actions; only the steps are timed (a reset, when an episode ends, is not);
the target is 1.10x.

Table 2, MuJoCo, N worlds: env-steps per second of :class:`SimVectorEnv` (one process, worlds
in turn; ``--threads``: in a thread pool), of Gymnasium's ``AsyncVectorEnv`` over the same
task (one process per world), and of Gymnasium's own ``InvertedPendulum-v5`` (MuJoCo; a cart
and a hinged pole, 2 physics steps of 0.02 s per env step, where simbridge's cart-pole takes 5
of 1/240 s) in Gymnasium's ``SyncVectorEnv``; random actions, episodes autoreset. Physics steps
per second are given too, since the two models step differently.

Each round times every row once, in turn; the table gives each ratio's median over rounds and
its spread (least, greatest). The machine is shared: read the ratios, not the times.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np

CART, POLE = "slider_to_cart", "cart_to_pole"


CLOCKS = {"cpu": time.process_time, "wall": time.perf_counter}


def clock_cost(clock: Callable[[], float]) -> float:
    """Seconds one ``start = clock(); ... clock() - start`` pair adds to a timed step."""
    n, total = 20000, 0.0
    for _ in range(n):
        start = clock()
        total += clock() - start
    return total / n


def env_runner(backend: str, clock: Callable[[], float]) -> tuple[Callable, Callable]:
    """(run, close): ``run(actions)`` steps SimEnv through them and returns the seconds spent in
    ``step`` (a reset, when an episode ends, is not timed)."""
    from simbridge.envs import SimEnv

    env = SimEnv("cartpole", backend=backend)
    env.reset(seed=0)

    def run(actions: np.ndarray) -> float:
        elapsed = 0.0
        for a in actions:
            start = clock()
            _, _, terminated, truncated, _ = env.step(a)
            elapsed += clock() - start
            if terminated or truncated:
                env.reset()
        return elapsed

    return run, env.close


def hand_runner(backend: str, clock: Callable[[], float]) -> tuple[Callable, Callable]:
    """(run, close) of the hand-written Sim loop doing the env's commands and reads.

    Its world is built as the env builds it (the same Sim, robot, released pole, brake off);
    a reset restores the snapshot and draws the initial state, untimed."""
    from simbridge.envs import SimEnv

    env = SimEnv("cartpole", backend=backend)  # builds the world; the loop below uses its Sim
    sim, body = env.sim, env.world.body
    joints = np.array([sim.joint_index(body, CART), sim.joint_index(body, POLE)])
    cart = joints[:1]
    snapshot = sim.get_state(exact=True)
    rng = np.random.default_rng(0)
    steps = 0

    def reset() -> None:
        sim.set_state(snapshot)
        q0, qd0 = rng.uniform(-0.05, 0.05, 2), rng.uniform(-0.05, 0.05, 2)
        sim.reset_joint_state(body, joints, q0, qd0)

    def run(actions: np.ndarray) -> float:
        nonlocal steps
        elapsed = 0.0
        for a in actions:
            start = clock()
            force = np.clip(a, -1.0, 1.0) * 10.0
            for _ in range(5):
                sim.set_joint_torque(body, cart, force)
                sim.step()
            s = sim.joint_states(body, joints)
            obs = np.concatenate([s.positions, s.velocities]).astype(np.float32)
            steps += 1
            done = abs(obs[1]) > 0.2095 or abs(obs[0]) > 2.4 or steps >= 500
            elapsed += clock() - start
            if done:
                reset()
                steps = 0
        return elapsed

    reset()
    return run, env.close


def time_vector(make: Callable[[], object], n: int, steps: int) -> float:
    """Env-steps per second of a vector env over ``steps`` steps of random actions (after 20)."""
    venv = make()
    venv.reset(seed=0)  # type: ignore[attr-defined]
    space = venv.action_space  # type: ignore[attr-defined]
    space.seed(0)
    acts = [space.sample() for _ in range(steps + 20)]
    for a in acts[:20]:
        venv.step(a)  # type: ignore[attr-defined]
    start = time.perf_counter()
    for a in acts[20:]:
        venv.step(a)  # type: ignore[attr-defined]
    elapsed = time.perf_counter() - start
    venv.close()  # type: ignore[attr-defined]
    return n * steps / elapsed


def vector_makers(n: int, threads: int) -> dict[str, Callable[[], object]]:
    """The vector envs of table 2, by row name."""
    import gymnasium as gym

    from simbridge.envs import SimEnv
    from simbridge.envs.vector import SimVectorEnv

    def one() -> SimEnv:
        return SimEnv("cartpole", backend="mujoco")

    makers: dict[str, Callable[[], object]] = {
        "SimVectorEnv": lambda: SimVectorEnv(n, "cartpole", backend="mujoco"),
        "AsyncVectorEnv(SimEnv)": lambda: gym.vector.AsyncVectorEnv([one] * n),
        "InvertedPendulum-v5 sync": lambda: gym.make_vec(
            "InvertedPendulum-v5", n, vectorization_mode="sync"
        ),
    }
    if threads:
        makers[f"SimVectorEnv threads={threads}"] = lambda: SimVectorEnv(
            n, "cartpole", backend="mujoco", threads=threads
        )
    return makers


def spread(values: list[float]) -> str:
    """``median (least-greatest)``."""
    return f"{statistics.median(values):.2f} ({min(values):.2f}-{max(values):.2f})"


def step_table(backends: list[str], rounds: int, steps: int, clock_name: str) -> None:
    """Table 1: the env step against the hand-written loop, per engine, in alternating blocks
    of ``steps`` control steps (the ratio of each adjacent pair: slow drifts in the machine's
    load cancel)."""
    clock = CLOCKS[clock_name]
    cost = clock_cost(clock)
    actions = np.random.default_rng(1).uniform(-1, 1, (steps, 1)).astype(np.float32)
    print(
        f"\nenv step against a hand-written Sim loop, cart-pole: {rounds} alternating blocks "
        f"of {steps} steps, {clock_name} clock (its own cost, {cost * 1e6:.2f} us, taken off)"
    )
    print("| engine | env us/step | hand us/step | ratio median (spread) | target |")
    print("|---|---|---|---|---|")
    for b in backends:
        (env_run, env_close), (hand_run, hand_close) = env_runner(b, clock), hand_runner(b, clock)
        env_run(actions[:200]), hand_run(actions[:200])  # warm-up
        env_us, hand_us = [], []
        for _ in range(rounds):
            env_us.append((env_run(actions) / steps - cost) * 1e6)
            hand_us.append((hand_run(actions) / steps - cost) * 1e6)
        env_close(), hand_close()
        ratios = [e / h for e, h in zip(env_us, hand_us, strict=True)]
        print(
            f"| {b} | {statistics.median(env_us):.0f} | {statistics.median(hand_us):.0f} "
            f"| {spread(ratios)} | <= 1.10 |"
        )


def vector_table(n: int, threads: int, rounds: int, steps: int) -> None:
    """Table 2: vector-env throughput on MuJoCo."""
    makers = vector_makers(n, threads)
    rates: dict[str, list[float]] = {k: [] for k in makers}
    for _ in range(rounds):
        for name, make in makers.items():
            rates[name].append(time_vector(make, n, steps))
    physics = {"InvertedPendulum-v5 sync": 2}
    base = rates["SimVectorEnv"]
    print(f"\nvector envs on MuJoCo, {n} worlds, {steps} steps x {rounds} rounds")
    print("| vector env | env-steps/s | physics steps/s | SimVectorEnv / it, median (spread) |")
    print("|---|---|---|---|")
    for name, r in rates.items():
        med = statistics.median(r)
        ratios = [s / x for s, x in zip(base, r, strict=True)]
        print(f"| {name} | {med:.0f} | {med * physics.get(name, 5):.0f} | {spread(ratios)} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--backends", nargs="+", default=["pybullet", "mujoco", "physx"])
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--steps", type=int, default=500, help="control steps a block, table 1")
    ap.add_argument("--clock", choices=sorted(CLOCKS), default="cpu", help="table 1's clock")
    ap.add_argument("--worlds", type=int, default=4)
    ap.add_argument("--threads", type=int, default=0, help="also SimVectorEnv with a pool")
    ap.add_argument("--vector-steps", type=int, default=500)
    ap.add_argument("--skip-vector", action="store_true")
    args = ap.parse_args()
    step_table(args.backends, args.rounds, args.steps, args.clock)
    if not args.skip_vector:
        vector_table(args.worlds, args.threads, args.rounds, args.vector_steps)


if __name__ == "__main__":
    main()
