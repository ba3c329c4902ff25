"""Engine settings (simbridge.engine_settings): declared, checked, carried by a profile, applied
by each backend on its real engine, recorded in the manifest.

The physics checks use robots/free_box.urdf (3 kg, 0.4 m tall) on robots/plane.urdf, one
second at 1/240 s: each setting must move a measured figure the way the engine's own
documentation says, and each setting given at its declared default must leave a run bit for
bit as it is with none given (that holds the declared defaults to what the backend does).
"""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import numpy as np
import pytest

import simbridge
from simbridge import engine_settings as es
from simbridge.exceptions import (
    InvalidArgumentError,
    InvalidEngineSettingError,
    InvalidProfileError,
    UnknownBackendError,
)

ROBOTS = Path(simbridge.__file__).resolve().parents[2] / "robots"
needs_sapien = pytest.mark.needs_backend("physx")  # tests/_engines.py: skipped, or fails in CI
ENGINE_MODULES = ("pybullet", "mujoco", "sapien")


# ---------------------------------------------------------------- declared and checked


@pytest.mark.parametrize("backend", ["pybullet", "mujoco", "physx"])
def test_every_backend_declares_settings_with_a_valid_default(backend):
    known = es.settings_for(backend)
    assert len(known) >= 6
    prof = simbridge.get_profile("pybullet")
    for key, s in known.items():
        assert s.key == key and s.meaning and s.range_text()
        # the declared default passes its own check
        assert s.check(backend, s.default_for(prof)) is not None
        if s.toward:
            other, _, other_key = s.toward.partition(".")
            assert other_key in es.settings_for(other), s.toward


def test_reading_the_settings_imports_no_engine():
    code = (
        "import sys\n"
        "from simbridge import engine_settings as es\n"
        "for b in ('pybullet', 'mujoco', 'physx'):\n"
        "    es.settings_for(b)\n"
        "import simbridge\n"
        "simbridge.get_profile('pybullet').with_engine('mujoco', impratio=3)\n"
        f"print(sorted(m for m in {ENGINE_MODULES!r} if m in sys.modules))\n"
    )
    import subprocess

    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_an_unknown_key_lists_the_valid_ones():
    with pytest.raises(InvalidProfileError) as err:
        es.validate("mujoco", {"stiffness": 1.0})
    assert isinstance(err.value, InvalidEngineSettingError)
    msg = str(err.value)
    assert "mujoco.stiffness" in msg and "solref" in msg and "impratio" in msg


@pytest.mark.parametrize(
    ("backend", "key", "value", "words"),
    [
        ("mujoco", "impratio", -1.0, "> 0"),
        ("mujoco", "cone", "round", "['pyramidal', 'elliptic']"),
        ("mujoco", "solref", [0.02], "2 finite numbers"),
        ("mujoco", "solimp", [0.9, float("nan"), 0.001], "3 or 5 finite numbers"),
        ("mujoco", "noslip_iterations", 2.5, "an integer >= 0"),
        ("pybullet", "contactERP", 1.5, "<= 1"),
        ("pybullet", "useSplitImpulse", 1, "true or false"),
        ("pybullet", "numSubSteps", True, "an integer"),
        ("physx", "contact_offset", 0.0, "> 0"),
        ("physx", "solver", "pgs", "['PGS', 'TGS']"),
    ],
)
def test_a_bad_value_names_the_key_and_its_range(backend, key, value, words):
    with pytest.raises(InvalidEngineSettingError) as err:
        es.validate(backend, {key: value})
    assert f"{backend}.{key}" in str(err.value) and words in str(err.value)


def test_settings_that_must_agree_are_checked_together():
    with pytest.raises(InvalidEngineSettingError, match="physx.rest_offset.*below contact_offset"):
        simbridge.get_profile("pybullet").with_engine("physx", rest_offset=0.02)  # 1 cm default
    with pytest.raises(InvalidEngineSettingError, match="rest_offset"):
        es.validate("physx", {"contact_offset": 0.0002})  # below the 0.5 mm rest offset
    ok = es.validate("physx", {"contact_offset": 0.05, "rest_offset": 0.02})
    assert ok == {"contact_offset": 0.05, "rest_offset": 0.02}


