"""PhysX's contact points, computed for all points at once (backends/physx/contacts.py), against
a plain per-point reference written here (PhysX's normal, impulse over dt, separation less the
rest offsets, one point at a time with ``np.cross``), on a driven r2d2 whose points both rest
(no friction impulse: a perpendicular is chosen) and slide."""

from __future__ import annotations

import numpy as np
import pytest

import simbridge

pytestmark = pytest.mark.needs_backend("physx")  # tests/_engines.py: skipped, or fails in CI


def _reference(sim) -> list[tuple]:
    """The last step's points, one at a time (the backend's conversion before it was done on
    arrays; as its module docstring says)."""
    from simbridge.backends.physx import inspect
    from simbridge.backends.physx.contacts import REST

    backend = inspect.backend_of(sim)
    owners = {}
    for body, robot in backend._robots.items():
        if robot.static:
            owners[id(robot.built.actor)] = (body, -1)
        else:
            for k, comp in enumerate(robot.built.links):
                owners[id(comp)] = (body, k - 1)
    out = []
    for contact in inspect.scene(sim).get_contacts():
        a, b = owners.get(id(contact.bodies[0])), owners.get(id(contact.bodies[1]))
        if a is None or b is None:
            continue
        for point in contact.points:
            n = np.asarray(point.normal, dtype=float)
            force = np.asarray(point.impulse, dtype=float) * (1.0 / backend._dt)
            normal_force = float(force @ n)
            tangential = force - normal_force * n
            size = float(np.linalg.norm(tangential))
            if size > 0.0:
                d1 = tangential / size
            else:
                axis = np.array([1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
                d1 = np.cross(n, axis) / np.linalg.norm(np.cross(n, axis))
            dist = float(point.separation) - REST
            on_b = np.asarray(point.position, dtype=float)
            out.append(
                (a[0], b[0], a[1], b[1], *(on_b + dist * n), *on_b, *n, dist)
                + (max(normal_force, 0.0), size, *d1, 0.0, *np.cross(n, d1))
            )
    return out


def _flat(p) -> tuple:
    """A ContactPoint's fields after its flag, the vectors spread out."""
    out = []
    for x in p[1:]:
        out.extend(x if isinstance(x, tuple) else (x,))
    return tuple(out)


def test_points_match_the_per_point_reference():
    """Every point of 600 steps of a drive, field by field. Not bit for bit: the reference's
    ``np.linalg.norm`` of a 3-vector goes through BLAS's dot, the backend sums x, y, z in turn;
    measured over 3000 steps of this drive, the largest difference was 2.2e-16 (in the friction
    fields, 453 of the 3000 steps), hence 1e-12 here."""
    with simbridge.Sim("physx") as sim:
        plane = sim.load_urdf("plane.urdf")
        r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        resting = sliding = 0
        for k in range(600):
            v = 8.0 * np.sin(k / 60.0)
            sim.set_joint_velocity(r2d2, [2, 3, 6, 7], [v, v, -v, -v], max_force=50.0)
            sim.step()
            got = [_flat(p) for p in sim.contact_points()]
            want = _reference(sim)
            assert len(got) == len(want), k
            for g, w in zip(got, want, strict=True):
                assert g[:4] == w[:4], k  # bodies and links
                np.testing.assert_allclose(g[4:], w[4:], rtol=1e-12, atol=1e-12, err_msg=str(k))
            resting += sum(1 for w in want if w[15] == 0.0)
            sliding += sum(1 for w in want if w[15] > 0.0)
        assert {p.body_b for p in sim.contact_points(r2d2)} == {plane}
    # both branches of the friction direction were taken
    assert resting > 100 and sliding > 100, (resting, sliding)


def test_the_perpendicular_is_the_per_point_one():
    """The friction direction chosen where there is no friction impulse, for normals all round
    (near x too, where the axis crossed changes), against ``np.cross`` one normal at a time."""
    from simbridge.backends.physx.contacts import _perpendicular

    rng = np.random.default_rng(0)
    n = rng.normal(size=(500, 3))
    n[:100] = [1.0, 0.0, 0.0] + 0.05 * n[:100]  # near +x
    n[100:150] = [-1.0, 0.0, 0.0] + 0.05 * n[100:150]  # near -x
    n /= np.linalg.norm(n, axis=1)[:, None]
    got = _perpendicular(n)
    for i in range(len(n)):
        axis = np.array([1.0, 0.0, 0.0] if abs(n[i, 0]) < 0.9 else [0.0, 1.0, 0.0])
        d = np.cross(n[i], axis)
        np.testing.assert_allclose(got[i], d / np.linalg.norm(d), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(np.einsum("ij,ij->i", got, n), 0.0, atol=1e-12)
    assert (np.abs(n[:, 0]) >= 0.9).sum() >= 100
