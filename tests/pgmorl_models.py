"""What MuJoCo compiles from PGMORL's model files, as plain numbers: the values the tests
compare between MuJoCo 2.3.3's compile of the published files and MuJoCo 4's compile of
the shipped ones (`wcac_jax/envs/assets/*_pgmorl.xml`).

Run as a script in a virtual environment with `mujoco==2.3.3` (no other package needed)
to write the committed fixture from the published files:

    python tests/pgmorl_models.py PGMORL/environments/assets \\
        > tests/fixtures/pgmorl_models_mujoco233.json

Imported by the tests, `compiled(model)` reads MuJoCo 4's compile the same way.
"""

import json
import os
import sys

import mujoco
import numpy as np

# shipped file -> the published file it comes from (PGMORL's and COLA's are identical)
PUBLISHED = {
    "walker2d_pgmorl.xml": "walker2d.xml",
    "hopper_pgmorl.xml": "hopper.xml",
    "swimmer_pgmorl.xml": "swimmer.xml",
    "ant_pgmorl.xml": "ant.xml",
    "half_cheetah_pgmorl.xml": "half_cheetah.xml",
    "humanoid_pgmorl.xml": "humanoid.xml",
}
CONTACT_STEPS = 200  # random-action steps over which the swimmer's contacts are counted


def _inertia_matrices(model) -> list:
    """Each body's inertia tensor about its centre of mass, in the body frame, `[nbody,
    3, 3]`: comparable whatever principal-axis order or sign the compiler picked."""
    out = []
    for b in range(model.nbody):
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, model.body_iquat[b])
        rot = rot.reshape(3, 3)
        out.append((rot @ np.diag(model.body_inertia[b]) @ rot.T).tolist())
    return out


def max_contacts(model, steps: int = CONTACT_STEPS, seed: int = 0) -> int:
    """The most contacts MuJoCo finds in any of `steps` random-action steps from the
    initial state."""
    data = mujoco.MjData(model)
    rng = np.random.default_rng(seed)
    lo, hi = model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1]
    most = 0
    for _ in range(steps):
        data.ctrl[:] = rng.uniform(lo, hi)
        mujoco.mj_step(model, data)
        most = max(most, int(data.ncon))
    return most


def compiled(model) -> dict:
    """The compiled values the shipped models must keep, as lists and numbers."""
    return {
        "body_mass": model.body_mass.tolist(),
        "body_inertia_matrix": _inertia_matrices(model),
        "body_pos": model.body_pos.tolist(),
        "body_quat": model.body_quat.tolist(),
        "body_ipos": model.body_ipos.tolist(),
        "qpos0": model.qpos0.tolist(),
        "jnt_range": model.jnt_range.tolist(),
        "jnt_limited": model.jnt_limited.tolist(),
        "jnt_stiffness": model.jnt_stiffness.tolist(),
        "dof_damping": model.dof_damping.tolist(),
        "dof_armature": model.dof_armature.tolist(),
        "actuator_gear": model.actuator_gear[:, 0].tolist(),
        "actuator_ctrlrange": model.actuator_ctrlrange.tolist(),
        "actuator_ctrllimited": model.actuator_ctrllimited.tolist(),
        "geom_friction": model.geom_friction.tolist(),
        "geom_size": model.geom_size.tolist(),
        "timestep": float(model.opt.timestep),
        "integrator": int(model.opt.integrator),
        "solver": int(model.opt.solver),
        "iterations": int(model.opt.iterations),
        "density": float(model.opt.density),
        "viscosity": float(model.opt.viscosity),
        "max_contacts": max_contacts(model),
    }


def main(published_dir: str) -> None:
    """Writes the fixture to stdout: MuJoCo's version, then one line per model."""
    lines = [f'"mujoco": {json.dumps(mujoco.__version__)}']
    for shipped, published in PUBLISHED.items():
        model = mujoco.MjModel.from_xml_path(os.path.join(published_dir, published))
        values = json.dumps(compiled(model), separators=(",", ":"))
        lines.append(f"{json.dumps(shipped)}: {values}")
    print("{\n" + ",\n".join(lines) + "\n}")


if __name__ == "__main__":
    main(sys.argv[1])