def test_an_unknown_backend_lists_the_registered_ones():
    with pytest.raises(UnknownBackendError) as err:
        simbridge.get_profile("pybullet").with_engine("bullet", erp=0.3)
    assert "pybullet" in str(err.value) and "mujoco" in str(err.value)


def test_the_profile_carries_settings_frozen_hashable_and_json_able():
    base = simbridge.get_profile("pybullet")
    assert base.engine("mujoco") == {} and "engines" not in base.as_dict()
    p = base.with_engine("mujoco", solref=[0.01, 1], impratio=10).with_engine(
        "pybullet", contactERP=0.2
    )
    p = p.with_engine("mujoco", impratio=4)  # on top: solref kept, impratio replaced
    assert p.engine("mujoco") == {"impratio": 4.0, "solref": (0.01, 1.0)}
    assert p.engine("pybullet") == {"contactERP": 0.2}
    assert hash(p) == hash(
        base.with_engine("pybullet", contactERP=0.2).with_engine(
            "mujoco", impratio=4, solref=(0.01, 1.0)
        )
    )
    assert pickle.loads(pickle.dumps(p)) == p
    d = p.as_dict()
    assert d["engines"] == {
        "mujoco": {"impratio": 4.0, "solref": [0.01, 1.0]},
        "pybullet": {"contactERP": 0.2},
    }
    assert simbridge.Profile(**d) == p  # the JSON-able form reads back to an equal profile
    assert p.with_(timestep=0.01).engine("mujoco") == p.engine("mujoco")
    with pytest.raises(InvalidArgumentError):
        simbridge.Profile(name="x", engines={"mujoco": 3})


def test_effective_values_follow_the_profile():
    p = simbridge.get_profile("pybullet").with_(timestep=0.005)
    assert es.effective("mujoco", p)["solref"] == [0.01, 1.0]  # 2 dt, the backend's own
    assert es.effective("mujoco", p.with_engine("mujoco", solref=(0.03, 0.9)))["solref"] == [
        0.03,
        0.9,
    ]
    assert es.effective("pybullet", p)["contactERP"] == 0.08


def test_an_assignment_is_read_as_toml():
    assert es.parse_assignment("mujoco.impratio=10") == ("mujoco", "impratio", 10)
    assert es.parse_assignment("mujoco.solref=[0.01, 1]") == ("mujoco", "solref", [0.01, 1])
    assert es.parse_assignment("mujoco.cone=elliptic") == ("mujoco", "cone", "elliptic")
    assert es.parse_assignment("pybullet.useSplitImpulse=false")[2] is False
    for bad in ("impratio=10", "mujoco.impratio", "mujoco.=1", ".x=1"):
        with pytest.raises(InvalidArgumentError):
            es.parse_assignment(bad)


# ---------------------------------------------------------------- applied on the engines


def _box(backend, *, z=0.2, steps=240, profile="pybullet", **settings):
    """The free box on the plane from height ``z``: (base z per step, base vz per step,
    manifest)."""
    with simbridge.Sim(backend, profile=profile, engine_settings=settings) as sim:
        sim.load_urdf(ROBOTS / "plane.urdf", fixed_base=True)
        b = sim.load_urdf(
            ROBOTS / "free_box.urdf", base_position=(0.0, 0.0, z), base_orientation=TILT
        )
        zs, vs = [], []
        for _ in range(steps):
            sim.step()
            s = sim.base_state(b)
            zs.append(s.position[2])
            vs.append(s.linear_velocity[2])
        return np.array(zs), np.array(vs), sim.manifest()


TILT = (0.0, 0.0, 0.0, 1.0)


def _settle(backend, **settings):
    """Where the resting box's base ends, less where it would touch the plane (m)."""
    return _box(backend, **settings)[0][-1] - 0.2


def _pop(backend, **settings):
    """The box started 2 cm into the plane: its largest upward speed over 24 steps (m/s)."""
    return _box(backend, z=0.18, steps=24, **settings)[1].max()


def _rebound(backend, **settings):
    """The box dropped 30 cm with restitution 0.5: its largest upward speed (m/s)."""
    prof = simbridge.get_profile("pybullet").with_(restitution=0.5)
    return _box(backend, z=0.5, profile=prof, **settings)[1].max()


