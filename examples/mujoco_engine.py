"""The same impact in two engines: the own simulator and MuJoCo (docs/simulate.md).

Prints every figure quoted in the section "MuJoCo as a second engine":

1. a 1-DoF slider (4 kg, 0.5 m/s) into a Kelvin-Voigt wall: closed form, own, MuJoCo;
2. the planar rover (rocker, spring 50 N m/rad) and the rocker-bogie, Kelvin-Voigt
   contact (k = 1e6 N/m, c = 2000 N s/m) on the ground and the obstacle, beta = 30, 60,
   90 deg: F_max of both engines (the agreement tests);
3. the default Hunt-Crossley obstacle (k = 1e7, e = 0.5) through MuJoCo's equivalent
   Kelvin-Voigt (an approximation), and the law itself applied in MuJoCo (engine
   ``mujoco_laws``);
3b. the rocker-bogie with the obstacle in front of one wheel (as `roverimpact simulate`
   runs a scenario), Hunt-Crossley obstacle and ground, and a Kelvin-Voigt obstacle on
   the Hunt-Crossley ground;
4. friction mu = 0.3 (an approximation: capped viscous slope in MuJoCo's cone).

    python examples/mujoco_engine.py
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from roverimpact.contact import get_law, predict
from roverimpact.models import rocker_bogie, rover2d
from roverimpact.models.base import MultibodyModel, Wheel
from roverimpact.simulate import SimulationConfig, initial_state, simulate_impact
from roverimpact.simulate.engines import simulate_impact_mujoco, simulate_impact_mujoco_laws

KV = {"name": "kelvin-voigt", "k": 1e6, "c": 2000.0, "e": None, "n": None}


def slider(mass=4.0, radius=0.05):
    model = pin.Model()
    j = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "x")
    model.appendBodyToJoint(j, pin.Inertia(mass, np.zeros(3), 0.01 * np.eye(3)),
                            pin.SE3.Identity())
    model.addFrame(pin.Frame("ball", j, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    return MultibodyModel(model=model, name="slider", wheels=[Wheel("ball", "ball", radius)],
                          params={"q_nominal": [0.0]})


def both(mbm, cfg):
    q0, v0 = initial_state(mbm, cfg)
    return (simulate_impact(mbm, cfg, q0=q0, v0=v0),
            simulate_impact_mujoco(mbm, cfg, q0=q0, v0=v0))


def row(label, r_own, r_mj):
    print(f"  {label:<26} own {r_own.F_max_total:8.1f} N   MuJoCo {r_mj.F_max_total:8.1f} N"
          f"   {r_mj.F_max_total / r_own.F_max_total - 1:+.2%}")


def main():
    print("1. 1-DoF slider, Kelvin-Voigt k = 1e5 N/m, c = 50 N s/m, 4 kg at 0.5 m/s")
    cfg = SimulationConfig(ground=False, speed=0.5, obstacle={
        "name": "kelvin-voigt", "k": 1e5, "c": 50.0, "e": None, "n": None}, t_after=0.05)
    r_own, r_mj = simulate_impact(slider(), cfg), simulate_impact_mujoco(slider(), cfg)
    closed = predict(get_law("kelvin-voigt", k=1e5, c=50.0), 4.0, 0.5).peak_force
    print(f"  closed form {closed:.2f} N, own {r_own.F_max_total:.2f} N, MuJoCo "
          f"{r_mj.F_max_total:.2f} N ({r_mj.F_max_total / closed - 1:+.2%})")

    print("2. Kelvin-Voigt ground and obstacle (exact in both engines)")
    for name, mbm, extra in (("rover2d rocker", rover2d(suspension="rocker"),
                              {"springs": {"rocker": {"k": 50.0, "c": 2.0}}}),
                             ("rocker-bogie", rocker_bogie(), {})):
        for beta in (30.0, 60.0, 90.0):
            cfg = SimulationConfig(speed=0.3, beta_deg=beta, obstacle=KV, ground_contact=KV,
                                   t_after=0.03, **extra)
            row(f"{name}, beta = {beta:.0f}", *both(mbm, cfg))

    print("3. Hunt-Crossley obstacle k = 1e7, e = 0.5 (MuJoCo: equivalent Kelvin-Voigt)")
    for name, mbm in (("rover2d rocker", rover2d(suspension="rocker")),
                      ("rocker-bogie", rocker_bogie())):
        for beta in (30.0, 45.0, 60.0, 90.0):
            cfg = SimulationConfig(speed=0.3, beta_deg=beta, obstacle={"k": 1e7, "e": 0.5},
                                   t_after=0.05)
            r_own, r_mj = both(mbm, cfg)
            row(f"{name}, beta = {beta:.0f}", r_own, r_mj)
            q0, v0 = initial_state(mbm, cfg)
            r_laws = simulate_impact_mujoco_laws(mbm, cfg, q0=q0, v0=v0)
            print(f"  {'':<26} MuJoCo with the law itself {r_laws.F_max_total:8.1f} N   "
                  f"{r_laws.F_max_total / r_own.F_max_total - 1:+.2%}")

    print("3b. rocker-bogie, the obstacle in front of the left front wheel only (a scenario's"
          " obstacle.wheel)")
    rb = rocker_bogie()
    for beta in (30.0, 45.0, 60.0, 90.0):
        cfg = SimulationConfig(speed=0.3, beta_deg=beta, obstacle={"k": 1e7, "e": 0.5},
                               obstacle_wheels=["left_front"], t_after=0.05)
        row(f"rocker-bogie, beta = {beta:.0f}", *both(rb, cfg))
    kv_obstacle = {"name": "kelvin-voigt", "k": 1e6, "c": 500.0, "e": None, "n": None}
    cfg = SimulationConfig(speed=0.3, beta_deg=90.0, obstacle=kv_obstacle,
                           obstacle_wheels=["left_front"], t_after=0.05)
    row("same, KV obstacle, beta = 90", *both(rb, cfg))

    print("4. friction mu = 0.3, Kelvin-Voigt, beta = 45 and 90")
    for name, mbm in (("rover2d rocker", rover2d(suspension="rocker")),
                      ("rocker-bogie", rocker_bogie())):
        for beta in (45.0, 90.0):
            cfg = SimulationConfig(speed=0.3, beta_deg=beta, obstacle=KV, ground_contact=KV,
                                   mu=0.3, t_after=0.02)
            r_own, r_mj = both(mbm, cfg)
            row(f"{name}, beta = {beta:.0f}", r_own, r_mj)
            w = r_own.contact_wheel
            print(f"  {'':<26} peak obstacle friction own "
                  f"{r_own.history[f'obstacle_{w}_ft'].max():6.1f} N   MuJoCo "
                  f"{r_mj.history[f'obstacle_{w}_ft'].max():6.1f} N")


if __name__ == "__main__":
    main()
