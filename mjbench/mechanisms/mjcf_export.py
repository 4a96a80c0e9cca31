"""A machine's MuJoCo model as a stand-alone MJCF file that plain MuJoCo loads assembled.

mjbench builds its MuJoCo models from the scenario (``Mechanism.build_spec``) and starts a run in
the assembled pose the mechanism computes (``initial_qpos``/``initial_qvel``).  A file written for
people — the committed ``assets/mjcf/*.xml`` (``scripts/export_mjcf.py``), a mechanism's
``export_mjcf`` — must stand alone: opened in MuJoCo's viewer or loaded with ``mujoco.MjModel``
it must not start off its loop closure.  :func:`standalone_xml` therefore writes

* every single-joint body's frame turned (or shifted) by its joint's initial value, with the joint's
  ``ref`` at that value: ``qpos0`` — what ``MjData`` starts from — *is* the initial pose, and a
  joint's coordinate means what it meant before (the same map from ``qpos`` to positions);
* the keyframe ``initial``: the scenario's initial ``qpos`` and ``qvel``, full precision;

both projected on the loop-closure constraints of the model *as written* (MuJoCo writes lengths with
six significant digits, so the file's links differ from the scenario's by up to 5e-7 of their
length: the pose is assembled for the file's model, to ≤ 1e-12 m).  The result is checked by loading
it back (:func:`closure_of`); a file that would not be assembled is an error, never written.
"""
from __future__ import annotations

import re

import numpy as np

import mujoco

from ..errors import GeometryError

#: largest loop-closure residual [m] accepted at qpos0 and at the keyframe of a written file
CLOSURE_TOL = 1e-10


def _num(x) -> str:
    return repr(float(x)) if float(x) != 0.0 else "0"


def _vec(v) -> str:
    return " ".join(_num(x) for x in v)


def closure_of(model, qpos) -> float:
    """Largest equality-constraint residual of ``model`` at ``qpos`` [m] (0 without constraints)."""
    d = mujoco.MjData(model)
    d.qpos[:] = qpos
    mujoco.mj_fwdPosition(model, d)
    return float(np.max(np.abs(d.efc_pos[:d.ne]))) if d.ne else 0.0


def _eq(model, data, qpos):
    data.qpos[:] = qpos
    mujoco.mj_fwdPosition(model, data)
    ne, nv = data.ne, model.nv
    if ne == 0:
        return np.zeros(0), np.zeros((0, nv))
    efc = np.asarray(data.efc_J)
    if mujoco.mj_isSparse(model):
        J = np.zeros((ne, nv))
        for i in range(ne):
            a, n = int(data.efc_J_rowadr[i]), int(data.efc_J_rownnz[i])
            J[i, data.efc_J_colind[a:a + n]] = efc[a:a + n]
    else:
        J = efc.reshape(-1)[:ne * nv].reshape(ne, nv).copy()
    return data.efc_pos[:ne].copy(), J


def assemble(model, qpos, qvel, input_dof, tol: float = 1e-13, maxit: int = 50):
    """``qpos`` and ``qvel`` projected on ``model``'s equality constraints with the input dof(s) held
    (an index or one per axis): Gauss-Newton on the residual, then the velocities in the constraints'
    null space → (qpos, qvel)."""
    d = mujoco.MjData(model)
    x = np.array(qpos, float)
    held = np.atleast_1d(np.asarray(input_dof, dtype=int))
    others = np.array([i for i in range(model.nv) if i not in held], dtype=int)
    r, J = _eq(model, d, x)
    for _ in range(maxit):
        if not len(r) or np.max(np.abs(r)) < tol:
            break
        dv = np.zeros(model.nv)
        dv[others] = np.linalg.lstsq(J[:, others], -r, rcond=None)[0]
        mujoco.mj_integratePos(model, x, dv, 1.0)
        r, J = _eq(model, d, x)
    v = np.array(qvel, float)
    if len(r):
        v[others] = np.linalg.lstsq(J[:, others], -J[:, held] @ v[held], rcond=None)[0]
    return x, v


