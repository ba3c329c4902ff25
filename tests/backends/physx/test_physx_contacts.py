"""PhysX's contact points (backends/physx/contacts.py, each point converted in Python floats)
against two references written here, on a driven r2d2 whose points both rest (no friction
impulse: a perpendicular is chosen) and slide: a numpy reference one point at a time
(``np.cross``, ``np.linalg.norm``), and, bit for bit, the array version the backend used
before (every point of a step at once, the arithmetic on ``(k, 3)`` arrays)."""

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


def _array_version(sim) -> list[tuple]:
    """The last step's points as the backend computed them before its per-point floats: every
    point at once on ``(k, 3)`` float64 arrays, dot and cross products written out (x, y, z
    summed in turn), the perpendicular from the same terms."""
    from simbridge.backends.physx import inspect
    from simbridge.backends.physx.contacts import REST

    backend = inspect.backend_of(sim)
    owners = backend._owners()
    pairs, fields = [], []
    for contact in inspect.scene(sim).get_contacts():
        a, b = owners.get(id(contact.bodies[0])), owners.get(id(contact.bodies[1]))
        if a is None or b is None:
            continue
        for point in contact.points:
            pairs.append((a[0], b[0], a[1], b[1]))
            fields.extend((point.position, point.normal, point.impulse))
            fields.append((point.separation, 0.0, 0.0))
    if not pairs:
        return []
    raw = np.array(fields, dtype=float).reshape(-1, 4, 3)

    def dot(u, v):
        return u[:, 0] * v[:, 0] + u[:, 1] * v[:, 1] + u[:, 2] * v[:, 2]

    def cross(u, v):
        return np.stack(
            [
                u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1],
                u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2],
                u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0],
            ],
            axis=1,
        )

    on_b, n = raw[:, 0], raw[:, 1]
    force = raw[:, 2] * (1.0 / backend._dt)
    normal_force = dot(force, n)
    tangential = force - normal_force[:, None] * n
    size = np.sqrt(dot(tangential, tangential))
    moving = size > 0.0
    d1 = tangential / np.where(moving, size, 1.0)[:, None]
    y = (np.abs(n[:, 0]) >= 0.9).astype(float)[:, None]
    axis = np.concatenate([1.0 - y, y, 0.0 * y], axis=1)
    perp = cross(n, axis)
    d1 = np.where(moving[:, None], d1, perp / np.sqrt(dot(perp, perp))[:, None])
    d2 = cross(n, d1)
    dist = raw[:, 3, 0] - REST
    on_a = on_b + dist[:, None] * n
    pushed = np.where(normal_force < 0.0, 0.0, normal_force)
    return [
        (*pairs[i], *on_a[i], *on_b[i], *n[i], dist[i], pushed[i], size[i], *d1[i], 0.0, *d2[i])
        for i in range(len(pairs))
    ]


def test_points_are_the_array_version_bit_for_bit():
    """Every point of 600 steps of the drive, every field the very float (signed zeros too)
    of the array version: the per-point floats change the cost, not the values."""
    with simbridge.Sim("physx") as sim:
        sim.load_urdf("plane.urdf")
        r2d2 = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
        resting = sliding = 0
        for k in range(600):
            v = 8.0 * np.sin(k / 60.0)
            sim.set_joint_velocity(r2d2, [2, 3, 6, 7], [v, v, -v, -v], max_force=50.0)
            sim.step()
            got = [_flat(p) for p in sim.contact_points()]
            want = _array_version(sim)
            assert len(got) == len(want), k
            for g, w in zip(got, want, strict=True):
                assert g[:4] == w[:4], k
                assert all(type(x) is float for x in g[4:]), k
                assert np.array(g[4:]).tobytes() == np.array(w[4:]).tobytes(), (k, g, w)
            resting += sum(1 for w in want if w[15] == 0.0)
            sliding += sum(1 for w in want if w[15] > 0.0)
    assert resting > 100 and sliding > 100, (resting, sliding)


