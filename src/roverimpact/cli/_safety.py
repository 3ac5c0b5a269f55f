"""``roverimpact safety ...``: ISO/TS 15066 transient-contact limits for robot arms."""

from __future__ import annotations

import math

import numpy as np
import typer

from ._app import _Typer, app, console, new_table, one_format, print_csv, print_json

safety_app = _Typer(help="ISO/TS 15066 transient contact: body regions, speed limits, arms.",
                         no_args_is_help=True)
app.add_typer(safety_app, name="safety")


def _check_mass(value: float | None, option: str, what: str, *, allow_zero: bool) -> None:
    """An option in kg: finite and > 0 (>= 0 with ``allow_zero``), named as typed."""
    from ..exceptions import InputError

    if value is not None and not (math.isfinite(value) and (
            value >= 0 if allow_zero else value > 0)):
        raise InputError(f"{option} ({what}) must be a finite number "
                         f"{'>=' if allow_zero else '>'} 0 kg, got {value:g}")


def _numbers(text: str, option: str, count: int | None = None) -> list[float]:
    """Comma-separated numbers of an option, or one InputError naming it."""
    from ..exceptions import InputError

    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        raise InputError(f"{option} must be comma-separated numbers, got {text!r}") from None
    if count is not None and len(values) != count:
        raise InputError(f"{option} must be {count} comma-separated numbers, got {text!r}")
    return values


def _configuration(robot: str, mbm, q: str | None, deg: bool) -> np.ndarray:
    """``--q`` (``--deg``) of ``safety arm`` / ``safety point``, else the ready pose of a
    known robot, else Pinocchio's neutral configuration."""
    import pinocchio as pin

    from ..exceptions import InputError
    from ..safety.arm import arm_configuration, check_joint_limits, ready_pose

    if q is not None:
        return arm_configuration(mbm, _numbers(q, "--q"), deg=deg)
    if deg:
        raise InputError("--deg applies to the values of --q: give --q too")
    if (pose := ready_pose(robot)) is not None:
        return np.array(pose)
    q0 = pin.neutral(mbm.model)
    check_joint_limits(mbm, q0, "without --q, Pinocchio's neutral configuration (0 for "
                       "each joint)", "; give --q")
    return q0


def _fmt_v(region, m_R) -> str:
    from ..safety import (
        max_transient_speed,
    )

    if region.F_transient is None:
        return "-"
    return f"{max_transient_speed(region, m_R):.3f}"


@safety_app.command("regions")
def regions_cmd(
    robot_mass: float = typer.Option(None, "--robot-mass", help="Total moving mass M [kg]: "
                                     "adds the speed limit with m_R = M/2 + payload."),
    payload: float = typer.Option(0.0, "--payload", help="Payload m_L [kg] (with "
                                  "--robot-mass)."),
    as_json: bool = typer.Option(False, "--json", help="Print the table as JSON (SI: K in "
                                 "N/m; null where a transient contact is not permitted)."),
    as_csv: bool = typer.Option(False, "--csv", help="Print the table as CSV (SI units)."),
) -> None:
    """The standard's body regions (m_H, K, force limits) and optional speed limits."""
    one_format(as_json, as_csv)
    from ..exceptions import InputError
    from ..safety import (
        BODY_REGIONS,
        ISO_TS_15066_SOURCE,
        iso_robot_mass,
        max_transient_speed,
        reduced_mass,
    )

    _check_mass(robot_mass, "--robot-mass", "total moving mass M", allow_zero=False)
    _check_mass(payload, "--payload", "payload m_L", allow_zero=True)
    if payload and robot_mass is None:
        raise InputError("--payload enters the speed limits through m_R = M/2 + payload: "
                         "give --robot-mass (the total moving mass M) too")
    m_R = None if robot_mass is None else float(iso_robot_mass(robot_mass, payload))
    recs = []
    for r in BODY_REGIONS.values():
        rec = {"region": r.name, "m_H": r.m_H, "K": r.K, "F_qs": r.F_qs,
               "F_transient": r.F_transient}
        if m_R is not None:
            rec |= {"m_R": m_R, "mu": float(reduced_mass(r.m_H, m_R)),
                    "v_max": (None if r.F_transient is None
                              else float(max_transient_speed(r, m_R)))}
        recs.append(rec)
    if as_json:
        print_json({"regions": recs, "source": ISO_TS_15066_SOURCE})
        return
    if as_csv:
        print_csv(list(recs[0]), (rec.values() for rec in recs))
        return
    cols = ["region", "m_H [kg]", "K [N/mm]", "F_qs [N]", "F_transient [N]"]
    if m_R is not None:
        cols += [f"mu [kg] (m_R={m_R:g})", "v_max [m/s]"]
    tab = new_table("ISO/TS 15066:2016 body regions (Tables A.2, A.3)", *cols)
    for r, rec in zip(BODY_REGIONS.values(), recs, strict=True):
        row = [r.name, f"{r.m_H:g}", f"{r.K / 1e3:g}", f"{r.F_qs:g}",
               "-" if r.F_transient is None else f"{r.F_transient:g}"]
        if m_R is not None:
            row += [f"{rec['mu']:.3f}", _fmt_v(r, m_R)]
        tab.add_row(*row)
    tab.caption = "-: transient contact not permitted (no F_transient)."
    console.print(tab)
    console.print(f"source: {ISO_TS_15066_SOURCE}", highlight=False)


