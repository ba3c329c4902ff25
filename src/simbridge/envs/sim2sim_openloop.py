"""The training engine's actions replayed open loop on the other engines: where the physics
parts (:func:`openloop`; its report: :mod:`.sim2sim_openloop_report`).

For each of the first few seeds of a ``simbridge sim2sim`` run:

1. the policy runs on the training engine, closed loop, and every action it sends is logged
   (the same episode as the paired run's: ``reset(seed=...)`` gives the same initial state);
2. that action log is replayed open loop, the same seed and initial state, on every engine,
   the training engine included: ``ensemble`` runs per engine, run 0 as it is and run k >= 1
   with every movable joint of the action's robot (and a free base's pose) moved by a tiny
   seeded offset, ``perturb`` rad or m (raised for a float32 engine as compare's ensembles
   raise it: :func:`simbridge.compare.run.offsets.engine_perturbation`), the same directions on
   every engine; and once more at half the time step (twice the decimation: the same control
   period), for each engine's own time-step error;
3. each engine's runs are judged against the training engine's by compare's verdict
   (:func:`simbridge.compare.analysis.verdict.judge`: ``agree``, ``chaotic``, ``unresolved``,
   ``differ``, the gap with its bootstrap interval) in each quantity of the robot's state
   (:data:`QUANTITIES`: the joint positions' RMS, and a free base's position and
   orientation). The training engine's own runs give the chaos floor: where its tiny offsets
   grow as large as the gap, the replay cannot tell the engines apart.

"Where the physics parts" (:attr:`Replay.parts_at`) is the first instant at which the gap
reaches the quantity's tolerance (1 cm, 1 degree) and more than ``MARGINAL[1]`` (2) times the
training engine's spread: the other engine's runs leave the training engine's envelope.

The replay of the training engine on itself (its run 0) repeats the logged closed-loop episode
(:attr:`OpenLoop.reproduces` gives the largest difference; 0 where the engine steps
deterministically): a replay that did not would be the harness's fault, not the physics'.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.envs.task import Task

if TYPE_CHECKING:
    from simbridge.compare.analysis.verdict import Verdict
    from simbridge.envs.env import SimEnv
    from simbridge.envs.paired import Engine

__all__ = [
    "DEFAULT_ENSEMBLE",
    "DEFAULT_PERTURB",
    "DEFAULT_SEEDS",
    "QUANTITIES",
    "SEVERITY",
    "OpenLoop",
    "Replay",
    "openloop",
]

DEFAULT_SEEDS = 4
"""Seeds replayed open loop by ``simbridge sim2sim`` (``--openloop``)."""
DEFAULT_ENSEMBLE = 8
"""Runs per engine and seed, the unperturbed one included (``--openloop-ensemble``): 4 is the
fewest with which compare's permutation test can separate two ensembles at p < 0.05."""
DEFAULT_PERTURB = 1e-9
"""Each perturbed run's offset, rad or m (compare's ensembles' default)."""
QUANTITIES = ("joint_position_rms", "base_distance", "orientation")
"""compare's quantities judged: the joint positions (every robot), the base position and
orientation (a free base only)."""
SEVERITY = ("agree", "chaotic", "unresolved", "differ")
"""The verdicts from the mildest: a seed's verdict is its quantities' most severe."""

_SOURCES = {"joint_position_rms": "q", "base_distance": "p", "orientation": "o"}


@dataclass
class Replay:
    """One engine's replay of one seed's action log, judged against the training engine."""

    engine: str
    """The engine's label."""
    seed: int
    """The episode's seed."""
    steps: int
    """Control steps replayed (the training episode's length)."""
    verdicts: dict[str, Verdict]
    """Per quantity of :data:`QUANTITIES` judged, compare's verdict."""
    parts_at: dict[str, float | None]
    """Per quantity, the first time (s) the runs leave the training engine's envelope, or
    None."""
    diverged_at: float | None = None
    """When the engine's state went non-finite during the replay (s), or None."""

    @property
    def deciding(self) -> str:
        """The quantity that decides the seed's verdict: the most severe verdict, and among
        equals the one that parts first."""

        def key(q: str) -> tuple[int, float]:
            t = self.parts_at[q]
            return (-SEVERITY.index(self.verdicts[q].verdict), np.inf if t is None else t)

        return min(self.verdicts, key=key)

    @property
    def verdict(self) -> str:
        """The seed's verdict: its deciding quantity's."""
        return self.verdicts[self.deciding].verdict


