r"""Load-time cross-check of a Pinocchio model against MuJoCo's compiler and CRBA.

Both engines compute the joint-space mass matrix of the same file, Pinocchio by its CRBA
on the model roverimpact built, MuJoCo by ``mj_fullM`` on its own compiled model. In
MuJoCo's velocity coordinates (``v = T qvel``, :func:`~roverimpact.models.mjcf.
velocity_map`) they must agree:

.. math::

    M_{mj}(q) = T^T M_{pin}(q)\, T,
    \qquad
    \frac{|M_{mj,ij} - (T^T M_{pin} T)_{ij}|}{\sqrt{M_{mj,ii} M_{mj,jj}}} \le r_{tol}

One configuration is evaluated (MuJoCo's ``qpos0`` moved by a fixed pseudo-random step,
so that no symmetry of ``qpos0`` hides a wrong inertia): one ``mj_forward`` plus one
``mj_fullM`` and one ``pin.crba``. A mismatch raises :class:`~roverimpact.exceptions.
ModelError` naming the rows (joints) that differ and the body where the difference
starts (the deepest differing joints: a wrong inertia also changes the rows of every
joint above it).

For a URDF, :func:`check_urdf` gives MuJoCo a copy of the file with URDF's meaning:
``<visual>``, ``<collision>`` and any ``<mujoco>`` element removed (geometry carries no
mass in URDF; no mesh is loaded), ``inertiafromgeom="false"`` (a link without
``<inertial>`` has no mass), ``fusestatic="true"``, no ``balanceinertia``, and a free
joint ``root_joint`` on the root link for a floating base. MuJoCo refuses moving bodies
without mass or inertia; every moving body of both copies therefore gets the same tiny
extra inertia (mass ``1e-9`` of the total, inertia ``1e-9`` of the largest), which leaves
the comparison exact. MuJoCo also refuses an inertia that violates the triangle inequality
(``A + B < C``; CAD exports have them): such a link gets the same isotropic addition
``delta * 1`` in both copies, just enough for MuJoCo (:func:`_restore_triangle`). If
MuJoCo cannot compile the file (a floating joint below the root ...), or a joint has no
MuJoCo counterpart (planar joints ...), the check is skipped: it never makes a file that
Pinocchio can load unloadable.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..exceptions import ModelError
from .mjcf import mujoco_warnings, state_to_pinocchio, velocity_map

__all__ = ["check_mass_matrix", "check_urdf", "full_mass_matrix", "probe_qpos"]

_SEED = 20240614


def full_mass_matrix(mujoco, m, d) -> np.ndarray:
    """Dense ``M`` (nv, nv) of MuJoCo data ``d`` after ``mj_forward`` (``mj_fullM``, the
    MuJoCo 3.x and 4.x signatures)."""
    M = np.zeros((m.nv, m.nv))
    try:
        mujoco.mj_fullM(m, d, M)  # MuJoCo >= 3.3: mj_fullM(m, d, dst)
    except TypeError:  # pragma: no cover - older MuJoCo: mj_fullM(m, dst, qM)
        mujoco.mj_fullM(m, M, d.qM)
    return M


def probe_qpos(m, seed: int = _SEED) -> np.ndarray:
    """A generic configuration: ``qpos0`` plus a fixed pseudo-random step per joint
    (hinge +-0.6 rad, slide +-0.1 m, ball and free: random orientation)."""
    rng = np.random.default_rng(seed)
    qpos = np.array(m.qpos0, dtype=float)
    for k in range(m.njnt):
        a, t = int(m.jnt_qposadr[k]), int(m.jnt_type[k])
        if t == 3:
            qpos[a] += rng.uniform(-0.6, 0.6)
        elif t == 2:
            qpos[a] += rng.uniform(-0.1, 0.1)
        elif t == 1:
            quat = rng.standard_normal(4)
            qpos[a:a + 4] = quat / np.linalg.norm(quat)
        else:
            qpos[a:a + 3] += rng.uniform(-0.1, 0.1, 3)
            quat = rng.standard_normal(4)
            qpos[a + 3:a + 7] = quat / np.linalg.norm(quat)
    return qpos


def _mismatch(model, mp, m, M_mj, M_pin, rtol, body_names):
    """``None``, or the message part naming the differing rows and where they start."""
    d = np.sqrt(np.maximum(np.abs(np.diag(M_mj)), np.finfo(float).tiny))
    D = np.abs(M_pin - M_mj) / np.outer(d, d)
    if not np.all(np.isfinite(D)):
        D = np.where(np.isfinite(D), D, np.inf)
    bad_dof = np.max(D, axis=1) > rtol
    if not bad_dof.any():
        return None
    dof_joint = {}
    for name, _kind, _qa, da in mp["joints"]:
        for k in range(model.joints[model.getJointId(name)].nv):
            dof_joint[da + k] = name
    bad = []
    for i in np.flatnonzero(bad_dof):
        nm = dof_joint.get(int(i), f"dof {int(i)}")
        if nm not in bad:
            bad.append(nm)
    ids = {nm: model.getJointId(nm) for nm in bad if model.existJointName(nm)}

    def below(a, b):  # is joint a strictly below joint b?
        j = model.parents[a]
        while j > 0:
            if j == b:
                return True
            j = model.parents[j]
        return False

    start = [nm for nm, j in ids.items() if not any(below(k, j) for k in ids.values())]
    where = ", ".join(f"body {body_names.get(nm, '?')!r} (joint {nm!r})" for nm in start)
    worst = float(np.max(D))
    return (f"rows of joints {bad} differ by up to {worst:.2g} (relative to "
            f"sqrt(M_ii M_jj), tolerance {rtol:g}); the difference starts at {where}")


def _joint_bodies(mujoco, m, mp) -> dict[str, str]:
    out = {}
    for name, _kind, _qa, _da in mp["joints"]:
        k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
        if k >= 0:
            b = int(m.jnt_bodyid[k])
            out[name] = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
    return out


def compare_mass_matrices(model, mp: dict, m, qpos=None, rtol: float = 1e-8):
    """``(M_mujoco, T^T M_pinocchio T, message or None)`` at ``qpos`` (default
    :func:`probe_qpos`)."""
    import mujoco

    qpos = probe_qpos(m) if qpos is None else np.asarray(qpos, dtype=float)
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_forward(m, d)
    M_mj = full_mass_matrix(mujoco, m, d)
    q, _ = state_to_pinocchio(model, mp, qpos, None)
    M = pin.crba(model, model.createData(), q)
    M = np.triu(M) + np.triu(M, 1).T
    T = velocity_map(model, mp, q)
    M_pin = T.T @ M @ T
    msg = _mismatch(model, mp, m, M_mj, M_pin, rtol, _joint_bodies(mujoco, m, mp))
    return M_mj, M_pin, msg


def check_mass_matrix(mbm, m, *, source: str, rtol: float = 1e-8, model=None) -> None:
    """Refuse ``mbm`` if its ``M(q)`` differs from MuJoCo's ``mj_fullM`` for ``m``.

    Parameters
    ----------
    mbm : MultibodyModel
        With ``params["mujoco"]`` (joint map).
    m : mujoco.MjModel
        MuJoCo's compiled model of the same file.
    source : str
        File name for the message.
    rtol : float
        Largest accepted ``|dM_ij| / sqrt(M_ii M_jj)``.
    model : pinocchio.Model, optional
        Compare this model instead of ``mbm.model`` (the URDF check's patched copy).

    Raises
    ------
    ModelError
        On a mismatch, naming the joints whose rows differ and the bodies where the
        difference starts.
    """
    mp = mbm.params["mujoco"]
    _, _, msg = compare_mass_matrices(mbm.model if model is None else model, mp, m, rtol=rtol)
    if msg is not None:
        raise ModelError(f"{source}: the mass matrix M(q) roverimpact built (Pinocchio) "
                         f"disagrees with MuJoCo's compiler (mj_fullM) at a reference "
                         f"configuration: {msg}. Check the inertias of these bodies.")


# ----------------------------------------------------------------------------- URDF


def _urdf_for_mujoco(root: ET.Element) -> str:
    root = ET.fromstring(ET.tostring(root))  # copy
    for el in list(root):
        if el.tag == "mujoco" or (isinstance(el.tag, str) and el.tag.startswith("roverimpact_")):
            root.remove(el)
    for link in root.iter("link"):
        for el in list(link):
            if el.tag in ("visual", "collision"):
                link.remove(el)
    return ET.tostring(root, encoding="unicode")


def _root_link(root: ET.Element) -> str | None:
    links = [el.get("name") for el in root.iter("link")]
    children = {c.get("link") for j in root.iter("joint") for c in j.iter("child")}
    roots = [nm for nm in links if nm not in children]
    return roots[0] if len(roots) == 1 else None


_KIND_OK = {  # MuJoCo joint type -> accepted Pinocchio (nq, nv)
    "hinge": {(1, 1), (2, 1)}, "slide": {(1, 1)}, "ball": {(4, 3)}, "free": {(7, 6)},
}


def _compile_urdf(mujoco, root: ET.Element, floating: bool):
    """MuJoCo's model of the URDF with URDF's meaning and the tiny inertia patch:
    ``(m, {link: ipos}, dm, dI)``, or ``(None, ...)`` if the root cannot float."""
    spec = mujoco.MjSpec.from_string(_urdf_for_mujoco(root))
    c = spec.compiler
    c.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    c.fusestatic = True
    c.discardvisual = True
    c.balanceinertia = False
    c.boundmass = 0.0
    c.boundinertia = 0.0
    c.settotalmass = -1.0
    if floating:
        name = _root_link(root)
        body = spec.body(name) if name else None
        if body is None or name == "world":
            return None, None, 0.0, 0.0, {}
        body.add_freejoint(name="root_joint")
    for el in root.iter("roverimpact_armature"):  # export_urdf's rotor inertia
        joint = spec.joint(el.get("joint"))
        arm = [float(x) for x in el.get("value").split()]
        if joint is not None:
            if len(set(arm)) != 1:
                raise ValueError(f"the armature of joint {el.get('joint')!r} differs between "
                                 "its DoFs; MuJoCo has one per joint")
            joint.armature = arm[0]
    triangle = _restore_triangle(spec)
    moving = [b for b in spec.bodies if any(True for _ in b.joints)]
    total = sum(float(b.mass) for b in spec.bodies)
    imax = 0.0
    for b in spec.bodies:
        fi = np.asarray(b.fullinertia, dtype=float)
        if np.isfinite(fi[0]):
            imax = max(imax, float(np.max(np.abs(fi))))
        imax = max(imax, float(np.max(np.abs(np.asarray(b.inertia, dtype=float)))))
    dm, dI = max(1e-9 * total, 1e-12), max(1e-9 * imax, 1e-12)
    patch = {}
    for b in moving:
        ipos = np.array(b.ipos, dtype=float)  # a copy: compiling rewrites the spec
        ipos = ipos if np.all(np.isfinite(ipos)) else np.zeros(3)
        if b.explicitinertial:
            fi = np.asarray(b.fullinertia, dtype=float)
            if np.isfinite(fi[0]):
                fi[:3] += dI
                b.fullinertia = fi
            else:
                b.inertia = np.asarray(b.inertia, dtype=float) + dI
            b.mass = float(b.mass) + dm
        else:
            b.explicitinertial = True
            b.mass, b.ipos, b.iquat = dm, np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])
            b.inertia = np.full(3, dI)
            ipos = np.zeros(3)
        patch[b.name] = ipos
    return spec.compile(), patch, dm, dI, triangle


def _restore_triangle(spec) -> dict[str, float]:
    """Add ``delta`` to the three principal moments of every link whose explicit inertia
    violates the triangle inequality (``A + B < C``: MuJoCo refuses it; CAD exports have
    it, the allegro hand's finger links by 20 %), just enough to satisfy it; ``{link:
    delta}``. ``delta * 1`` (isotropic) is the same tensor change in any frame, so
    :func:`check_urdf` adds it to Pinocchio's copy too and the comparison stays exact."""
    out = {}
    for b in spec.bodies:
        if not b.explicitinertial:
            continue
        fi = np.asarray(b.fullinertia, dtype=float)
        if np.isfinite(fi[0]):
            xx, yy, zz, xy, xz, yz = fi
            ev = np.linalg.eigvalsh([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        else:
            ev = np.sort(np.asarray(b.inertia, dtype=float))
        gap = float(ev[2] - ev[0] - ev[1])
        if not gap > 0.0:
            continue
        delta = gap * (1.0 + 1e-6) + 1e-12
        if np.isfinite(fi[0]):
            fi[:3] += delta
            b.fullinertia = fi
        else:
            b.inertia = np.asarray(b.inertia, dtype=float) + delta
        out[b.name] = delta
    return out


def check_urdf(path: str | Path, root: ET.Element, model, *, floating: bool,
               rtol: float = 1e-8) -> tuple[dict | None, str | None]:
    """Compile a URDF with MuJoCo (URDF's meaning, see the module docstring) and compare
    ``M(q)`` with Pinocchio's ``model``.

    Returns
    -------
    mp : dict or None
        The MuJoCo joint map (``params["mujoco"]``), ``None`` if the check was skipped.
    skipped : str or None
        Why the check was skipped (mujoco missing, MuJoCo cannot compile the file, a
        joint has no MuJoCo counterpart), else ``None``.

    Raises
    ------
    ModelError
        If both engines compile the file and their ``M(q)`` differ.
    """
    try:
        import mujoco
    except ImportError:  # pragma: no cover - mujoco is a base dependency
        return None, "mujoco is not installed"
    try:
        with mujoco_warnings(mujoco):  # about MuJoCo's import of a copy: not shown
            m, patch, dm, dI, triangle = _compile_urdf(mujoco, root, floating)
        if m is None:
            return None, "the root link has no MuJoCo body to float"
    except Exception as exc:  # MuJoCo's URDF importer or compiler refused the file
        msg = " ".join(str(exc).split()) or type(exc).__name__
        return None, f"MuJoCo cannot compile it ({msg})"
    # joint map by name
    obj = mujoco.mjtObj
    mp = {"nq": int(m.nq), "nv": int(m.nv), "joints": [],
          "qpos0": [float(x) for x in m.qpos0]}
    if m.nv != model.nv or m.njnt != model.njoints - 1:
        return None, (f"MuJoCo's model has {m.njnt} joints / {m.nv} DoF, Pinocchio's "
                      f"{model.njoints - 1} / {model.nv}")
    kinds = {0: "free", 1: "ball", 2: "slide", 3: "hinge"}
    for j in range(1, model.njoints):
        name = model.names[j]
        k = mujoco.mj_name2id(m, obj.mjOBJ_JOINT, name)
        if k < 0:
            return None, f"joint {name!r} has no MuJoCo counterpart"
        kind = kinds[int(m.jnt_type[k])]
        jm = model.joints[j]
        if (jm.nq, jm.nv) not in _KIND_OK[kind]:
            return None, f"joint {name!r} ({jm.shortname()}) is a MuJoCo {kind} joint"
        mp["joints"].append([name, kind, int(m.jnt_qposadr[k]), int(m.jnt_dofadr[k])])
    # the same tiny inertia on Pinocchio's copy: each moving link's frame is its joint frame
    pm = pin.Model(model)
    for bname, ipos in patch.items():
        b = mujoco.mj_name2id(m, obj.mjOBJ_BODY, bname)
        if b < 0 or m.body_jntnum[b] < 1:
            return None, f"link {bname!r} is not a moving body in MuJoCo's model"
        jname = mujoco.mj_id2name(m, obj.mjOBJ_JOINT, int(m.body_jntadr[b]))
        if not model.existJointName(jname):
            return None, f"joint {jname!r} has no Pinocchio counterpart"
        jid = model.getJointId(jname)
        pm.inertias[jid] = pm.inertias[jid] + pin.Inertia(dm, ipos, dI * np.eye(3))
    for link, delta in triangle.items():  # the same isotropic delta, wherever the link is
        if not model.existFrame(link):
            return None, f"link {link!r} has no Pinocchio frame"
        jid = model.frames[model.getFrameId(link)].parentJoint
        pm.inertias[jid] = pm.inertias[jid] + pin.Inertia(0.0, np.zeros(3),
                                                            delta * np.eye(3))
    _, _, msg = compare_mass_matrices(pm, mp, m, rtol=rtol)
    if msg is not None:
        raise ModelError(f"{path}: Pinocchio's URDF model disagrees with MuJoCo's import of "
                         f"the same file (M(q) at a reference configuration): {msg}. Check "
                         "the <inertial> of these links.")
    return mp, None