def test_mujoco_settings_change_the_physics():
    base = _settle("mujoco")
    # a softer contact (time constant 0.05 s against 2 dt) lets the resting box sink deeper
    assert _settle("mujoco", solref=[0.05, 1.0]) < base - 1e-5
    # the margin: contacts act from 1 cm away, the box rests there
    assert _settle("mujoco", margin=0.01) == pytest.approx(0.01, abs=2e-4)
    assert base == pytest.approx(0.001, abs=2e-4)  # the default 1 mm margin
    # a penetration pushed out slower by a softer contact, faster by a weaker impedance
    pop = _pop("mujoco")
    assert _pop("mujoco", solref=[0.05, 1.0]) < 0.5 * pop
    assert _pop("mujoco", solimp=[0.5, 0.6, 0.01]) > 1.2 * pop


def test_pybullet_settings_change_the_physics():
    # the contact ERP is the share of a penetration corrected per step: 2 cm * 0.08 / dt
    pop = _pop("pybullet")
    assert pop == pytest.approx(0.02 * 0.08 * 240, rel=0.02)
    assert _pop("pybullet", contactERP=0.8) == pytest.approx(10 * pop, rel=0.02)
    # slop: penetration left alone; a global CFM softens every contact
    assert _settle("pybullet", contactSlop=0.01) == pytest.approx(-0.01, abs=2e-4)
    assert _settle("pybullet", globalCFM=0.01) < _settle("pybullet") - 1e-3
    # no bounce under the restitution velocity threshold (the drop lands at ~2.4 m/s)
    assert _rebound("pybullet") > 0.5
    assert _rebound("pybullet", restitutionVelocityThreshold=5.0) < 0.3 * _rebound("pybullet")


@needs_sapien
def test_physx_settings_change_the_physics():
    # two shapes rest the sum of their rest offsets apart: 2 x 0.5 mm, then 2 x 5 mm
    assert _settle("physx") == pytest.approx(0.001, abs=1e-4)
    assert _settle("physx", rest_offset=0.005) == pytest.approx(0.01, abs=1e-4)
    # a penetration leaves no faster than the depenetration cap
    assert _pop("physx") > 0.01
    assert _pop("physx", max_depenetration_velocity=0.001) <= 0.001 + 1e-6
    # more velocity iterations leave less spurious speed after the push-out
    assert _pop("physx", solver_velocity_iterations=8) < 0.1 * _pop("physx")
    # the bounce threshold: a 2.4 m/s landing bounces under 2 m/s, not under 5 m/s
    assert _rebound("physx") > 0.3
    assert _rebound("physx", bounce_threshold=5.0) < 0.01
    with pytest.raises(InvalidProfileError, match="rest_offset"):
        _box("physx", steps=1, rest_offset=0.02)  # not below the contact offset


def _defaults(backend):
    prof = simbridge.get_profile("pybullet")
    return {k: s.default_for(prof) for k, s in es.settings_for(backend).items()}


@pytest.mark.parametrize(
    "backend", ["pybullet", "mujoco", pytest.param("physx", marks=needs_sapien)]
)
def test_every_setting_at_its_default_changes_nothing(backend):
    """Each declared default given explicitly: the same run, bit for bit (the declared
    defaults are what the backend does when none is set)."""
    ref = _box(backend, z=0.25, steps=120)
    prof = simbridge.get_profile("pybullet").with_(restitution=0.3)
    ref_bounce = _box(backend, z=0.5, steps=120, profile=prof)
    all_defaults = _defaults(backend)
    run = _box(backend, z=0.25, steps=120, **all_defaults)
    np.testing.assert_array_equal(run[0], ref[0])
    np.testing.assert_array_equal(run[1], ref[1])
    run = _box(backend, z=0.5, steps=120, profile=prof, **all_defaults)
    np.testing.assert_array_equal(run[0], ref_bounce[0])
    np.testing.assert_array_equal(run[1], ref_bounce[1])


