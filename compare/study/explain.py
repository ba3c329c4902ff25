"""``simbridge explain SCENARIO``: which setting explains the gap between two engines here?
:func:`explain`.

For every pair of engines the study lists a short set of **candidates**, each a setting and the
value it is moved to, with the reason it could explain the gap in this scenario
(:func:`candidates`):

- a profile entry (or engine setting) on which the two engines' profiles differ: the first
  engine is given the second's value (the gap between two runs of one engine with a friction
  changed on purpose is then gone);
- each profile departure that applies to this scenario (:func:`~simbridge.compare.report.
  departures.applicable`) and that a setting can move: the speed clamp (the engines apply it
  differently: run without it), the <contact> restitution and rolling/spinning friction MuJoCo
  and PhysX do not reproduce (run without the file's <contact>), the motor rows and contacts an
  iterative solve leaves short (PyBullet's or PhysX's at 200 iterations where MuJoCo solves
  them exactly; both at 200 where both iterate), link damping PhysX applies by another law
  (both run without it), and the contact settings that move one engine's contact toward the
  other's (:func:`_engine_candidates`);
- the joint-limit rule (``physx.limit_rule``, ``mujoco.limit_rule``), where the engines part at
  a limit event (a joint reached its limit in either engine's run within
  :data:`~simbridge.compare.run.events.PARTING_WINDOW` before the gap first reached its
  threshold, or the gap was born while one was at it: :func:`limit_parting`) and their rules
  differ: each engine that has the setting given the other's rule (:func:`_limit_candidates`);
- a departure no setting moves (collision cylinders, joint axes, float32 state, the joint
  limits where the engines do not part at one) or that changes only what is reported is listed
  as not tested, and why.

Each candidate is one :func:`~simbridge.compare.compare` of the pair with the setting moved.
The **share of the gap removed** is ``1 - gap_after / gap_before``, both the median distance
between the two engines' runs at the instant the pair's verdict was judged, with a 95% bootstrap
interval over the four ensembles (the pair's runs before and after, resampled independently).
The candidates are ranked by it; one that removes at least :data:`EXPLAINS` of the gap with the
interval's low end at least :data:`PARTLY` explains it; where none removes :data:`PARTLY` with an
interval above 0 the report says that nothing tested explains the gap.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from simbridge.exceptions import InvalidArgumentError, SimbridgeError
from simbridge.profiles import get_profile

from ..analysis.diff import QUANTITIES
from ..analysis.events import EngineEvents, Event, Parting, engine_events, parting
from ..analysis.verdict import BOOTSTRAP_RESAMPLES, CONFIDENCE, Interval
from ..pipeline import Comparison, Pair, compare
from ..report.departures import applicable, checked
from ..run.events import PARTING_WINDOW
from ..run.quantities import distance
from ..scenario import format_timestep, load_scenario
from .points import PROFILE_ENTRIES, PairFigures, _with_change, format_value, pair_figures

__all__ = [
    "DEFAULT_ENSEMBLE",
    "EXPLAINS",
    "PARTLY",
    "Candidate",
    "CandidateResult",
    "PairExplanation",
    "Explanation",
    "candidates",
    "explain",
    "limit_parting",
    "not_checked",
    "share_removed",
]

DEFAULT_ENSEMBLE = 6
"""Runs per engine in explain's comparisons (compare's default is 16): 6 keeps an explain of
r2d2-gentle within minutes on 2 cores, and 6 against 6 runs lets the permutation test reach
p = 0.002."""
EXPLAINS = 0.5
"""A candidate that removes at least this share of the gap explains it..."""
PARTLY = 0.2
"""...with the low end of its interval at least this; one whose low end is above 0 and whose
share reaches this explains part of it."""
SOLVER_ITERATIONS_RAISED = 200
"""PyBullet's solver iterations in the candidate that brings its sequential-impulse solve
toward an exact one (the profile's 50; the motors departure measured 200 iterations bringing a
spherical joint's shortfall from 4.6 to 0.03 rad/s)."""


@dataclass(frozen=True)
class Candidate:
    """A setting moved for one pair: ``moves`` are ``(slot, key, value)``, slot 0 or 1 of the
    pair, key a profile entry or ``BACKEND.KEY``."""

    name: str
    moves: tuple[tuple[int, str, Any], ...]
    source: str  # "profiles differ", "departure: <key>"
    why: str

    def as_dict(self, labels: Sequence[str]) -> dict[str, Any]:
        return {
            "name": self.name,
            "moves": [
                {"engine": labels[s], "key": k, "value": list(v) if isinstance(v, tuple) else v}
                for s, k, v in self.moves
            ],
            "source": self.source,
            "why": self.why,
        }

    def describe(self, labels: Sequence[str]) -> str:
        return "; ".join(f"{labels[s]}: {k} = {format_value(v)}" for s, k, v in self.moves)


@dataclass
class CandidateResult:
    """A candidate's run: the pair's profiles, the gap after at the judged instant, the share
    of the gap it removed (bootstrap intervals), the pair's verdict after."""

    candidate: Candidate
    profiles: tuple[str, str]
    gap: Interval
    share: Interval
    after: PairFigures
    wall_time: float

    @property
    def explains(self) -> str:
        """``yes`` (most of the gap), ``partly`` or ``no``."""
        s = self.share
        low = s.low if s.low is not None else s.value
        if s.value >= EXPLAINS and low >= PARTLY:
            return "yes"
        if s.value >= PARTLY and low > 0:
            return "partly"
        return "no"


@dataclass
class PairExplanation:
    """One pair of engines: its gap before, the candidates ranked, those not tested."""

    a: int
    b: int
    labels: tuple[str, str]
    before: PairFigures
    instant: float  # s, where the gap is measured (the pair's judged instant)
    gap: Interval  # before, at that instant
    ranked: list[CandidateResult] = field(default_factory=list)
    not_tested: list[tuple[str, str]] = field(default_factory=list)  # (departure, why)
    not_checked: list[str] = field(default_factory=list)
    """Departures the engines list that are not checked against this scenario: not tested."""
    failed: list[tuple[Candidate, str]] = field(default_factory=list)
    """Candidates whose rerun stopped with an error (a diverged engine...), with it."""
    note: str = ""  # why nothing was run (no gap to explain)

    @property
    def conclusion(self) -> str:
        text = self._conclusion()
        if self.before.verdict == "chaotic" and not self.note:
            who = " and ".join(self.before.engines) or "an engine"
            text += (
                f" (The gap is {'within' if self.before.reason == 'within spread' else 'near'} "
                f"{who}'s own spread: part of it is chaos, which no setting removes.)"
            )
        return text

    def _conclusion(self) -> str:
        a, b = self.labels
        if self.note:
            return self.note
        if not self.ranked and self.failed:
            return (
                f"Every candidate's rerun for {a} - {b} failed ({len(self.failed)}): nothing "
                "tested explains the gap."
            )
        if not self.ranked:
            return f"No setting could be moved for {a} - {b}: nothing tested explains the gap."
        best = self.ranked[0]
        pct = _pct(best.share)
        if best.explains == "yes":
            return (
                f"{best.candidate.name} explains most of the gap between {a} and {b}: moving it "
                f"({best.candidate.describe(self.labels)}) removes {pct} of it."
            )
        if best.explains == "partly":
            return (
                f"{best.candidate.name} explains part of the gap between {a} and {b}: it removes "
                f"{pct}; no setting tested removes most of it."
            )
        return (
            f"Nothing tested explains the gap between {a} and {b}: of {len(self.ranked)} "
            f"setting(s) moved, the most any removes is {pct} ({best.candidate.name})."
        )


@dataclass
class Explanation:
    """An explain study: every pair's explanation, with how it was run."""

    scenario: str
    backends: tuple[str, ...]
    profiles: tuple[str, ...]
    labels: tuple[str, ...]
    timestep: float
    ensemble: int
    duration: float | None
    pairs: list[PairExplanation]
    wall_time: float

    def as_dict(self) -> dict[str, Any]:
        out = []
        for p in self.pairs:
            out.append(
                {
                    "labels": list(p.labels),
                    "before": p.before.as_dict(),
                    "instant": p.instant,
                    "gap": _idict(p.gap),
                    "conclusion": p.conclusion,
                    "ranking": [
                        {
                            **r.candidate.as_dict(p.labels),
                            "explains": r.explains,
                            "share_removed": _idict(r.share),
                            "gap_after": _idict(r.gap),
                            "verdict_after": r.after.verdict,
                            "profiles": list(r.profiles),
                            "wall_time": r.wall_time,
                        }
                        for r in p.ranked
                    ],
                    "not_tested": [{"departure": k, "why": w} for k, w in p.not_tested],
                    "not_checked": list(p.not_checked),
                    "failed": [{**c.as_dict(p.labels), "error": err} for c, err in p.failed],
                }
            )
        return {
            "scenario": self.scenario,
            "backends": list(self.backends),
            "profiles": list(self.profiles),
            "labels": list(self.labels),
            "timestep": self.timestep,
            "ensemble": self.ensemble,
            "duration": self.duration,
            "wall_time": self.wall_time,
            "explains_at": {"share": EXPLAINS, "interval_low": PARTLY},
            "pairs": out,
        }


def _idict(x: Interval) -> dict[str, float | None]:
    return {"value": x.value, "low": x.low, "high": x.high}


def _p(x: float) -> str:
    return f"{100 * x:.0f}%".replace("-0%", "0%")


def _pct(x: Interval) -> str:
    if x.low is None or x.high is None:
        return _p(x.value)
    return f"{_p(x.value)} (95% interval {_p(x.low)} to {_p(x.high)})"


# ---------------------------------------------------------------- candidates


def _profile_differences(profiles: tuple[str, str], labels: tuple[str, str]) -> list[Candidate]:
    pa, pb = (get_profile(p) for p in profiles)
    out = []
    for key in PROFILE_ENTRIES:
        va, vb = getattr(pa, key), getattr(pb, key)
        if va != vb:
            out.append(
                Candidate(
                    key,
                    ((0, key, vb),),
                    "profiles differ",
                    f"{labels[0]} runs {key} = {format_value(va)}, {labels[1]} "
                    f"{format_value(vb)}: {labels[0]} given {labels[1]}'s value",
                )
            )
    if True:
        sa, sb = pa.engine_settings(), pb.engine_settings()
        for backend in sorted(set(sa) | set(sb)):
            ka, kb = sa.get(backend, {}), sb.get(backend, {})
            for key in sorted(set(ka) | set(kb)):
                if key in kb and ka.get(key) != kb[key]:
                    out.append(
                        Candidate(
                            f"{backend}.{key}",
                            ((0, f"{backend}.{key}", kb[key]),),
                            "profiles differ",
                            f"{labels[1]}'s profile sets {backend}.{key} = "
                            f"{format_value(kb[key])}, {labels[0]}'s "
                            f"{format_value(ka.get(key, 'default'))}: {labels[0]} given it",
                        )
                    )
    return out


UNTESTABLE = {
    "cylinder": "a collision shape, not a setting: no setting moves it",
    "joint limits": "the limit rule is each backend's own here: neither engine has a limit_rule "
    "setting",
    "joint axis": "the file's axis, not a setting",
    "precision": "the engine's float32 state: no setting moves it",
    "meshes": "collision shapes, not a setting: no setting moves it",
    "spherical joints": "how the engine builds the joint: no setting moves it",
    "self collision": "the engine's collision filter: no setting moves it",
    "friction combine": "the engine's combine rule: no setting moves it",
    "applied torques": "what is reported, not the motion: no rerun changes the gap",
    "contact friction": "what is reported, not the motion: no rerun changes the gap",
    "snapshot": "set_state and teleports only, which a compared run does not use",
}

# engines whose motor and contact rows are solved by iterations stopped at the profile's count
_ITERATIVE = ("pybullet", "physx")


def _iterations_candidate(
    backends: tuple[str, str], labels: tuple[str, str], key: str
) -> list[Candidate]:
    """More solver iterations where an engine's solve stops short: on the iterative engine alone
    where the other solves its rows exactly (MuJoCo), on both where both iterate."""
    it = [s for s in (0, 1) if backends[s] in _ITERATIVE]
    if not it:
        return []
    n = SOLVER_ITERATIONS_RAISED
    if len(it) == 2:
        return [
            Candidate(
                "solver_iterations",
                ((0, "solver_iterations", n), (1, "solver_iterations", n)),
                f"departure: {key}",
                f"{labels[0]} and {labels[1]} both solve their motor and contact rows by "
                "iterations stopped at the profile's count, each short of the exact solve in "
                f"its own way: both given {n}, nearer the exact solve",
            )
        ]
    k = it[0]
    kind = "sequential impulses" if backends[k] == "pybullet" else "Gauss-Seidel iterations"
    return [
        Candidate(
            "solver_iterations",
            ((k, "solver_iterations", n),),
            f"departure: {key}",
            f"{labels[1 - k]} solves its motor and contact rows exactly; {labels[k]}'s {kind} "
            f"stop after the profile's iterations: {n} bring {labels[k]} toward the exact solve",
        )
    ]


def _damping_candidate(profiles: tuple[str, str], labels: tuple[str, str]) -> list[Candidate]:
    """Both engines without link damping, where they apply it by different laws (PhysX's
    v -= k v dt against PyBullet's added quadratic term)."""
    moves = tuple(
        (s, key, 0.0)
        for s in (0, 1)
        for key in ("linear_damping", "angular_damping")
        if getattr(get_profile(profiles[s]), key)
    )
    if not moves:
        return []
    return [
        Candidate(
            "link damping",
            moves,
            "departure: link damping",
            "the engines damp link velocities by different laws: both run without link damping",
        )
    ]


NOSLIP_ITERATIONS = 10
"""MuJoCo's no-slip iterations in the candidate that removes its contacts' creep."""


def _effective(backend: str, profile: str) -> dict[str, Any]:
    from simbridge.engine_settings import effective

    try:
        return effective(backend, get_profile(profile))
    except Exception:  # a backend without settings
        return {}


PYBULLET_MARGIN = 0.001
"""m: PyBullet's collision margin on a URDF's shapes: two shapes rest this far apart."""
CONTACT_OFFSET_NEAR = 0.001
"""m per shape: PhysX's contact offset in the candidate that makes its contacts near the rest
distance, as MuJoCo's margin does (PhysX's own 1 cm makes a pair's contacts 2 cm apart)."""


def _cone(backend: str, settings: dict[str, Any]) -> bool:
    """Whether this engine limits friction by a cone (the same friction in every direction).
    Measured (bench/friction_cone.py, a box sliding on the plane at 2 m/s along x and along the
    diagonal): PyBullet's cone 0.52 g both ways, its enableConeFriction = False a box (0.52 g
    along x, 0.73 g on the diagonal); MuJoCo's pyramid 0.46 g along x, 0.27 g on the diagonal,
    its elliptic cone 0.45 g both; PhysX 0.52 g both ways: a cone."""
    if backend == "pybullet":
        return bool(settings.get("enableConeFriction", True))
    if backend == "mujoco":
        return settings.get("cone") == "elliptic"
    return backend == "physx"


def _engine_candidates(
    backends: tuple[str, str], profiles: tuple[str, str], labels: tuple[str, str], dt: float
) -> list[Candidate]:
    """The engine settings that could explain a contact gap between these two engines, each
    moved toward the other engine's behaviour (a short list, reasoned one by one)."""
    out: list[Candidate] = []
    slot = {b: k for k, b in reversed(list(enumerate(backends)))}
    eff = [_effective(b, p) for b, p in zip(backends, profiles, strict=True)]
    if "mujoco" in slot:
        m = slot["mujoco"]
        o = 1 - m
        ms = eff[m]
        if "pybullet" in slot:
            bs = eff[slot["pybullet"]]
            erp = float(bs.get("contactERP", 0.0) or 0.0)
            if erp > 0 and "solref" in ms:
                tau = dt / erp
                out.append(
                    Candidate(
                        "mujoco.solref",
                        ((m, "mujoco.solref", (tau, 1.0)),),
                        "departure: contact",
                        f"PyBullet corrects {erp:g} of a contact's penetration per step "
                        f"(contactERP), a time constant of about dt / {erp:g} = "
                        f"{tau * 1000:.3g} ms; MuJoCo's contacts run at "
                        f"{float(ms['solref'][0]) * 1000:.3g} ms: {labels[m]} given PyBullet's",
                    )
                )
        if ms.get("cone") == "pyramidal" and _cone(backends[o], eff[o]):
            why = (
                f"{labels[o]} limits friction by a cone, {labels[m]} by a pyramid (measured on "
                "a sliding box: the same friction along an axis, about half on the diagonal): "
            )
            out.append(
                Candidate(
                    "mujoco.cone",
                    ((m, "mujoco.cone", "elliptic"),),
                    "departure: contact",
                    why + f"{labels[m]} given the cone",
                )
            )
            if backends[o] == "pybullet":
                out.append(
                    Candidate(
                        "pybullet.enableConeFriction",
                        ((o, "pybullet.enableConeFriction", False),),
                        "departure: contact",
                        why + f"{labels[o]} given its per-direction friction (not MuJoCo's "
                        "pyramid: a box, 1.4 times the cone's friction on the diagonal where "
                        "the pyramid gives about half; bench/friction_cone.py)",
                    )
                )
        if "noslip_iterations" in ms and not ms["noslip_iterations"]:
            out.append(
                Candidate(
                    "mujoco.noslip_iterations",
                    ((m, "mujoco.noslip_iterations", NOSLIP_ITERATIONS),),
                    "departure: contact",
                    f"MuJoCo's soft contacts let a loaded contact creep where impulse solvers "
                    f"hold static friction: {labels[m]} given {NOSLIP_ITERATIONS} no-slip "
                    "iterations",
                )
            )
    if "physx" in slot:
        x = slot["physx"]
        o = 1 - x
        xs = eff[x]
        rest = float(xs.get("rest_offset", 0.0) or 0.0)
        other = backends[o]
        # the distance at which two shapes rest: PhysX the sum of their rest offsets, PyBullet
        # its collision margin, MuJoCo its contacts' margin (r2d2 rests at z 0.47100 on all three)
        if other == "pybullet":
            rests_at: float | None = PYBULLET_MARGIN
        elif other == "mujoco":
            rests_at = float(eff[o].get("margin", 0.0) or 0.0)
        else:
            rests_at = None
        if rests_at is not None and not math.isclose(2 * rest, rests_at, abs_tol=1e-9):
            out.append(
                Candidate(
                    "physx.rest_offset",
                    ((x, "physx.rest_offset", rests_at / 2),),
                    "departure: contact",
                    f"PhysX rests two shapes {2 * rest * 1000:.3g} mm apart (twice its rest "
                    f"offset), {labels[o]} {rests_at * 1000:.3g} mm: {labels[x]} given "
                    f"{rests_at / 2 * 1000:.3g} mm per shape",
                )
            )
        offset = float(xs.get("contact_offset", 0.0) or 0.0)
        near = max(CONTACT_OFFSET_NEAR, rest + CONTACT_OFFSET_NEAR / 2)
        if other == "mujoco" and offset > near:
            out.append(
                Candidate(
                    "physx.contact_offset",
                    ((x, "physx.contact_offset", near),),
                    "departure: contact",
                    f"PhysX makes a pair's contacts from {2 * offset * 1000:.3g} mm apart "
                    f"(twice its contact offset), {labels[o]} within its "
                    f"{float(eff[o].get('margin', 0.0)) * 1000:.3g} mm margin: {labels[x]} given "
                    f"{near * 1000:.3g} mm per shape",
                )
            )
    return out


FIXED_LIMIT_RULES = {"pybullet": "pybullet"}
"""The joint-limit rule of an engine that has no ``limit_rule`` setting: PyBullet's is its own
row (btMultiBodyJointLimitConstraint), which nothing turns into a hard limit."""
LIMIT_RULE_WORDS = {
    "pybullet": "lets a joint arriving at its limit pass by up to one step's travel, then pushes "
    "it back (PyBullet's rule)",
    "hard": "stops a joint arriving at its limit on it within the step (a hard limit)",
}


def _limit_rule(backend: str, settings: dict[str, Any]) -> str | None:
    """The joint-limit rule ``backend`` runs with these effective settings (None: unknown)."""
    if "limit_rule" in settings:
        return str(settings["limit_rule"])
    return FIXED_LIMIT_RULES.get(backend)


def _has_limit_rule(backend: str) -> bool:
    from simbridge.engine_settings import settings_for

    try:
        return "limit_rule" in settings_for(backend)
    except SimbridgeError:
        return False


def limit_parting(where: Parting, engines: Sequence[EngineEvents]) -> tuple[str, Event] | None:
    """The limit event at which the pair parts, with its engine's label (None: they do not part
    at one): the event the gap was born after or during (``where``, :func:`~simbridge.compare.
    analysis.events.parting`) when it is a ``joint_limit``, else the latest ``joint_limit`` of
    either engine (``engines``: the pair's) that began within :data:`PARTING_WINDOW` before the
    gap first reached its threshold (a limit hit that made a motor saturate a step later parts
    the engines as much as the hit itself)."""
    if where.time is None:
        return None
    if where.event is not None and where.event.kind == "joint_limit":
        return (where.event_label or "", where.event)
    found: tuple[str, Event] | None = None
    for e in engines:
        for ev in e.events:
            if ev.kind != "joint_limit":
                continue
            if where.time - PARTING_WINDOW - 1e-12 <= ev.time <= where.time + where.step + 1e-12:
                if found is None or ev.time > found[1].time:
                    found = (e.label, ev)
    return found


def _limit_words(at: tuple[str, Event], engines: Sequence[EngineEvents] = ()) -> str:
    """``in the step pybullet's kuka reached the upper limit of lbr_iiwa_joint_2 (2.094,
    t = 0.700 s; past it by pybullet 2.7e-02, physx 5.8e-08)``."""
    label, ev = at
    past = []
    for e in engines:
        beyond = [
            x.figures.get("beyond", math.nan)
            for x in e.events
            if x.kind == "joint_limit"
            and x.part == ev.part
            and x.side == ev.side
            and abs(x.time - ev.time) <= PARTING_WINDOW + 1e-12
        ]
        if beyond:
            past.append(f"{e.label} {max(beyond):.2g}")
    limit = ev.figures.get("limit")
    return (
        f"where {label}'s {ev.body} reached the {ev.side} limit of {ev.part}"
        + (f" ({limit:.4g}" if limit is not None else " (")
        + f", t = {ev.time:.3f} s"
        + (f"; largest past it: {', '.join(past)}" if past else "")
        + ")"
    )


def _limit_candidates(
    backends: tuple[str, str],
    profiles: tuple[str, str],
    labels: tuple[str, str],
    at: tuple[str, Event] | None,
    engines: Sequence[EngineEvents] = (),
) -> tuple[list[Candidate], str]:
    """The joint-limit rule moved toward the other engine's, where the pair parts at a limit
    event ``at``: each engine with a ``limit_rule`` setting given the other's rule. With none,
    why nothing is tested."""
    from simbridge.engine_settings import settings_for

    if not any(_has_limit_rule(b) for b in backends):
        return [], UNTESTABLE["joint limits"]
    if at is None:
        return [], (
            "joints reach their limits here, but the engines do not part at a limit event: the "
            "limit rule (limit_rule) is not moved"
        )
    eff = [_effective(b, p) for b, p in zip(backends, profiles, strict=True)]
    rules = [_limit_rule(b, e) for b, e in zip(backends, eff, strict=True)]
    if rules[0] == rules[1]:
        return [], f"both engines apply the same limit rule here ({rules[0]!r})"
    where = _limit_words(at, engines)
    out = []
    for s in (0, 1):
        o = 1 - s
        key = f"{backends[s]}.limit_rule"
        target = rules[o]
        if target is None or "limit_rule" not in eff[s]:
            continue
        if target not in settings_for(backends[s])["limit_rule"].choices:
            continue
        words = [LIMIT_RULE_WORDS.get(str(r), f"applies its {r!r} rule") for r in rules]
        out.append(
            Candidate(
                key,
                ((s, key, target),),
                "departure: joint limits",
                f"the engines part {where}: {labels[o]} {words[o]}, {labels[s]} {words[s]}: "
                f"{labels[s]} given {labels[o]}'s rule",
            )
        )
    if not out:
        return [], f"no engine of the pair has the other's limit rule ({rules[0]}, {rules[1]})"
    return out, ""


def not_checked(
    labels: tuple[str, str], departures: dict[str, dict[str, Any]] | None = None
) -> list[str]:
    """The departures of this pair's engines that no rule checks against the scenario (the
    compare report's "not checked against this scenario") and none found to apply: neither a
    candidate nor said to apply, only counted."""
    found: set[str] = set()
    unchecked: list[str] = []
    for label in labels:
        for d in (departures or {}).get(label, {}).get("apply", []):
            if checked(d):
                found.add(d["key"])
            else:
                unchecked.append(d["key"])
    return [k for k in dict.fromkeys(unchecked) if k not in found]


def candidates(
    backends: tuple[str, str],
    profiles: tuple[str, str],
    labels: tuple[str, str],
    departures: dict[str, dict[str, Any]] | None = None,
    timestep: float = 1 / 240,
    limit_event: tuple[str, Event] | None = None,
    events: Sequence[EngineEvents] = (),
) -> tuple[list[Candidate], list[tuple[str, str]]]:
    """The candidates of one pair of engines and the departures that apply but are not
    tested (each with why). ``departures`` is :func:`~simbridge.compare.report.departures.
    applicable`'s result for the comparison (by engine label); ``timestep`` the runs';
    ``limit_event`` the limit event at which the pair parts (:func:`limit_parting`; None: they
    do not part at one), ``events`` the pair's engines' events (for its figures)."""
    out = _profile_differences(profiles, labels)
    not_tested: list[tuple[str, str]] = []
    applying: dict[str, list[int]] = {}
    for slot, label in enumerate(labels):
        for d in (departures or {}).get(label, {}).get("apply", []):
            if checked(d):  # one the compare report marks "not checked" does not apply here
                applying.setdefault(d["key"], []).append(slot)
    if backends[0] != backends[1]:
        for key in applying:
            if key == "speed clamp":
                out.append(
                    Candidate(
                        "max_joint_velocity",
                        ((0, "max_joint_velocity", None), (1, "max_joint_velocity", None)),
                        "departure: speed clamp",
                        "a speed reached the clamp, which the engines apply differently: both "
                        "run without it",
                    )
                )
            elif key in ("restitution", "rolling/spinning friction"):
                if any(c.name == "read_urdf_contact" for c in out):
                    continue
                out.append(
                    Candidate(
                        "read_urdf_contact",
                        ((0, "read_urdf_contact", False), (1, "read_urdf_contact", False)),
                        f"departure: {key}",
                        "links with <contact> restitution or rolling/spinning friction touched "
                        "something and the engines do not reproduce them alike: both run "
                        "without the file's <contact>",
                    )
                )
            elif key in ("motors", "contact"):
                if not any(c.name == "solver_iterations" for c in out):
                    out += _iterations_candidate(backends, labels, key)
                if key == "contact":
                    out += _engine_candidates(backends, profiles, labels, timestep)
            elif key == "link damping":
                if not any(c.name == "link damping" for c in out):
                    out += _damping_candidate(profiles, labels)
            elif key == "joint limits":
                found, why = _limit_candidates(backends, profiles, labels, limit_event, events)
                out += found
                if not found:
                    not_tested.append((key, why))
            elif key in UNTESTABLE:
                not_tested.append((key, UNTESTABLE[key]))
            else:
                not_tested.append((key, "no setting is known to move it"))
    seen: set[tuple[Any, ...]] = set()
    unique = []
    for c in out:
        sig = tuple((s, k, repr(v)) for s, k, v in c.moves)
        if sig not in seen:
            seen.add(sig)
            unique.append(c)
    return unique, list(dict.fromkeys(not_tested))


# ---------------------------------------------------------------- measuring


def _matrix(quantity: str, fa: np.ndarray, fb: np.ndarray) -> np.ndarray:
    return distance(quantity, fa[:, None], fb[None, :])


def share_removed(
    quantity: str,
    before: tuple[np.ndarray, np.ndarray],
    after: tuple[np.ndarray, np.ndarray],
    *,
    seed: int = 0,
    resamples: int = BOOTSTRAP_RESAMPLES,
) -> tuple[Interval, Interval, Interval]:
    """(gap before, gap after, share removed) at one instant, each with its 95% percentile
    bootstrap interval: ``before``/``after`` are the two engines' runs' features there, (N, ...)
    each; a gap is the median distance over every pair (run of A, run of B)."""
    db = _matrix(quantity, *before)
    da = _matrix(quantity, *after)
    gb, ga = float(np.median(db)), float(np.median(da))
    share = 1.0 - ga / gb if gb > 0 else math.nan
    if min(*db.shape, *da.shape) < 2:
        return Interval(gb), Interval(ga), Interval(share)
    rng = np.random.default_rng(seed)
    bs, as_, ss = [], [], []
    for _ in range(resamples):
        ib = (rng.integers(0, db.shape[0], db.shape[0]), rng.integers(0, db.shape[1], db.shape[1]))
        ia = (rng.integers(0, da.shape[0], da.shape[0]), rng.integers(0, da.shape[1], da.shape[1]))
        x = float(np.median(db[np.ix_(*ib)]))
        y = float(np.median(da[np.ix_(*ia)]))
        bs.append(x)
        as_.append(y)
        ss.append(1.0 - y / x if x > 0 else math.nan)
    q = (100 * (1 - CONFIDENCE) / 2, 100 * (1 + CONFIDENCE) / 2)

    def iv(value: float, xs: list[float]) -> Interval:
        arr = np.asarray(xs)
        arr = arr[np.isfinite(arr)]
        if not arr.size:
            return Interval(value)
        lo, hi = np.percentile(arr, q)
        return Interval(value, float(lo), float(hi))

    return iv(gb, bs), iv(ga, as_), iv(share, ss)


def _at(time: np.ndarray, t: float) -> int:
    return int(np.argmin(np.abs(np.asarray(time) - t)))


# ---------------------------------------------------------------- the study


def explain(
    scenario: Any,
    backends: Sequence[str] | None = None,
    *,
    profile: str | Sequence[str] | None = None,
    timestep: float | str | None = None,
    ensemble: int = DEFAULT_ENSEMBLE,
    seed: int = 0,
    on_run: Callable[[str], None] | None = None,
    **compare_args: Any,
) -> Explanation:
    """For every pair of engines, move each candidate setting toward the other engine's
    behaviour and rank the settings by the share of the gap each removes.

    Args:
        scenario, backends, profile: as :func:`~simbridge.compare.compare`'s.
        timestep: the time step of every run (default the scenario's).
        ensemble: runs per engine in every comparison (:data:`DEFAULT_ENSEMBLE`); at least 2
            for intervals.
        seed: seeds the ensembles and the bootstrap.
        on_run: ``on_run(what)`` before each comparison runs.
        compare_args: passed to every :func:`~simbridge.compare.compare` call (``duration``,
            ``perturb``, ``workers``...; ``resync_every`` defaults to 0 here: not needed).

    Raises:
        InvalidArgumentError: a bad ensemble size; what compare raises (an
            ``engine_settings`` for an engine not run: EngineNotInStudyError, before any run).
    """
    if isinstance(ensemble, bool) or not isinstance(ensemble, int) or ensemble < 1:
        raise InvalidArgumentError("ensemble", f"expected an integer >= 1, got {ensemble!r}")
    start = _time.perf_counter()
    sc = load_scenario(scenario)
    if compare_args.get("controller") is not None:
        sc = sc.with_controller(compare_args.pop("controller"))
    compare_args.setdefault("resync_every", 0)
    from ..scenario import parse_timestep

    dt = parse_timestep(timestep) if timestep is not None else sc.timestep
    if on_run is not None:
        on_run("the comparison as given")
    base = compare(
        sc, backends, profile=profile, timesteps=[dt], ensemble=ensemble, seed=seed, **compare_args
    )
    events = engine_events(base)
    deps = applicable(base, events)
    pairs = []
    for p in base.pairs:
        assert p.verdict is not None
        a, b = p.a, p.b
        labels = (base.labels[a], base.labels[b])
        names = (base.backends[a], base.backends[b])
        profs = (base.profiles[a], base.profiles[b])
        before = pair_figures(p.verdict)
        j = p.verdict.judged_index
        t = float(p.verdict.time[j])
        q = p.verdict.quantity
        fb = (base.ensembles[a].features[:, j], base.ensembles[b].features[:, j])
        gap = share_removed(q, fb, fb, seed=seed)[0]
        pe = PairExplanation(a, b, labels, before, t, gap)
        pairs.append(pe)
        if before.verdict == "agree":
            pe.note = (
                f"{labels[0]} and {labels[1]} agree here (the gap stays below "
                f"{fmt_tol(before)}): there is no gap to explain."
            )
            continue
        pair_events = (events[a], events[b])
        at = limit_parting(pair_parting(base, p, events), pair_events)
        cands, pe.not_tested = candidates(names, profs, labels, deps, dt, at, pair_events)
        pe.not_checked = not_checked(labels, deps)
        results = []
        for cand in cands:
            moved = list(profs)
            for slot, key, value in cand.moves:
                moved[slot] = _with_change(moved[slot], key, value)
            if on_run is not None:
                on_run(f"{labels[0]} - {labels[1]}: {cand.describe(labels)}")
            t0 = _time.perf_counter()
            try:
                c = compare(
                    sc,
                    list(names),
                    profile=moved,
                    timesteps=[dt],
                    ensemble=ensemble,
                    seed=seed,
                    **compare_args,
                )
            except SimbridgeError as exc:  # the moved setting broke a run: say so, go on
                pe.failed.append((cand, str(exc)))
                continue
            v = c.pairs[0].verdict
            assert v is not None
            k = _at(c.ensembles[0].time, t)
            fa = (c.ensembles[0].features[:, k], c.ensembles[1].features[:, k])
            _, g_after, share = share_removed(q, fb, fa, seed=seed)
            results.append(
                CandidateResult(
                    cand,
                    (moved[0], moved[1]),
                    g_after,
                    share,
                    pair_figures(v),
                    _time.perf_counter() - t0,
                )
            )
        results.sort(key=lambda r: -(r.share.value if math.isfinite(r.share.value) else -1e300))
        pe.ranked = results
    return Explanation(
        scenario=sc.name,
        backends=base.backends,
        profiles=base.profiles,
        labels=base.labels,
        timestep=dt,
        ensemble=ensemble,
        duration=compare_args.get("duration"),
        pairs=pairs,
        wall_time=_time.perf_counter() - start,
    )


def fmt_tol(p: PairFigures) -> str:
    from ..report.fmt import fmt_threshold

    return fmt_threshold(p.tolerance, p.unit)


def pair_parting(c: Comparison, p: Pair, events: Sequence[EngineEvents]) -> Parting:
    """Where the gap between the engines of ``p`` is born, as the compare report says it
    (``summary.json``'s ``pairs[].parting``): the headline quantity first reaching its first
    threshold at the headline time step, the phases and the pair's events (``events``: every
    engine's, :func:`~simbridge.compare.analysis.events.engine_events`)."""
    q = c.headline_quantity
    dt = c.timestep
    thr = QUANTITIES[q].thresholds[0]
    tr = c.runs[(p.a, dt)]
    phases = [(name, float(tr.time[i]), float(tr.time[j])) for name, i, j in tr.phases]
    return parting(
        p.cross[dt].first_crossing(q, thr), thr, q, phases, [events[p.a], events[p.b]], dt
    )


# ---------------------------------------------------------------- report


def explanation_lines(e: Explanation) -> list[str]:
    """report.md of an explain study."""
    lines = [
        f"# Explain: {e.scenario} on {', '.join(e.labels)}",
        "",
        f"Every run at dt = {format_timestep(e.timestep)} s"
        + (f", the first {e.duration:g} s" if e.duration else "")
        + f", with ensembles of {e.ensemble} runs per engine (compare's default is 16: smaller "
        f"here so that every candidate's rerun stays short); {e.wall_time:.0f} s in all.",
        "",
        "Each candidate moves one setting toward the other engine's behaviour and reruns the "
        "pair. The share of the gap removed is 1 - gap after / gap before, the gap being the "
        "median distance between the two engines' runs at the instant the pair's verdict was "
        "judged; its 95% interval is a bootstrap over the four ensembles. A candidate explains "
        f"the gap when it removes at least {EXPLAINS:.0%} (interval's low end at least "
        f"{PARTLY:.0%}).",
    ]
    for p in e.pairs:
        u = p.before.unit
        lines += [
            "",
            f"## {p.labels[0]} - {p.labels[1]}",
            "",
            f"Before: **{p.before.verdict}** ({p.before.reason}); gap at t = {p.instant:.3f} s: "
            f"{_iv(p.gap, u)}.",
            "",
            f"**{p.conclusion}**",
        ]
        if p.note:
            continue
        lines += [
            "",
            "### Candidates",
            "",
            "| setting | moved to | from | why |",
            "|---|---|---|---|",
        ]
        for r in p.ranked:
            c = r.candidate
            lines.append(f"| {c.name} | {c.describe(p.labels)} | {c.source} | {c.why} |")
        for key, why in p.not_tested:
            lines.append(f"| (departure: {key}) | not tested | departure applies | {why} |")
        for c, err in p.failed:
            lines.append(
                f"| {c.name} | {c.describe(p.labels)} | {c.source} | {c.why}; **the rerun "
                f"failed**: {err} |"
            )
        if p.not_checked:
            n = len(p.not_checked)
            lines += [
                "",
                f"Left out: {n} departure{'s' if n != 1 else ''} the engines list but that "
                f"{'are' if n != 1 else 'is'} not checked against this scenario (as the compare "
                f"report marks {'them' if n != 1 else 'it'}), not tested: "
                + ", ".join(p.not_checked)
                + ".",
            ]
        if p.ranked:
            lines += [
                "",
                "### Ranking",
                "",
                "| rank | setting | share of the gap removed [95%] | gap after [95%] | verdict "
                "after | explains | profiles run | wall |",
                "|---|---|---|---|---|---|---|---|",
            ]
            for i, r in enumerate(p.ranked, 1):
                lines.append(
                    f"| {i} | {r.candidate.name} | {_pct(r.share)} | {_iv(r.gap, u)} "
                    f"| {r.after.verdict} | {r.explains} | {' / '.join(r.profiles)} "
                    f"| {r.wall_time:.1f} s |"
                )
    return lines


def _iv(x: Interval, unit: str) -> str:
    from ..report.fmt import fmt_value

    if x.low is None or x.high is None:
        return fmt_value(x.value, unit)
    return f"{fmt_value(x.value, unit)} [{fmt_value(x.low, unit)}, {fmt_value(x.high, unit)}]"


def plot_explanation(e: Explanation, out: Path) -> list[str]:
    """Per pair with candidates: the share each removes (bars with intervals)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    for p in e.pairs:
        if not p.ranked:
            continue
        fig, ax = plt.subplots(figsize=(7, 0.6 + 0.5 * len(p.ranked)))
        ys = list(range(len(p.ranked)))[::-1]
        vals = [100 * r.share.value for r in p.ranked]
        lo = [
            100 * (r.share.value - (r.share.low if r.share.low is not None else r.share.value))
            for r in p.ranked
        ]
        hi = [
            100 * ((r.share.high if r.share.high is not None else r.share.value) - r.share.value)
            for r in p.ranked
        ]
        ax.barh(ys, vals, xerr=[lo, hi], capsize=3, color="tab:blue")
        ax.set_yticks(ys, [r.candidate.name for r in p.ranked])
        ax.axvline(0, color="black", lw=0.8)
        ax.axvline(100 * EXPLAINS, color="grey", ls=":", lw=1)
        ax.set_xlabel("share of the gap removed (%), 95% interval")
        ax.set_title(f"{p.labels[0]} - {p.labels[1]}", fontsize=10)
        fig.tight_layout()
        stem = "".join(ch if ch.isalnum() else "_" for ch in f"{p.labels[0]}-{p.labels[1]}")
        name = f"explain_{stem}.png"
        fig.savefig(out / name, dpi=110)
        plt.close(fig)
        names.append(name)
    return names
