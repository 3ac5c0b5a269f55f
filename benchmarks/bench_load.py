"""Speed of loading robot files, with and without the MuJoCo cross-check of M(q).

The robot is generated here: a 30-body six-legged wheeled rover written as URDF users
write it (chassis + 6 legs of hip, thigh, shank and a continuous wheel joint + a 3-link
arm with two fingers; inertial frames with rpy, products of inertia, mesh geometry that
is not on disk, a fixed sensor link, one mimic joint). Figures: ``load_robot`` with the
check (Pinocchio's parser + MuJoCo's URDF import and compile + one mj_fullM + one CRBA)
and without it, fixed and floating base; the same robot as MJCF (MuJoCo's own export of it) through
MuJoCo's compiler and the body-by-body conversion. Best of 7 repeats of 5 loads.
Target (issue 14): a 30-body URDF with the check under 1 s.
Run: python benchmarks/bench_load.py
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
from machine import reference

from roverimpact.models import load_robot


def _inertial(rng, mass, size):
    a, b, c = size
    ixx, iyy, izz = (mass * (b * b + c * c) / 12, mass * (a * a + c * c) / 12,
                     mass * (a * a + b * b) / 12)
    rpy = " ".join(f"{x:.4f}" for x in rng.uniform(-0.3, 0.3, 3))
    xyz = " ".join(f"{x:.4f}" for x in rng.uniform(-0.02, 0.02, 3))
    return (f'<inertial><origin xyz="{xyz}" rpy="{rpy}"/><mass value="{mass}"/>'
            f'<inertia ixx="{ixx:.6g}" iyy="{iyy:.6g}" izz="{izz:.6g}" ixy="{0.01 * ixx:.6g}" '
            f'ixz="0" iyz="0"/></inertial>')


def _link(rng, name, mass, size):
    box = " ".join(str(s) for s in size)
    return (f'  <link name="{name}">{_inertial(rng, mass, size)}\n'
            f'    <visual><geometry><mesh filename="package://rover/meshes/{name}.dae"/>'
            f'</geometry></visual>\n'
            f'    <collision><geometry><box size="{box}"/></geometry></collision></link>\n')


def _joint(name, kind, parent, child, xyz, axis, extra=""):
    lim = ('<limit lower="-1.5" upper="1.5" effort="100" velocity="5"/>'
           if kind == "revolute" else "")
    return (f'  <joint name="{name}" type="{kind}"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{xyz}" rpy="0 0 0"/><axis xyz="{axis}"/>'
            f'{lim}{extra}</joint>\n')


def rover_urdf() -> str:
    """URDF text of the 30-body rover (30 links with mass, 29 moving joints)."""
    rng = np.random.default_rng(0)
    out = ['<?xml version="1.0"?>\n<robot name="hexa_rover">\n']
    out.append(_link(rng, "chassis", 40.0, (1.0, 0.6, 0.25)))
    out.append('  <link name="lidar"/>\n')
    out.append(_joint("lidar_mount", "fixed", "chassis", "lidar", "0.4 0 0.2", "1 0 0"))
    for i, (x, y) in enumerate([(0.4, 0.35), (0.4, -0.35), (0.0, 0.35), (0.0, -0.35),
                                (-0.4, 0.35), (-0.4, -0.35)]):
        leg = f"leg{i}"
        out.append(_link(rng, f"{leg}_hip", 1.2, (0.1, 0.1, 0.1)))
        out.append(_link(rng, f"{leg}_thigh", 1.5, (0.3, 0.05, 0.05)))
        out.append(_link(rng, f"{leg}_shank", 1.0, (0.3, 0.04, 0.04)))
        out.append(_link(rng, f"{leg}_wheel", 2.0, (0.25, 0.1, 0.25)))
        out.append(_joint(f"{leg}_hip_joint", "revolute", "chassis", f"{leg}_hip",
                          f"{x} {y} -0.1", "1 0 0"))
        out.append(_joint(f"{leg}_thigh_joint", "revolute", f"{leg}_hip", f"{leg}_thigh",
                          "0 0 -0.05", "0 1 0"))
        out.append(_joint(f"{leg}_shank_joint", "revolute", f"{leg}_thigh", f"{leg}_shank",
                          "0.3 0 0", "0 1 0"))
        out.append(_joint(f"{leg}_wheel_joint", "continuous", f"{leg}_shank", f"{leg}_wheel",
                          "0.3 0 0", "0 1 0"))
    parent = "chassis"
    for k in range(3):
        out.append(_link(rng, f"arm{k}", 1.0 - 0.15 * k, (0.25, 0.05, 0.05)))
        out.append(_joint(f"arm_joint{k}", "revolute", parent, f"arm{k}",
                          "0.45 0 0.15" if k == 0 else "0.25 0 0", "0 0 1" if k % 2 == 0
                          else "0 1 0"))
        parent = f"arm{k}"
    out.append(_link(rng, "finger_a", 0.1, (0.06, 0.02, 0.02)))
    out.append(_joint("finger_a_joint", "prismatic", parent, "finger_a", "0.25 0.02 0",
                      "0 1 0", '<limit lower="0" upper="0.04" effort="10" velocity="0.1"/>'))
    out.append(_link(rng, "finger_b", 0.1, (0.06, 0.02, 0.02)))
    out.append(_joint("finger_b_joint", "prismatic", parent, "finger_b", "0.25 -0.02 0",
                      "0 1 0", '<limit lower="-0.04" upper="0" effort="10" velocity="0.1"/>'
                      '<mimic joint="finger_a_joint" multiplier="-1"/>'))
    out.append("</robot>\n")
    return "".join(out)


def best_of(fn, repeats=7, n=5) -> float:
    fn()
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, (time.perf_counter() - t0) / n)
    return best


def main():
    print(reference())  # how fast this machine is right now (machine.py)
    import mujoco

    tmp = Path(tempfile.mkdtemp())
    urdf = tmp / "hexa_rover.urdf"
    urdf.write_text(rover_urdf())
    mbm = load_robot(urdf)
    nbody = mbm.model.njoints  # the fixed chassis + one link per moving joint
    print(f"robot: {urdf.name}, {nbody} bodies with mass, nq = {mbm.model.nq}, "
          f"nv = {mbm.model.nv}, loop rows {mbm.loop_names}, MuJoCo check: "
          f"{mbm.params['mujoco_check']}")
    # the same robot as MJCF: MuJoCo's own export of its URDF import
    spec = mujoco.MjSpec.from_file(str(urdf))
    spec.compiler.discardvisual = True
    for b in spec.bodies:
        for g in list(b.geoms):
            spec.delete(g)
    mjcf = tmp / "hexa_rover.xml"
    mjcf.write_text(spec.to_xml())
    rows = []
    for floating in (False, True):
        t_on = best_of(lambda f=floating: load_robot(urdf, floating_base=f))
        t_off = best_of(lambda f=floating: load_robot(urdf, floating_base=f,
                                                      mujoco_check=False))
        base = "floating" if floating else "fixed"
        rows.append((f"URDF, {base} base, with MuJoCo check", t_on, t_on / t_off))
        rows.append((f"URDF, {base} base, no check", t_off, 1.0))
    t_mj = best_of(lambda: load_robot(mjcf))
    t_mj_off = best_of(lambda: load_robot(mjcf, mujoco_check=False))
    rows.append(("MJCF (MuJoCo compile + conversion), with check", t_mj, t_mj / t_mj_off))
    rows.append(("MJCF, no check", t_mj_off, 1.0))
    print(f"{'load':52s} {'time':>10s} {'vs no check':>12s}")
    for name, t, r in rows:
        print(f"{name:52s} {t * 1e3:8.2f} ms {r:11.2f}x")
    worst = max(t for name, t, _ in rows if name.startswith("URDF") and "with" in name)
    print(f"target: 30-body URDF with the check under 1 s -> {worst * 1e3:.1f} ms "
          f"({'met' if worst < 1.0 else 'MISSED'})")


if __name__ == "__main__":
    main()
