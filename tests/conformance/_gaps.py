"""Known gaps of the conformance suite: what a backend cannot do exactly, with the measured size
(a module of its own: ``from conftest import gap`` found another folder's conftest when pytest
collected tests/conformance and tests/compare in one call).

The suite names no backend in its tests. Where backends differ, a test asks :func:`gap` for
the backend under test: the table below is keyed by gap, then by the name a backend class is
registered under. A backend not listed under a gap is held to the exact rule the test states
(the tightest figure measured on any backend, or PyBullet's own behaviour). A backend class
that subclasses a listed one inherits its gaps (the lookup walks the class's bases), so a
backend registered under a new name for an engine already here answers as that engine does;
a backend on a new engine lists its own gaps here, measured (tests/conformance/README.md).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TypeVar

from simbridge.exceptions import BackendError
from simbridge.registry import available_backends, load_backend, unavailable_reason

__all__ = ["KNOWN_GAPS", "REFERENCE", "declared", "gap", "gap_names", "usable_backends"]

T = TypeVar("T")

# The backend whose behaviour is the reference semantics (PyBullet's): a test whose expectation
# is "what PyBullet does" runs it beside the backend under test, named here and nowhere else.
REFERENCE = "pybullet"

# Known gaps: a test that meets one uses the measured size as its tolerance instead of skipping
# (gz-physics' CHECK_UNSUPPORTED_ENGINE with a number), and checks that the gap is still real
# where it can (a gap that closed must be removed). Keyed by gap, then backend.
KNOWN_GAPS: dict[str, dict[str, float]] = {
    # PyBullet's getLinkState returns link poses rounded to float32 (the shared-memory link-state
    # buffer), and so does a fixed base's pose; a free base's pose and joint states stay double.
    # Measured worst error against yourdfpy's double-precision kinematics on the suite's robots
    # (test_kinematics.py, poses within ~2 m of the origin): 3.3e-7 (laikago_toes.urdf), 2.1e-7
    # (r2d2), 7e-8 (pendulum); limit 5e-7 (float32 eps 1.19e-7 times |x| <= ~2, plus composition).
    # Exact rule: 1e-9 (test_kinematics.TOL).
    "link_state_float32": {"pybullet": 5e-7},
    # Link frames at load against raw PyBullet's (test_pybullet_data.py, test_mjcf_sdf.py,
    # test_corpus.py), relative to max(1, |position|). Exact rule: 2e-7 (raw PyBullet's frames
    # are float32-rounded: _raw.FRAME_REL). PhysX keeps every pose in float32 and places each link
    # by composing float32 joint frames down the chain: measured worst over pybullet_data 3.0e-7
    # (bicycle/bike.urdf; kuka_iiwa/model.urdf link 3 2.2e-7; bench/urdf_coverage.py); limit
    # 1e-6, about 8 float32 spacings.
    "link_frames_vs_raw": {"physx": 1e-6},
    # The most movable joints one body may have (test_limits.py, test_corpus.py): PyBullet's
    # state reads fail past 121 (measured, bench/limits.py). Exact rule: no limit (128 load).
    "most_joints": {"pybullet": 121},
    # The deepest nesting of joints a backend takes, refused one deeper up front (test_limits.py):
    # PyBullet 121 (as most_joints), MuJoCo 1022 (its compiler's signature depth). Exact rule:
    # no limit (a 200-joint chain loads and steps).
    "deepest_chain": {"pybullet": 121, "mujoco": 1022},
    # The deepest element nesting the engine's XML reader takes (test_errors.py): PyBullet's
    # TinyXML refuses more than 98 levels, <robot> counting 1 (measured on raw PyBullet). Exact
    # rule: no limit.
    "deepest_xml": {"pybullet": 98},
    # Where a contact point on B lies (test_contacts.py): on the surface (PyBullet, measured
    # 2e-16), or half the pair margin above it (MuJoCo's 1 mm margin: 5e-4 m, to 1e-12). The
    # size is that height. Exact rule: on the surface, within 1e-5 m.
    "contact_point_above_surface": {"mujoco": 5e-4},
    # A portable state (no engine data) carried into another Sim of the same engine, largest
    # one-step error over r2d2-gentle's 6 points (test_state.py): PyBullet 1.9e-2 (over all of
    # r2d2-gentle, bench/state_floor.py: 0.22 rad/s on a wheel, 3.6e-2 m/s at the base): the other
    # world has not the contact manifolds of this one (PyBullet collects up to 4 points per pair
    # over several steps and warm-starts their impulses), and none can be set; 0.5 is 2x the worst
    # of the whole scenario. Exact rule: 1e-10 (MuJoCo measured 1.9e-15: a cold solver start;
    # over the whole scenario one point reached 1e-8 m/s).
    "state_in_another_sim": {"pybullet": 0.5},
    # The same with the engine's own data (get_state()): PyBullet's saveState belongs to its own
    # client, so the portable state is set and the floor above is real (measured > 1e-6).
    # Exact rule: the next step is the same bits (MuJoCo: the same compiled layout).
    "engine_state_in_another_sim": {"pybullet": 0.5},
    # Spherical commands against raw PyBullet's (test_spherical.py CASES): the exact rule is the
    # same bits (the PyBullet backend makes the same engine calls). The size scales the measured
    # tolerances CASES lists beside each case (MuJoCo: 1, those figures as measured).
    "spherical_commands_vs_raw": {"mujoco": 1.0},
    # Two velocity motors on coupled rows (the double pendulum, test_cross_engine.py): PyBullet's
    # iterative solve leaves the elbow 1e-4 .. 7e-4 rad/s short of its target each step
    # (measured -1.99999 .. -1.9993 for -2). Exact rule: 1e-9 (MuJoCo's rows solved exactly).
    "coupled_motor_rows": {"pybullet": 1e-3},
    # A spherical motor's three rows coupled by the child's inertia (test_spherical.py): one step
    # from rest 0.7 rad from the target, how far short of the asked velocity the joint lands.
    # PyBullet's 50 solver iterations: measured 2.07 rad/s short of 6.68 asked (0.03 at 200
    # iterations); limit 2.5. Exact rule: 1e-12 (MuJoCo solves the rows exactly).
    "spherical_motor_coupled_rows": {"pybullet": 2.5},
}


def _lineage(backend: str) -> list[str]:
    """``backend`` and then the names its class's bases are registered under (most derived
    first): a subclass of a listed backend answers as its base where it is not listed itself."""
    names = [backend]
    try:
        cls = load_backend(backend)
    except BackendError:  # not loadable here: only its own name applies
        return names
    for base in cls.__mro__[1:]:
        name = base.__dict__.get("name")
        if isinstance(name, str) and name not in names:
            names.append(name)
    return names


def declared(table: Mapping[str, T], backend: str) -> T | None:
    """``backend``'s entry in a table keyed by backend (or the entry of the backend its class
    derives from), or None when it has none."""
    for candidate in _lineage(backend):
        if candidate in table:
            return table[candidate]
    return None


def gap(backend: str, name: str) -> float | None:
    """The measured size of known gap ``name`` of ``backend`` (or of the backend its class
    derives from), or None when it has none: held to the exact rule."""
    return declared(KNOWN_GAPS[name], backend)  # KeyError: a gap no entry describes (a typo)


def gap_names() -> list[str]:
    return sorted(KNOWN_GAPS)


def usable_backends() -> list[str]:
    """Every registered backend that loads here, in registration order (for the tests that
    carry a state or a model from the backend under test to each other one)."""
    return [name for name in available_backends() if unavailable_reason(name) is None]
