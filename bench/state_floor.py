"""The one-step error of ``Sim.set_state``: each engine against itself (the floor of a resync).

    python bench/state_floor.py                     # every shipped scenario, both backends
    python bench/state_floor.py r2d2-gentle --every 5

For each scenario and backend, Sim A runs the scenario (its commands issued before every step,
as ``simbridge compare`` does). Every ``--every`` steps, just before A's step, A's state is
taken (``A.get_state()``) and

* ``exact``: A itself is set back to that state with its engine data, steps, is compared with
  the uninterrupted step, and is put back (must be 0: bit for bit);
* ``portable, same Sim``: A is set to ``state.portable()``: what the engine keeps of its past
  in this world (PyBullet's contact caches) stays;
* ``portable, other Sim``: a second Sim B of the same backend, the same robots loaded in the
  same order, is set to ``state.portable()`` and steps once: nothing of A's past reaches B.
  This is the floor of a cross-engine resync (engine B set from engine A's state).

The tables give the largest and the median error over the resync points of the subject
robot's base position (m), base velocity (m/s, rad/s) and joint velocities (rad/s).
Accuracy figures, not timings: the result does not depend on the machine's load.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

import simbridge
from simbridge.compare.scenario import Scenario, list_scenarios, load_scenario


def _world(sc: Scenario, backend: str) -> tuple[simbridge.Sim, dict[str, int]]:
    sim = simbridge.Sim(backend, gravity=sc.gravity, timestep=sc.timestep, profile=sc.profile)
    ids = {}
    for r in sc.robots:
        ids[r.name] = sim.load_urdf(
            sc.resolve_urdf(r),
            base_position=r.position,
            base_orientation=r.orientation,
            fixed_base=r.fixed_base,
        )
        for joint, q in r.joint_positions:
            sim.reset_joint_state(ids[r.name], joint, q)
    return sim, ids


def _issue(sim: simbridge.Sim, ids: dict[str, int], commands: Any) -> None:
    for c in commands:
        body = ids[c.robot]
        if c.mode == "velocity":
            sim.set_joint_velocity(body, list(c.joints), c.target, max_force=c.max_force)
        elif c.mode == "position":
            kw = {k: v for k, v in (("kp", c.kp), ("kd", c.kd)) if v is not None}
            sim.set_joint_position(body, list(c.joints), c.target, max_force=c.max_force, **kw)
        else:
            sim.set_joint_torque(body, list(c.joints), c.target)


def _observe(sim: simbridge.Sim, body: int) -> np.ndarray:
    s = sim.base_state(body)
    js = sim.joint_states(body)
    return np.concatenate([s.position, s.linear_velocity, s.angular_velocity, js.velocities])


def _errors(a: np.ndarray, b: np.ndarray) -> tuple[float, float, float]:
    d = np.abs(a - b)
    return float(d[0:3].max()), float(d[3:9].max()), float(d[9:].max(initial=0.0))


def measure(sc: Scenario, backend: str, every: int) -> dict[str, np.ndarray]:
    a, ids = _world(sc, backend)
    b, _ = _world(sc, backend)
    subject = ids[sc.subject]
    out: dict[str, list[tuple[float, float, float]]] = {
        "exact": [],
        "portable, same Sim": [],
        "portable, other Sim": [],
    }
    step = 0
    with a, b:
        for phase in sc.phases:
            for c in phase.commands:
                if c.mode == "torque":  # release the brake, as simbridge compare does
                    a.set_joint_velocity(ids[c.robot], list(c.joints), 0.0, max_force=0.0)
            for _ in range(phase.steps):
                _issue(a, ids, phase.commands)
                step += 1
                if step % every:
                    a.step()
                    continue
                state = a.get_state()
                a.step()
                truth = _observe(a, subject)
                after = a.get_state()
                for name, sim, st in (
                    ("exact", a, state),
                    ("portable, same Sim", a, state.portable()),
                    ("portable, other Sim", b, state.portable()),
                ):
                    sim.set_state(st)
                    sim.step()
                    out[name].append(_errors(_observe(sim, subject), truth))
                a.set_state(after)  # back on A's own path, bit for bit
    return {k: np.array(v) for k, v in out.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenarios", nargs="*", help="shipped names or TOML files (all)")
    parser.add_argument("--every", type=int, default=10, help="steps between resyncs")
    parser.add_argument("--backends", default="pybullet,mujoco")
    args = parser.parse_args()
    scenarios = [load_scenario(s) for s in args.scenarios] or list_scenarios()
    print(
        "| scenario | backend | restore | points | base position (max, median) m "
        "| base velocity (max, median) | joint velocity (max, median) rad/s |"
    )
    print("|---|---|---|---|---|---|---|")
    for sc in scenarios:
        for backend in args.backends.split(","):
            for name, e in measure(sc, backend, args.every).items():
                cells = " | ".join(
                    f"{e[:, k].max():.2g}, {np.median(e[:, k]):.2g}" for k in range(3)
                )
                print(f"| {sc.name} | {backend} | {name} | {len(e)} | {cells} |")


if __name__ == "__main__":
    main()