@safety_app.command("arm")
def arm_cmd(
    robot: str = typer.Argument(..., help="URDF file or erd:<name> (example-robot-data)."),
    q: str = typer.Option(None, "--q", help="Configuration, comma-separated: Pinocchio's "
                          "nq coordinates (a continuous joint takes two: cos, sin), or one "
                          "value per joint (rad / m; continuous joints by angle); default: "
                          "the ready pose for known robots (either spelling), else the "
                          "neutral one."),
    deg: bool = typer.Option(False, "--deg", help="--q gives one value per joint, angles in "
                             "degrees (prismatic joints in m)."),
    payload: float = typer.Option(0.0, "--payload", help="Payload m_L [kg] (ISO formula)."),
    region: str = typer.Option("chest", "--region", help="Body region for the speed limits."),
    points: str = typer.Option("com", "--points", help="'com' or 'origin' of each link."),
    as_json: bool = typer.Option(False, "--json", help="Print the table as JSON (null for an "
                                 "unbounded mass or speed)."),
    as_csv: bool = typer.Option(False, "--csv", help="Print the table as CSV."),
) -> None:
    """Per link: the standard's m_R = M/2 + m_L vs the exact effective mass, and v_max."""
    one_format(as_json, as_csv)
    from ..safety import arm_effective_masses, load_arm

    _check_mass(payload, "--payload", "payload m_L", allow_zero=True)
    mbm = load_arm(robot)
    qv = _configuration(robot, mbm, q, deg)
    df = arm_effective_masses(mbm, qv, payload=payload, points=points, region=region)
    if as_json:
        print_json({"robot": robot, "points": points, "region": region, "payload": payload,
                    "q": qv, "M_total": df.attrs["M_total"],
                    "links": df.to_dict(orient="records")})
        return
    if as_csv:
        print_csv(list(df.columns), df.itertuples(index=False))
        return
    cols = ["link", "m_R ISO [kg]", "m_min [kg]", "m_max [kg]", "m_min/m_R", "v ISO [m/s]",
            "v exact, worst dir. [m/s]", "v exact, best dir. [m/s]"]
    tab = new_table(f"{robot}: effective mass per link ({points}), region {region}", *cols)

    def f(x):
        return "-" if math.isnan(x) else "inf" if math.isinf(x) else f"{x:.3f}"

    for r in df.itertuples():
        tab.add_row(r.link, f(r.m_R_iso), f(r.m_min), f(r.m_max), f(r.ratio_min),
                    f(r.v_iso), f(r.v_exact_worst), f(r.v_exact_best))
    if df["v_iso"].isna().all():
        tab.caption = f"-: transient contact not permitted for {region} (no F_transient)."
    console.print(tab)
    console.print(f"M (moving parts) = {df.attrs['M_total']:.3f} kg, payload {payload:g} kg, "
                  f"q = {np.round(qv, 4).tolist()}", highlight=False)