@dataclass
class OpenLoop:
    """The open-loop replays of a sim2sim run."""

    trained_on: str
    """The training engine's label."""
    seeds: list[int]
    """The seeds replayed."""
    ensemble: int
    """Runs per engine and seed."""
    perturbation: dict[str, float]
    """Per engine label, the offset its perturbed runs got (rad or m)."""
    steps: dict[int, int]
    """Per seed, control steps of the training episode (its action log's length)."""
    reproduces: dict[int, float]
    """Per seed, the largest difference (rad or m, over joints and base pose) between the
    logged closed-loop episode and the training engine's unperturbed open-loop replay."""
    replays: list[Replay] = field(default_factory=list)
    """Every other engine's replays, engine by engine, seed by seed."""
    skipped: dict[int, str] = field(default_factory=dict)
    """Seeds not replayed, and why (an episode of fewer than 2 steps)."""
    outside: str = ""
    """For a policy trained outside simbridge (``external:NAME``), that NAME: no log of its
    training run is at hand, so the first engine's actions (:attr:`trained_on`, then that
    engine's label) stand in for it; empty for a training engine's own log."""


# ---------------------------------------------------------------- the runs


def _movable(env: SimEnv) -> list[int]:
    from simbridge.types import JointType

    sim, body = env.sim, env.world.body
    kinds = (JointType.REVOLUTE, JointType.PRISMATIC)
    return [i for i in range(sim.num_joints(body)) if sim.joint_info(body, i).type in kinds]


def _free_base(env: SimEnv) -> bool:
    t = env.task
    return not t.robot(t.action.robot).fixed_base


