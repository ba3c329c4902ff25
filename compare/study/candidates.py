"""The candidates of ``simbridge explain``: for one pair of engines, each setting that could
explain the gap between them here, moved toward the other engine, with the reason
(:func:`candidates`), and the departures no setting moves (:func:`not_checked`). The reasons are
:mod:`.explain`'s module docstring."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from simbridge.exceptions import SimbridgeError
from simbridge.profiles import get_profile

from ..analysis.events import EngineEvents, Event, Parting
from ..report.departures import checked
from ..run.events import PARTING_WINDOW
from .points import PROFILE_ENTRIES, format_value

__all__ = [
    "SOLVER_ITERATIONS_RAISED",
    "Candidate",
    "candidates",
    "limit_parting",
    "not_checked",
]

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
    moved toward the other engine's behaviour (a short list, reasoned one by one).

    Args:
        backends, profiles, labels: the pair's engines, profiles and names.
        dt: s, the time step.
    """
    slot = {b: k for k, b in reversed(list(enumerate(backends)))}
    eff = [_effective(b, p) for b, p in zip(backends, profiles, strict=True)]
    out: list[Candidate] = []
    if "mujoco" in slot:
        out += _mujoco_candidates(backends, slot, eff, labels, dt)
    if "physx" in slot:
        out += _physx_candidates(backends, slot["physx"], eff, labels)
    return out


def _mujoco_candidates(
    backends: tuple[str, str],
    slot: dict[str, int],
    eff: list[dict[str, Any]],
    labels: tuple[str, str],
    dt: float,
) -> list[Candidate]:
    """MuJoCo's settings that move its contacts toward the other engine's: the contact time
    constant, the friction cone, the no-slip iterations (:func:`_engine_candidates`).

    Args:
        slot: each backend's slot in the pair (the first where one runs twice).
        eff: each slot's engine settings in effect.
    """
    out: list[Candidate] = []
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
    return out


def _physx_candidates(
    backends: tuple[str, str], x: int, eff: list[dict[str, Any]], labels: tuple[str, str]
) -> list[Candidate]:
    """PhysX's settings (slot ``x``) that move its contacts toward the other engine's: the
    rest offset and the contact offset (:func:`_engine_candidates`).

    Args:
        eff: each slot's engine settings in effect.
    """
    out: list[Candidate] = []
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