@pytest.mark.parametrize(
    "backend", ["pybullet", "mujoco", pytest.param("physx", marks=needs_sapien)]
)
def test_the_manifest_records_the_effective_values(backend):
    known = es.settings_for(backend)
    key = next(k for k, s in known.items() if s.kind == "float")
    value = known[key].default_for(simbridge.get_profile("pybullet"))
    value = value / 2 if value else 1e-3
    *_, plain = _box(backend, steps=1)
    *_, chosen = _box(backend, steps=1, **{key: value})
    assert set(plain["engine_settings"]) == set(known)
    assert plain["engine_settings"] == _json(_defaults(backend))
    assert chosen["engine_settings"][key] == value
    assert chosen["profile"]["engines"] == {backend: {key: value}}
    assert "engines" not in plain["profile"]


def _json(d):
    return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}


@needs_sapien
def test_physx_contact_distance_follows_the_rest_offset():
    """A resting contact reads distance ~0 whatever the rest offset (the offset is where
    PhysX's shapes rest, the contact's zero)."""
    for settings in ({}, {"rest_offset": 0.004}):
        with simbridge.Sim("physx", engine_settings=settings) as sim:
            sim.load_urdf(ROBOTS / "plane.urdf", fixed_base=True)
            sim.load_urdf(ROBOTS / "free_box.urdf", base_position=(0.0, 0.0, 0.21))
            sim.step(240)
            points = sim.contact_points()
            assert points
            assert max(abs(c.distance) for c in points) < 2e-4, settings


def _slide(backend, **settings):
    """The box, settled, given 2 m/s along x and 1 m/s along y, sliding for a second against
    friction 0.5: where it stops, (x, y) m from where it started."""
    with simbridge.Sim(backend, engine_settings=settings) as sim:
        sim.load_urdf(ROBOTS / "plane.urdf", fixed_base=True)
        b = sim.load_urdf(ROBOTS / "free_box.urdf", base_position=(0.0, 0.0, 0.2))
        sim.step(24)
        sim.reset_base_state(b, linear_velocity=(2.0, 1.0, 0.0))
        sim.step(240)
        x, y, _ = sim.base_state(b).position
        return x, y


def test_the_friction_cone_settings_meet_across_engines():
    """A cone decelerates the slide along its velocity; a pyramid, each axis apart: the path
    bends. MuJoCo's elliptic cone takes its path to PyBullet's (whose default is a cone), and
    PyBullet's pyramid bends it (measured: y/x 0.42 PyBullet, 0.83 MuJoCo's pyramid, 0.43
    MuJoCo's cone, 0.19 PyBullet's pyramid)."""
    x, y = _slide("pybullet")
    cone = y / x
    x, y = _slide("mujoco")
    assert abs(y / x - cone) > 0.3
    x, y = _slide("mujoco", cone="elliptic")
    assert abs(y / x - cone) < 0.05
    x, y = _slide("pybullet", enableConeFriction=False)
    assert abs(y / x - cone) > 0.15
    # MuJoCo's frictional impedance moves the slide too (measured: x 0.66 m at impratio 10,
    # 0.48 m at 1, pyramidal cone)
    assert _slide("mujoco", impratio=10)[0] > _slide("mujoco")[0] + 0.05


def test_a_contact_offset_below_the_default_rest_offset_blames_the_contact_offset():
    # the user set contact_offset only: the message names it, and rest_offset's default
    with pytest.raises(InvalidEngineSettingError) as err:
        es.validate("physx", {"contact_offset": 0.0004})
    text = str(err.value)
    assert text.startswith("engine setting physx.contact_offset:"), text
    assert err.value.key == "contact_offset"
    assert "rest_offset" in text and "default 0.0005 m (0.5 mm)" in text
    assert "must stay below contact_offset" in text and "got 0.0004" in text
    # both set: the rest offset is the one to move, as before
    with pytest.raises(InvalidEngineSettingError, match="physx.rest_offset: must be below"):
        es.validate("physx", {"contact_offset": 0.0004, "rest_offset": 0.001})


def test_a_setting_of_another_engine_says_whose_it_is():
    with pytest.raises(InvalidEngineSettingError) as err:
        es.validate("mujoco", {"contact_offset": 0.002})
    text = str(err.value)
    assert "contact_offset is a physx setting; mujoco's are: " in text, text
    assert all(key in text for key in es.settings_for("mujoco"))
    # a key of no engine keeps its "did you mean"
    with pytest.raises(InvalidEngineSettingError, match=r"did you mean 'impratio'") as err:
        es.validate("mujoco", {"impratoi": 1})
    assert "is a" not in str(err.value)
