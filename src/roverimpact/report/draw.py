"""Drawings of an impact scenario: the model, the obstacle face, the contact point, the normal.

Planar models are drawn in side view (x-z); others in 3-D (matplotlib ``mplot3d``). Bodies
are drawn as a skeleton through the joint origins, wheels as circles in their plane and a
built-in rover's chassis as its box.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .plots import savefig, typeset

__all__ = ["draw_setup"]


def _box_corners(oMf, lx, ly, lz) -> np.ndarray:
    s = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * 0.5
    return (oMf.rotation @ (s * [lx, ly, lz]).T).T + oMf.translation


_BOX_EDGES = [(0, 1), (0, 2), (0, 4), (1, 3), (1, 5), (2, 3), (2, 6), (3, 7), (4, 5), (4, 6),
              (5, 7), (6, 7)]


def draw_setup(setup, path: str | Path | None = None, *, title: str | None = None,
               normal_length: float | None = None):
    """Draw an :class:`~roverimpact.scenario.ImpactSetup` and optionally save it (PNG/SVG).

    Parameters
    ----------
    setup : ImpactSetup
    path : str or Path, optional
        Output file; the figure is returned and not saved if omitted.
    title : str, optional
        Figure title (default: model name, beta/normal, T_c^-).
    normal_length : float, optional
        Length of the drawn normal arrow [m] (default: a quarter of the model's size).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import pinocchio as pin
    from matplotlib.figure import Figure

    mbm = setup.model
    model = mbm.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, setup.q)
    planar = bool(mbm.params.get("planar", False))
    pts = [data.oMi[j].translation for j in range(1, model.njoints)]
    segs = [(data.oMi[model.parents[j]].translation, data.oMi[j].translation)
            for j in range(2, model.njoints)
            if model.parents[j] > 0 and model.inertias[model.parents[j]].mass > 0]
    wheels = []
    for w in mbm.wheels:
        oMf = data.oMf[model.getFrameId(w.frame)]
        a = oMf.rotation @ np.asarray(w.axis, float)
        e1 = np.cross(a, [0.0, 0.0, 1.0])
        e1 = e1 / np.linalg.norm(e1) if np.linalg.norm(e1) > 1e-9 else oMf.rotation[:, 0]
        e2 = np.cross(a, e1)
        th = np.linspace(0, 2 * np.pi, 73)
        circ = oMf.translation + w.radius * (np.outer(np.cos(th), e1) + np.outer(np.sin(th), e2))
        wheels.append((w, oMf.translation, circ))
    box = None
    prm = mbm.params
    if all(k in prm for k in ("chassis_length", "chassis_width", "chassis_height")):
        fid = model.getFrameId("chassis") if model.existFrame("chassis") else None
        if fid is not None:
            box = _box_corners(data.oMf[fid], prm["chassis_length"], prm["chassis_width"],
                               prm["chassis_height"])
    allp = np.array(pts + [c for *_, c in wheels for c in c] + [setup.contact_point]
                    + ([] if box is None else list(box)))
    size = float(np.ptp(allp, axis=0).max()) or 1.0
    L = normal_length or 0.25 * size
    p, n = setup.contact_point, setup.normal
    e = setup.partition()
    if title is None:
        title = (f"{mbm.name}: n = ({n[0]:.2f}, {n[1]:.2f}, {n[2]:.2f}), "
                 f"T_c^- = {float(e.T_c_minus):.4g} J, v_n = {float(e.v_n):.3g} m/s")
    # obstacle face: a square patch (3-D) or a segment (2-D) through p, orthogonal to n
    t1 = np.cross(n, [0.0, 1.0, 0.0])
    if np.linalg.norm(t1) < 1e-9:
        t1 = np.cross(n, [1.0, 0.0, 0.0])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(n, t1)
    fig = Figure(figsize=(8, 5.5))
    if planar:
        ax = fig.add_subplot(111)
        xs = allp[:, 0]
        lo, hi = xs.min() - 0.3 * size, xs.max() + 0.3 * size
        ax.axhline(0.0, color="saddlebrown", lw=1.5)
        ax.fill_between([lo, hi], -0.05 * size, 0.0, color="tan", alpha=0.5)
        face = np.array([p - 0.6 * L * t1, p + 0.6 * L * t1])
        back = face - 0.4 * L * n
        poly = np.array([face[0], face[1], back[1], back[0]])
        ax.fill(poly[:, 0], poly[:, 2], color="grey", alpha=0.6, label="obstacle")
        ax.plot(face[:, 0], face[:, 2], color="k", lw=2)
        if box is not None:
            c = box[[0, 1, 5, 4, 0]]  # y = -w/2 face: corners (-,-,-),(-,-,+),(+,-,+),(+,-,-)
            ax.plot(c[:, 0], c[:, 2], color="tab:blue", lw=2, label="chassis")
        for a_, b_ in segs:
            ax.plot([a_[0], b_[0]], [a_[2], b_[2]], color="tab:green", lw=2)
        for w, c, circ in wheels:
            ax.plot(circ[:, 0], circ[:, 2], color="k", lw=1.5)
            ax.plot(c[0], c[2], "k+", ms=6)
            ax.annotate(w.name, (c[0], c[2] - 0.35 * w.radius), ha="center", fontsize=8)
        ax.plot(p[0], p[2], "ro", ms=6, label="contact point")
        ax.annotate("", xy=(p[0] + L * n[0], p[2] + L * n[2]), xytext=(p[0], p[2]),
                    arrowprops={"arrowstyle": "->", "color": "red", "lw": 2})
        ax.text(p[0] + 1.05 * L * n[0], p[2] + 1.05 * L * n[2], "n", color="red")
        if setup.scenario is not None and setup.scenario.obstacle.beta_deg is not None:
            ax.text(p[0], p[2] - 0.15 * L, f"beta = {setup.scenario.obstacle.beta_deg:g} deg",
                    color="red", fontsize=9, ha="center", va="top")
        ax.set_xlim(lo, hi)
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("z [m]")
        ax.legend(loc="upper left", fontsize=8)
    else:
        ax = fig.add_subplot(111, projection="3d")
        corners = np.array([p + s1 * 0.6 * L * t1 + s2 * 0.6 * L * t2
                            for s1, s2 in ((-1, -1), (1, -1), (1, 1), (-1, 1), (-1, -1))])
        ax.plot(corners[:, 0], corners[:, 1], corners[:, 2], color="k", lw=2, label="obstacle face")
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        ax.add_collection3d(Poly3DCollection([corners[:4]], color="grey", alpha=0.5))
        if box is not None:
            for i, j in _BOX_EDGES:
                ax.plot(*np.array([box[i], box[j]]).T, color="tab:blue", lw=1.5)
        for a_, b_ in segs:
            ax.plot(*np.array([a_, b_]).T, color="tab:green", lw=2)
        ax.scatter(*np.array(pts).T, color="tab:green", s=8)
        for *_, circ in wheels:
            ax.plot(circ[:, 0], circ[:, 1], circ[:, 2], color="k", lw=1.2)
        if mbm.wheels:
            lo, hi = allp.min(axis=0), allp.max(axis=0)
            gx, gy = np.meshgrid([lo[0] - 0.2 * size, hi[0] + 0.2 * size],
                                 [lo[1] - 0.2 * size, hi[1] + 0.2 * size])
            ax.plot_surface(gx, gy, np.zeros_like(gx), color="tan", alpha=0.3)
        ax.scatter(*p, color="red", s=30, label="contact point")
        ax.quiver(*p, *(L * n), color="red", lw=2)
        ax.text(*(p + 1.1 * L * n), "n", color="red")
        ctr = 0.5 * (allp.min(axis=0) + allp.max(axis=0))
        half = 0.6 * size
        ax.set_xlim(ctr[0] - half, ctr[0] + half)
        ax.set_ylim(ctr[1] - half, ctr[1] + half)
        ax.set_zlim(max(ctr[2] - half, -0.05 * size), ctr[2] + half)
        ax.set_box_aspect((1, 1, 1))
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_zlabel("z [m]")
        ax.view_init(elev=20, azim=-60)
        ax.legend(loc="upper left", fontsize=8)
    ax.set_title(typeset(title), fontsize=9)
    fig.tight_layout()
    if path is not None:
        savefig(fig, path, dpi=110)
    return fig