@safety_app.command("point")
def point_cmd(
    robot: str = typer.Argument(..., help="URDF file or erd:<name> (example-robot-data)."),
    frame: str = typer.Option(..., "--frame", help="Frame the contact point is fixed to: a "
                              "link or a tool frame (panda_hand_tcp, tool0, ...)."),
    direction: list[str] = typer.Option(..., "--direction", help="Contact direction "
                                        "x,y,z in world axes (normalised); repeat the "
                                        "option for several."),
    point: str = typer.Option(None, "--point", help="Contact point x,y,z [m] in the "
                              "frame's coordinates; default the frame origin."),
    q: str = typer.Option(None, "--q", help="Configuration, as in `safety arm --q`; "
                          "default: the ready pose for known robots, else the neutral one."),
    deg: bool = typer.Option(False, "--deg", help="--q gives one value per joint, angles in "
                             "degrees (prismatic joints in m)."),
    payload: float = typer.Option(0.0, "--payload", help="Payload m_L [kg]: in the ISO "
                                  "m_R = M/2 + m_L, and a point mass in the exact model."),
    payload_frame: str = typer.Option(None, "--payload-frame", help="Frame the payload is "
                                      "fixed to; default --frame."),
    payload_point: str = typer.Option(None, "--payload-point", help="Payload's centre of "
                                      "mass x,y,z [m] in its frame; default --point without "
                                      "--payload-frame, else that frame's origin."),
    region: str = typer.Option("chest", "--region", help="Body region for the speed limits."),
    as_json: bool = typer.Option(False, "--json", help="Print the table as JSON (null for an "
                                 "unbounded mass or a speed that is not permitted)."),
    as_csv: bool = typer.Option(False, "--csv", help="Print the table as CSV."),
) -> None:
    """Exact effective mass of one point of an arm along directions, and v_max (vs ISO)."""
    one_format(as_json, as_csv)
    from ..safety import body_region, load_arm, point_speed_limits

    _check_mass(payload, "--payload", "payload m_L", allow_zero=True)
    reg = body_region(region)
    U = np.array([_numbers(d, "--direction", 3) for d in direction])
    p = None if point is None else _numbers(point, "--point", 3)
    mbm = load_arm(robot)
    qv = _configuration(robot, mbm, q, deg)
    p_L = None if payload_point is None else _numbers(payload_point, "--payload-point", 3)
    df = point_speed_limits(mbm, qv, frame, U, point=p, payload=payload,
                            payload_frame=payload_frame, payload_point=p_L, region=reg)
    M_total, ok = df.attrs["M_total"], reg.F_transient is not None
    m_iso = float(df["m_R_iso"].iloc[0])
    v_iso = float(df["v_iso"].iloc[0]) if ok else None
    recs = [{"direction": [r.ux, r.uy, r.uz], "m_u": r.m_u, "v_max": r.v_max,
             "m_R_iso": m_iso, "v_iso": v_iso} for r in df.itertuples()]
    if as_json:
        print_json({"robot": robot, "frame": frame, "point": p, "region": reg.name,
                    "payload": payload, "payload_frame": payload_frame or frame,
                    "payload_point": p_L, "q": qv, "M_total": M_total, "directions": recs})
        return
    if as_csv:
        print_csv(["ux", "uy", "uz", "m_u", "v_max", "m_R_iso", "v_iso"],
                  ([*r["direction"], r["m_u"], r["v_max"], m_iso, v_iso] for r in recs))
        return

    def f(x):
        return "-" if x is None or math.isnan(x) else "inf" if math.isinf(x) else f"{x:.3f}"

    where = frame if p is None else f"{frame} + {p}"
    tab = new_table(f"{robot}: {where}, region {reg.name}", "direction u (world)",
                    "m_u [kg]", "v_max [m/s]")
    for r in recs:
        tab.add_row(", ".join(f"{x:.3f}" for x in r["direction"]), f(r["m_u"]),
                    f(r["v_max"]))
    tab.caption = ("inf: the point cannot move along u (v_max for mu = m_H). "
                   + ("" if ok else f"-: transient contact not permitted for {reg.name}."))
    console.print(tab)
    if payload:
        console.print(f"payload {payload:g} kg at {payload_frame or frame}"
                      f"{'' if p_L is None else f' + {p_L}'} in the exact model",
                      highlight=False)
    console.print(f"ISO/TS 15066: m_R = M/2 + m_L = {M_total:.3f}/2 + {payload:g} = "
                  f"{m_iso:.3f} kg, v_max = {f(v_iso)} m/s; q = "
                  f"{np.round(qv, 4).tolist()}", highlight=False)
