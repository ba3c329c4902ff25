"""The test robots simulate the bodies their comments state: mass and principal moments per link
under both profiles (``"urdf"``: the file's inertia; ``"pybullet"``: the solid box around the
collision AABB, which equals the file's for every box- and sphere-shaped link by design)."""

from __future__ import annotations

import pytest


def box(m: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    return (m * (y * y + z * z) / 12, m * (x * x + z * z) / 12, m * (x * x + y * y) / 12)


def sphere(m: float, r: float) -> tuple[float, float, float]:
    i = 2 * m * r * r / 5
    return (i, i, i)


# Bullet pads a cylinder's collision AABB by 0.003 m per side (measured on PyBullet 3.2.7:
# 0.014145 kg m^2 about the axle of the 0.1 m wheel, where 2 m r^2 / 3 would be 0.013333).
PAD = 0.003
WHEEL_FILE = (2 * (3 * 0.01 + 0.04**2) / 12, 2 * (3 * 0.01 + 0.04**2) / 12, 2 * 0.01 / 2)
WHEEL_AABB = box(2, 0.2 + 2 * PAD, 0.2 + 2 * PAD, 0.04 + 2 * PAD)

# robot -> link -> (mass, file inertia, collision-AABB inertia)
ROBOTS = {
    "pendulum.urdf": {-1: (1, box(1, 0.1, 0.1, 0.1), None), 0: (1, sphere(1, 0.05), None)},
    "double_pendulum.urdf": {
        -1: (1, box(1, 0.1, 0.1, 0.1), None),
        0: (1, box(1, 0.04, 0.04, 0.5), None),
        1: (0.5, box(0.5, 0.04, 0.04, 0.4), None),
    },
    "wheel.urdf": {-1: (100, box(100, 0.2, 0.2, 0.2), None), 0: (2, WHEEL_FILE, WHEEL_AABB)},
    "slider.urdf": {-1: (2, box(2, 1.0, 0.1, 0.05), None), 0: (0.5, box(0.5, 0.1, 0.1, 0.1), None)},
    "free_box.urdf": {-1: (3, box(3, 0.2, 0.3, 0.4), None)},
    "spherical_pendulum.urdf": {
        -1: (1, box(1, 0.1, 0.1, 0.1), None),
        # its collision box is turned with the inertial frame: PyBullet takes it for a compound
        # (the frames equal to round-off, not exactly) and pads it by 1 mm a side (measured)
        0: (1, box(1, 0.2, 0.1, 0.05), box(1, 0.2 + 0.002, 0.1 + 0.002, 0.05 + 0.002)),
    },
}


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_robot_inertias_match_their_formulas(make_sim, profile, name):
    sim = make_sim(profile=profile)
    body = sim.load_urdf(name)  # free base: the base reports its mass
    for link, (mass, file_inertia, aabb_inertia) in ROBOTS[name].items():
        info = sim.dynamics_info(body, link)
        assert info.mass == mass
        # file values are written to 17 digits and AABB boxes measured equal to 2e-16
        # relative; the padded cylinder to 4e-8 (Bullet's float32 hull vertices)
        want, rel = file_inertia, 1e-12
        if sim.profile.inertia_source == "collision_aabb" and aabb_inertia is not None:
            want, rel = aabb_inertia, 1e-7
        assert info.local_inertia_diagonal == pytest.approx(want, rel=rel), (name, link)