def _state(env: SimEnv, joints: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The action robot's base position (3,) m, orientation (4,) x y z w, joint positions."""
    sim, body = env.sim, env.world.body
    b = sim.base_state(body)
    q = sim.joint_states(body, joints).positions if joints else np.zeros(0)
    return np.asarray(b.position, float), np.asarray(b.orientation, float), np.asarray(q, float)


class _Track:
    """A run's states, one row per control step (row 0: after the reset)."""

    def __init__(self) -> None:
        self.p: list[np.ndarray] = []
        self.o: list[np.ndarray] = []
        self.q: list[np.ndarray] = []

    def add(self, s: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        self.p.append(s[0])
        self.o.append(s[1])
        self.q.append(s[2])

    def pad(self, rows: int) -> None:
        """Repeat the last row up to ``rows`` rows (a run that diverged)."""
        while len(self.p) < rows:
            self.p.append(self.p[-1])
            self.o.append(self.o[-1])
            self.q.append(self.q[-1])

    def arrays(self) -> dict[str, np.ndarray]:
        return {"p": np.array(self.p), "o": np.array(self.o), "q": np.array(self.q)}


def _log(env: SimEnv, policy: Any, spec: str, seed: int, joints: list[int]) -> tuple[Any, ...]:
    """The training engine's closed-loop episode: its actions (L, n) and states (L + 1 rows)."""
    from simbridge.envs.policies import check_output

    obs, _ = env.reset(seed=seed)
    track = _Track()
    track.add(_state(env, joints))
    actions = []
    while True:
        a = check_output(spec, env, policy(obs))
        if not np.isfinite(a).all():  # the paired run's NaN failure: the log ends before it
            break
        actions.append(np.array(a, dtype=np.float64))
        obs, _, terminated, truncated, info = env.step(a)
        if info.get("failure") == "diverged":
            break
        track.add(_state(env, joints))
        if terminated or truncated:
            break
    n = len(env.task.action.joints)
    return np.array(actions).reshape(-1, n), track.arrays()


def _perturb(env: SimEnv, joints: list[int], offset: dict[str, np.ndarray]) -> None:
    """Move the joints by ``offset["q"]`` and a free base by ``offset["p"]`` (m) and the
    rotation vector ``offset["r"]`` (rad, world), velocities kept."""
    from simbridge.transforms import quat_multiply

    sim, body = env.sim, env.world.body
    if joints:
        s = sim.joint_states(body, joints)
        sim.reset_joint_state(body, joints, s.positions + offset["q"], s.velocities)
    if _free_base(env):
        b = sim.base_state(body)
        r = offset["r"]
        angle = float(np.linalg.norm(r))
        axis = r / angle * np.sin(angle / 2)
        turn = (float(axis[0]), float(axis[1]), float(axis[2]), float(np.cos(angle / 2)))
        sim.reset_base_state(
            body, np.asarray(b.position) + offset["p"], quat_multiply(turn, b.orientation)
        )
    env.world.stale()


def _replay(
    env: SimEnv,
    seed: int,
    actions: np.ndarray,
    joints: list[int],
    offset: dict[str, np.ndarray] | None,
) -> tuple[dict[str, np.ndarray], float | None]:
    """One open-loop run: reset to ``seed``, perturb, send ``actions`` whatever happens;
    the states (L + 1 rows) and when the engine diverged (s) or None."""
    env.reset(seed=seed)
    if offset is not None:
        _perturb(env, joints, offset)
    track = _Track()
    track.add(_state(env, joints))
    diverged = None
    for k, a in enumerate(actions):
        _, _, _, _, info = env.step(a)
        if info.get("failure") == "diverged":
            diverged = (k + 1) * env.task.control_dt
            break
        track.add(_state(env, joints))
    track.pad(len(actions) + 1)
    return track.arrays(), diverged


def _offsets(size: int, joints: int, eps: float, seed: int) -> list[dict[str, np.ndarray] | None]:
    """Run k's offset (None for run 0): seeded unit directions (the same on every engine) of
    length ``eps``, for the joints, a free base's position and its rotation vector."""
    rng = np.random.default_rng(seed)
    out: list[dict[str, np.ndarray] | None] = [None]
    for _ in range(1, size):
        d = {k: rng.standard_normal(n) for k, n in (("q", joints), ("p", 3), ("r", 3))}
        out.append({k: eps * v / max(float(np.linalg.norm(v)), 1e-300) for k, v in d.items()})
    return out


def _features(arrays: dict[str, np.ndarray], quantity: str) -> np.ndarray:
    from simbridge.compare.run.quantities import features

    return features(quantity, arrays[_SOURCES[quantity]])


class _EngineRuns:
    """One engine's replays of one seed: ``members`` (N runs at dt) and ``half`` (run 0 at
    dt / 2)."""

    def __init__(self, members: list[dict[str, np.ndarray]], half: dict[str, np.ndarray]):
        self.members = members
        self.half = half

    def stack(self, quantity: str) -> np.ndarray:
        return np.stack([_features(m, quantity) for m in self.members])

    def own_error(self, quantity: str) -> np.ndarray:
        from simbridge.compare.run.quantities import distance

        return distance(
            quantity, _features(self.members[0], quantity), _features(self.half, quantity)
        )


def _engine_perturbation(task: Task, backend: str, perturb: float) -> float:
    """The offset a backend's runs get: ``perturb``, raised for a float32 engine
    (:func:`simbridge.compare.run.offsets.engine_perturbation`, by the task's spawn poses)."""
    from simbridge.compare.run.offsets import engine_perturbation
    from simbridge.registry import state_dtype

    m, rad = engine_perturbation((perturb, perturb), state_dtype(backend), task)  # its robots
    return max(m, rad)


class _Engine:
    """An engine's two envs (dt and dt / 2) for the replays."""

    def __init__(self, task: Task, engine: Engine):
        from simbridge.envs.env import SimEnv

        t = dataclasses.replace(task, profile=engine.profile)
        half = dataclasses.replace(t, timestep=t.timestep / 2, decimation=2 * t.decimation)
        self.engine = engine
        self.env = SimEnv(t, backend=engine.backend)
        self.half = SimEnv(half, backend=engine.backend)
        self.joints = _movable(self.env)

    def runs(
        self, seed: int, actions: np.ndarray, offsets: list[dict[str, np.ndarray] | None]
    ) -> tuple[_EngineRuns, float | None]:
        members, diverged = [], None
        for off in offsets:
            arrays, d = _replay(self.env, seed, actions, self.joints, off)
            members.append(arrays)
            if d is not None and (diverged is None or d < diverged):
                diverged = d
        half, _ = _replay(self.half, seed, actions, self.joints, None)
        return _EngineRuns(members, half), diverged

    def close(self) -> None:
        self.env.close()
        self.half.close()


def _parts_at(v: Verdict) -> float | None:
    """The first instant the gap reaches the tolerance and more than ``MARGINAL[1]`` times the
    training engine's (floored) spread, or None."""
    from simbridge.compare.analysis.verdict import MARGINAL

    envelope = MARGINAL[1] * np.maximum(v.spreads[0], v.floor)
    out = np.flatnonzero((v.gap_series >= v.tolerance) & (v.gap_series > envelope))
    return float(v.time[out[0]]) if out.size else None


def _judged(
    time: np.ndarray,
    labels: tuple[str, str],
    runs: tuple[_EngineRuns, _EngineRuns],
    quantities: Sequence[str],
    seed: int,
) -> tuple[dict[str, Verdict], dict[str, float | None]]:
    from simbridge.compare.analysis.verdict import judge

    verdicts, parts = {}, {}
    for q in quantities:
        v = judge(
            time,
            q,
            labels,
            [r.stack(q) for r in runs],
            [r.own_error(q) for r in runs],
            seed=seed,
        )
        verdicts[q] = v
        parts[q] = _parts_at(v)
    return verdicts, parts


def openloop(
    task: Task,
    engines: Sequence[Engine],
    policy: str,
    seeds: Sequence[int],
    *,
    ensemble: int = DEFAULT_ENSEMBLE,
    perturb: float = DEFAULT_PERTURB,
    seed: int = 0,
    outside: str = "",
) -> OpenLoop:
    """Replay the training engine's actions open loop on every engine and judge where the
    physics parts (see the module's docstring).

    Args:
        task: the task.
        engines: the engines, the training engine first (:func:`~.paired.parse_engines`).
        policy: the policy as :func:`~simbridge.envs.policies.load_policy` takes it.
        seeds: the seeds to replay (one training episode each).
        ensemble: runs per engine and seed (run 0 unperturbed); at least 1.
        perturb: the perturbed runs' offset, rad or m (> 0).
        seed: seeds the offsets' directions, the bootstrap and the permutation test.
        outside: for a policy trained outside simbridge, the training simulator's name
            (``external:NAME``'s NAME): the first engine's actions stand in for the training
            run's, which simbridge has no log of (:attr:`OpenLoop.outside`).

    Returns:
        The :class:`OpenLoop`.

    Raises:
        InvalidArgumentError: ``ensemble`` below 1, ``perturb`` not above 0.
        PolicyError: a policy that does not load or whose output does not fit the task.
    """
    from simbridge.envs.policies import load_policy
    from simbridge.exceptions import InvalidArgumentError

    if ensemble < 1:
        raise InvalidArgumentError("ensemble", f"expected at least 1 run, got {ensemble}")
    if not perturb > 0:
        raise InvalidArgumentError("perturb", f"expected an offset above 0, got {perturb}")
    made = [_Engine(task, e) for e in engines]
    try:
        train = made[0]
        quantities = [q for q in QUANTITIES if q == QUANTITIES[0] or _free_base(train.env)]
        eps = {m.engine.label: _engine_perturbation(task, m.engine.backend, perturb) for m in made}
        result = OpenLoop(train.engine.label, list(seeds), ensemble, eps, {}, {}, outside=outside)
        pol = load_policy(policy, train.env)
        dt = task.control_dt
        for s in seeds:
            actions, logged = _log(train.env, pol, policy, s, train.joints)
            result.steps[s] = len(actions)
            if len(actions) < 2:
                result.skipped[s] = f"its training episode has {len(actions)} control step(s)"
                continue
            time = np.arange(len(actions) + 1) * dt
            n = len(train.joints)
            own, _ = train.runs(s, actions, _offsets(ensemble, n, eps[train.engine.label], seed))
            rows = len(logged["p"])  # fewer than the replay's where the logged run diverged
            result.reproduces[s] = max(
                float(np.max(np.abs(own.members[0][k][:rows] - logged[k]), initial=0.0))
                for k in ("p", "o", "q")
            )
            for m in made[1:]:
                runs, diverged = m.runs(
                    s, actions, _offsets(ensemble, len(m.joints), eps[m.engine.label], seed)
                )
                labels = (train.engine.label, m.engine.label)
                verdicts, parts = _judged(time, labels, (own, runs), quantities, seed)
                result.replays.append(
                    Replay(m.engine.label, s, len(actions), verdicts, parts, diverged)
                )
        return result
    finally:
        for m in made:
            m.close()
