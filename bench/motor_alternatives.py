"""Motor-law alternatives against PyBullet ("urdf" profile: no link damping, no brake).

    python bench/motor_alternatives.py

For each case, the largest |v - v_pybullet| over the run and the ripple around the target over
the last steps, for the MuJoCo backend's friction-loss rows and for the laws it was chosen over.
"""

import mujoco
import numpy as np

import simbridge
from simbridge.backends.mujoco import inspect


def through_sim(backend, urdf, joints, target, force, steps):
    """The velocity motor as simbridge runs it on ``backend``: joint velocities per step."""
    with simbridge.Sim(backend, profile="urdf") as s:
        r = s.load_urdf(urdf, fixed_base=True)
        s.set_joint_velocity(r, joints, target, max_force=force)
        out = []
        for _ in range(steps):
            s.step()
            out.append(s.joint_states(r, joints).velocities.copy())
        return np.array(out)


def raw(urdf, joints, target, force, steps, law, kv_scale=1.0):
    with simbridge.Sim("mujoco", profile="urdf") as s:
        r = s.load_urdf(urdf, fixed_base=True)
        s.set_joint_velocity(r, joints, 0.0, max_force=0.0)  # no rows: the law below drives
        m, d = inspect.model_and_data(s)
        dofs = inspect.robot(s, r).dofadr[joints]
        tv, F = np.asarray(target, float), np.asarray(force, float)
        dt = m.opt.timestep
        Mfull = np.zeros((m.nv, m.nv))
        out = []
        for _ in range(steps):
            mujoco.mj_step1(m, d)
            d.qfrc_applied[:] = 0
            mujoco.mj_fwdActuation(m, d)
            mujoco.mj_fwdAcceleration(m, d)
            vfree = d.qvel[dofs] + dt * d.qacc_smooth[dofs]
            mujoco.mj_fullM(m, d, Mfull)
            Minv = np.linalg.inv(Mfull)[np.ix_(dofs, dofs)]
            if (
                law == "kv"
            ):  # velocity actuator kv (ctrl - v), explicit (Euler), kv = scale * I_eff / dt
                kv = kv_scale / (np.diag(Minv) * dt)
                tau = np.clip(kv * (tv - d.qvel[dofs]), -F, F)
            elif law == "diag":  # per-step torque from the joint's own M^-1 entry
                tau = np.clip((tv - vfree) / (dt * np.diag(Minv)), -F, F)
            else:  # coupled solve over the motor dofs, then clamped
                tau = np.clip(np.linalg.solve(Minv, tv - vfree) / dt, -F, F)
            d.qfrc_applied[dofs] = tau
            mujoco.mj_step2(m, d)
            out.append(d.qvel[dofs].copy())
        return np.array(out)


cases = [
    ("wheel: one motor", "wheel.urdf", [0], [20.0], [1.0], 480),
    ("double pendulum: coupled", "double_pendulum.urdf", [0, 1], [1.0, -2.0], [5.0, 1.0], 240),
    ("double pendulum: strong", "double_pendulum.urdf", [0, 1], [1.0, -2.0], [500.0, 500.0], 240),
]
for title, urdf, j, tv, F, n in cases:
    ref = through_sim("pybullet", urdf, j, tv, F, n)
    rows = {
        "friction-loss rows (chosen)": through_sim("mujoco", urdf, j, tv, F, n),
        "velocity actuator kv=I/dt": raw(urdf, j, tv, F, n, "kv"),
        "velocity actuator kv=10 I/dt": raw(urdf, j, tv, F, n, "kv", 10.0),
        "torque law, own M^-1 entry": raw(urdf, j, tv, F, n, "diag"),
        "torque law, coupled solve": raw(urdf, j, tv, F, n, "coupled"),
    }
    print(title)
    for k, v in rows.items():
        err = np.abs(v - ref).max()
        ripple = np.abs(v[-20:] - np.asarray(tv)).max()
        print(
            f"   {k:32s} max|v - v_pybullet| {err:9.2e} rad/s   end ripple |v - v*| {ripple:9.2e}"
        )