def test_the_perpendicular_is_the_per_point_one():
    """The friction direction chosen where there is no friction impulse, for normals all round
    (near x too, where the axis crossed changes), against ``np.cross`` one normal at a time,
    and the second direction completing an orthonormal frame."""
    from simbridge.backends.physx.contacts import _point

    rng = np.random.default_rng(0)
    n = rng.normal(size=(500, 3))
    n[:100] = [1.0, 0.0, 0.0] + 0.05 * n[:100]  # near +x
    n[100:150] = [-1.0, 0.0, 0.0] + 0.05 * n[100:150]  # near -x
    n /= np.linalg.norm(n, axis=1)[:, None]
    pair = (1, 0, 2, -1)
    for i in range(len(n)):
        normal = n[i].tolist()
        p = _point(pair, [0.1, 0.2, 0.3], normal, [0.0, 0.0, 0.0], 0.001, 240.0, 0.001)
        assert p[1:5] == pair
        assert p.lateral_friction_1 == 0.0 and p.normal_force == 0.0 and p.distance == 0.0
        axis = np.array([1.0, 0.0, 0.0] if abs(n[i, 0]) < 0.9 else [0.0, 1.0, 0.0])
        d = np.cross(n[i], axis)
        np.testing.assert_allclose(p.lateral_friction_dir_1, d / np.linalg.norm(d), atol=1e-15)
        frame = np.array([p.lateral_friction_dir_1, p.lateral_friction_dir_2, normal])
        np.testing.assert_allclose(frame @ frame.T, np.eye(3), atol=1e-12)
    assert (np.abs(n[:, 0]) >= 0.9).sum() >= 100


def test_a_point_pushed_and_sliding():
    """One point by hand: the impulse over dt split along the normal and across it, the
    point on A a distance along the normal from B's, a pull (negative along the normal) read
    as no push."""
    from simbridge.backends.physx.contacts import _point

    p = _point(
        (0, 1, -1, 3), [1.0, 2.0, 3.0], [0.0, 0.0, 1.0], [0.5, 0.0, 2.0], 0.003, 100.0, 0.002
    )
    assert p.contact_flag == 0 and (p.body_a, p.body_b, p.link_a, p.link_b) == (0, 1, -1, 3)
    assert p.position_on_b == (1.0, 2.0, 3.0)
    assert p.distance == pytest.approx(0.001)
    assert p.position_on_a == pytest.approx((1.0, 2.0, 3.001))
    assert p.normal_force == pytest.approx(200.0)
    assert p.lateral_friction_1 == pytest.approx(50.0)
    assert p.lateral_friction_dir_1 == pytest.approx((1.0, 0.0, 0.0))
    assert p.lateral_friction_2 == 0.0
    assert p.lateral_friction_dir_2 == pytest.approx((0.0, 1.0, 0.0))  # normal x dir 1
    pulled = _point((0, 1, -1, 3), [0.0] * 3, [0.0, 0.0, 1.0], [0.0, 0.0, -1.0], 0.0, 100.0, 0.0)
    assert pulled.normal_force == 0.0 and pulled.lateral_friction_1 == 0.0


def test_a_normal_of_length_zero_gives_nan_directions_as_the_array_version():
    """No unit normal (a degenerate report): the friction directions are numpy's 0 / 0, NaN,
    as the array version gave them, not a ZeroDivisionError."""
    from simbridge.backends.physx.contacts import _point

    with pytest.warns(RuntimeWarning):
        p = _point((0, 1, -1, -1), [0.0] * 3, [0.0, 0.0, 0.0], [0.0] * 3, 0.0, 240.0, 0.0)
    assert all(np.isnan(p.lateral_friction_dir_1)) and all(np.isnan(p.lateral_friction_dir_2))
    assert p.normal_force == 0.0 and p.lateral_friction_1 == 0.0