def _quat_mul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def _rot(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _set_attrs(xml: str, tag: str, name: str, attrs: dict, drop=()) -> str:
    """The opening ``<tag name="NAME" ...>`` of ``xml`` with ``attrs`` set (full precision) and the
    attributes ``drop`` removed."""
    pat = re.compile(rf'<{tag} name="{re.escape(name)}"([^>]*?)(/?)>')
    m = pat.search(xml)
    if m is None:
        raise GeometryError(f"MJCF export: no <{tag} name={name!r}> in the written model")
    body = m.group(1)
    for k in list(attrs) + list(drop):
        body = re.sub(rf'\s{k}="[^"]*"', "", body)
    body += "".join(f' {k}="{v}"' for k, v in attrs.items())
    return xml[:m.start()] + f'<{tag} name="{name}"{body}{m.group(2)}>' + xml[m.end():]


def _reference_pose(xml: str, model, qpos) -> str:
    """``xml`` with every single-joint body's frame moved to the joint's value in ``qpos`` and the
    joint's ``ref`` set to it (module doc)."""
    hinge, slide = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
    for b in range(1, model.nbody):
        if model.body_jntnum[b] != 1:
            continue
        j = int(model.body_jntadr[b])
        typ = int(model.jnt_type[j])
        bname, jname = model.body(b).name, model.joint(j).name
        if typ not in (hinge, slide) or not bname or not jname:
            continue
        v = float(qpos[model.jnt_qposadr[j]])
        if v == 0.0:
            continue
        pos, quat = np.array(model.body_pos[b], float), np.array(model.body_quat[b], float)
        axis, anchor = np.array(model.jnt_axis[j], float), np.array(model.jnt_pos[j], float)
        if typ == hinge:  # frame' = frame · (rotation by v about the joint's axis through its anchor)
            rq = np.concatenate([[np.cos(v / 2)], np.sin(v / 2) * axis])
            pos = pos + _rot(quat) @ (anchor - _rot(rq) @ anchor)
            quat = _quat_mul(quat, rq)
            quat /= np.linalg.norm(quat)
        else:  # frame' = frame · (translation by v along the joint's axis)
            pos = pos + _rot(quat) @ (v * axis)
        xml = _set_attrs(xml, "body", bname, {"pos": _vec(pos), "quat": _vec(quat)},
                         drop=("axisangle", "euler", "xyaxes", "zaxis"))
        xml = _set_attrs(xml, "joint", jname, {"ref": _num(v)})
    return xml


def standalone_xml(spec, model, qpos, qvel, input_joint, header: str = "") -> str:
    """The MJCF text of ``spec`` (compiled as ``model``) that loads assembled in plain MuJoCo:
    ``qpos0`` and the keyframe ``initial`` at ``qpos``/``qvel`` (module doc); ``input_joint``: the
    driven joint's name, or the names of every driven joint (several axes)."""

    for k in list(spec.keys):  # one keyframe, ours, at full precision
        spec.delete(k)
    xml = _xml_with_inertials(spec)
    xml = re.sub(r"\n\s*<size nkey=\"\d+\"/>\n", "\n", xml)
    written = mujoco.MjModel.from_xml_string(xml)
    names = (input_joint,) if isinstance(input_joint, str) else tuple(input_joint)
    dof = [int(written.joint(n).dofadr[0]) for n in names]
    x, v = assemble(written, qpos, qvel, dof)
    xml = _reference_pose(xml, written, x)
    final = mujoco.MjModel.from_xml_string(xml)
    x, v = assemble(final, x, v, dof)
    key = f'  <keyframe>\n    <key name="initial" qpos="{_vec(x)}" qvel="{_vec(v)}"/>\n  </keyframe>\n'
    xml = xml.rstrip()
    assert xml.endswith("</mujoco>")
    xml = xml[:-len("</mujoco>")] + key + "</mujoco>\n"
    check = mujoco.MjModel.from_xml_string(xml)
    at0, atkey = closure_of(check, check.qpos0), closure_of(check, check.key_qpos[0])
    if not (at0 <= CLOSURE_TOL and atkey <= CLOSURE_TOL):
        raise GeometryError(f"MJCF export: the written model is not assembled (loop closure {at0:.3g} m at qpos0, "
                            f"{atkey:.3g} m at the keyframe; limit {CLOSURE_TOL:g} m)")
    return header + xml


def _xml_with_inertials(spec) -> str:
    """``spec.to_xml()`` with any explicit ``<inertial>`` element it left out restored (MuJoCo
    4.0.0's ``to_xml`` drops one whose ``ipos`` is unset; the XML would then not compile)."""
    xml = spec.to_xml()
    for b in spec.bodies[1:]:
        if not b.explicitinertial or re.search(rf'<body name="{re.escape(b.name)}"[^>]*>\s*<inertial', xml):
            continue
        tag = (f'<inertial pos="0 0 0" mass="{b.mass:.17g}" '
               f'diaginertia="{b.inertia[0]:.17g} {b.inertia[1]:.17g} {b.inertia[2]:.17g}"/>')
        xml = re.sub(rf'(\n(\s*)<body name="{re.escape(b.name)}"[^>]*>)', lambda m: f"{m.group(1)}\n{m.group(2)}  {tag}",
                     xml, count=1)
    return xml
