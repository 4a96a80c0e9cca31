"""The generic linkage as a :class:`~mjbench.mechanisms.base.Mechanism` (``[mechanism] type = "linkage"``).

:class:`Linkage` reads its reduced model from the compiled description's table (:mod:`.model`,
:mod:`.reduced`), its drawings and joint values from the position solver (:mod:`.kinematics`),
and takes its MJCF (:mod:`.mjspec`), its MuJoCo loads (:mod:`.multibody_loads`) and its kinematic
analysis (:mod:`.view`) from one mixin each.
"""
from __future__ import annotations

import numpy as np

from ... import compiled as C
from .. import register
from ..base import Mechanism, table_form
from .description import LinkageParams
from .gears import GearsMixin
from .loads import (LinkageExtP, LinkageModelP, _force_law, _loads_params, linkage_model, linkage_torque, load_abscissa,
                    stroke_table)
from .mjspec import MjSpecMixin, _first_load_point
from .model import compiled
from .multibody_loads import MultibodyLoadsMixin
from .topology import GROUND
from .view import AnalysisViewMixin


@register
class Linkage(AnalysisViewMixin, MjSpecMixin, MultibodyLoadsMixin, GearsMixin, Mechanism):
    """A single-DOF planar linkage from its description (see the module docstring)."""

    type_name = "linkage"
    Params = LinkageParams
    #: where the reduced model comes from (printed next to every multibody-vs-reduced figure)
    reduced_source = "independent: own loop-closure kinematics (Newton + constraint Jacobian)"

    def __init__(self, params: LinkageParams):
        self.params = params
        self.name = params.name
        self.input_joint = params.input
        self.c = c = compiled(params)
        #: the input travel after which the followed path repeats (2π; a multiple through change points)
        self.reduced_period = c.period
        self.table_info = dict(c.table_info)
        t = c.table
        self._tab3, self._tab1, self._tab = t.scalar3, t.scalar, t
        self._has_ext = bool(c.damped or any(s.damping > 0 for _, _, s in c.springs) or c.loads)
        #: the loads as the laws use them (a profile over the stroke converted to its table s/F)
        self.load_specs = [self._over_stroke(k, ld) for k, (_, _, ld) in enumerate(c.loads)]
        self._loads = [(5 + 2 * k, 6 + 2 * k, _force_law(ld, k)) for k, ld in enumerate(self.load_specs)]
        self.loads_P = _loads_params(self.load_specs)
        self.ext_P = LinkageExtP(t.P, self.loads_P)
        self._mb = None

    @classmethod
    def accepts(cls, p) -> bool:
        """Whether this class builds the description ``p`` (one input)."""
        return p.inputs is None

    @classmethod
    def from_params(cls, p):
        """The linkage of a description: this class, or the subclass that declares it accepts it
        (several inputs: :class:`.multi_mechanism.MultiLinkage`)."""
        if cls.accepts(p):
            return cls(p)
        for sub in cls.__subclasses__():
            if sub.accepts(p):
                return sub.from_params(p)
        raise ValueError(f"no linkage class accepts {p.name!r}")

    def _stated_z(self):
        """Body coordinates (1, 3n) of the stated pose."""
        return self.c.exact([self.c.q0])[0]

    def _over_stroke(self, k: int, ld):
        """Load k with a profile over the stroke converted to its table s/F (:func:`stroke_table`):
        the stroke is the range of the point's coordinate over one turn (table channel 5 + 2k)."""
        if ld.profile is None and ld.profile_fraction is None:
            return ld
        s = self.load_coordinate(k)
        return stroke_table(ld, float(s.min()), float(s.max()))

    def load_coordinate(self, k: int, n: int = 2048):
        """The coordinate s = P·d [m] of point load k over one period (n input angles)."""
        return self._tab(self.input_positions(n)[0], [5 + 2 * k])[..., 0]

    def load_names(self) -> list[str]:
        """Each load's name (its ``name``, else "load on <point>" / "torque on <link>")."""
        return [ld.name or (f"load on {ld.point}" if ld.link is None else f"torque on {ld.link}")
                for ld in self.load_specs]

    # ------------------------------------------------------------------ reduced model
    def reduced(self, q):
        """J(q) [kg·m²], dJ/dq [kg·m²/rad], dE_p/dq [N·m] from the table (accuracy: ``table_info``)."""
        if isinstance(q, float):
            return self._tab3(q)
        v = self._tab(q, [0, 1, 2])
        return v[..., 0], v[..., 1], v[..., 2]

    def reduced_exact(self, q):
        """(J, J', E_p') solved at q (array) without the table: Newton + analytic kinematics."""
        z, v, a = self.c.exact(q)
        ch = self.c.channels(z, v, a)
        return ch[:, 0], ch[:, 1], ch[:, 2]

    def potential_energy(self, q):
        """Gravity (zero level y = 0) + spring energy E_p(q) [J]."""
        if isinstance(q, float):
            return self._tab1(q, 3)
        return self._tab(q, [3])[..., 0]

    def damping_factor(self, q):
        """Σ c_j·(joint rate / q̇)² + Σ c_s·(dℓ/dq)² [N·m·s/rad]: viscous friction reduced to q."""
        if isinstance(q, float):
            return self._tab1(q, 4)
        return self._tab(q, [4])[..., 0]

    def reduced_viscous(self, q):
        """D(q) when the external torque is viscous only (no point loads): the reduced backends
        then tabulate it with J; None with loads (external_torque is called at every stage)."""
        if self._loads:
            return None
        return self.damping_factor(q)

    def external_torque(self, q, qd, t):
        """Viscous friction of joints and dampers, −D(q)·q̇, plus the point loads F(s)·ds/dq
        [N·m] (a gated load acts where ds/dq has the sign of its stroke, see LoadSpec;
        :func:`linkage_torque`)."""
        if not self._has_ext:
            return 0.0 * q
        P = self.ext_P
        return C.vectorize(lambda a, b: linkage_torque(a, b, P), q, qd)

    def model_form(self):
        """The reduced model as a law: the spline table of J, ½J', E_p' (and D when the external
        torque is viscous only); with point loads, plus :func:`linkage_torque` (:func:`linkage_model`)."""
        tf = table_form(self)
        if not self._loads:
            return tf
        return C.Form(linkage_model, LinkageModelP(tf.P, self.ext_P), flags=dict(tf.flags))

    def load_forces(self, q, qd):
        """[(s, ṡ, F)] of every load at (q, q̇): a point load's coordinate along its direction [m],
        its rate [m/s] and the force [N]; a torque load's table abscissa (its point's stroke [m] or
        the reduced input angle [rad]; 0 for a constant torque), its link's rate θ̇ [rad/s] and the
        torque [N·m]."""
        out = []
        P = self.loads_P
        for k, (ks, kd, law) in enumerate(self._loads):
            v = self._tab(q, [ks, kd])
            s, ds = v[..., 0], v[..., 1]
            if P.spec[k, 7] != 0.0:
                s = C.vectorize(lambda a, k=k: load_abscissa(k, a, P, self.c.table.P), q + 0.0 * ds)
            out.append((s, ds * qd, law(s, ds)))
        return out

    # ------------------------------------------------------------------ kinematics for drawings
    def state(self, q):
        """(z, v, a) solved at q (array): body coordinates (x_G, y_G, θ) per link and their first
        and second derivatives with respect to q."""
        return self.c.exact(q)

    def points(self, q):
        z = self.c.z_guess(np.ravel(np.asarray(q, float)))
        pts = self.c.world_points(z)
        shape = np.shape(q)
        return {k: (x.reshape(shape), y.reshape(shape)) if shape else (float(x[0]), float(y[0]))
                for k, (x, y) in pts.items()}

    def trace_point(self, q):
        ref = self.params.trace or _first_load_point(self.params)
        if ref is None:
            return None
        return self.points(q)[ref]

    def describe(self) -> dict:
        return self.params.to_dict()

    def linkage_view(self):
        """Itself: its own kinematics (link lines, joints) for ``mjbench analyze``."""
        return self

    def input_positions(self, n: int):
        """n input angles over one period from the stated pose's input angle (one turn; the turns
        after which a path through change points repeats)."""
        return self.c.q0 + self.c.period * np.arange(n) / n, "rad"

    def change_points(self) -> tuple:
        """Input angles [rad] in [q0, q0 + period) where the followed branch passes a change point."""
        return tuple(self.c.changes)

    def _tree_values(self, z, v=None):
        """Joint values (and rates per unit q if v) of the tree joints from body coordinates."""
        c = self.c
        o, th = c.frames(z)
        o, th = o[0], th[0]
        vals, rates = {}, {}
        if v is not None:
            jr = c.joint_rates(z, v)[0]
        for e in c.edges:
            if e.kind == "R":
                tp = th[c.index[e.parent]] if e.parent != GROUND else 0.0
                vals[e.name] = th[c.index[e.child]] - tp
                if v is not None:
                    rates[e.name] = jr[e.k] if e.line_first else -jr[e.k]
            else:
                d = c.slide_positions(z)[0, e.k]
                vals[e.name] = d
                if v is not None:
                    rates[e.name] = jr[e.k]
        return vals, rates

    def initial_qpos(self, model, q0: float, x0=None) -> np.ndarray:
        z, _, _ = self.c.exact([float(q0)])
        vals, _ = self._tree_values(z)
        qpos = np.array(model.qpos0, dtype=float)
        for name, val in vals.items():
            qpos[model.joint(name).qposadr[0]] = val
        qpos[model.joint(self.input_joint).qposadr[0]] = q0
        return qpos

    def initial_qvel(self, model, q0: float, qd0: float, x0=None, xd0=None) -> np.ndarray:
        z, v, _ = self.c.exact([float(q0)])
        _, rates = self._tree_values(z, v)
        qvel = np.zeros(model.nv)
        for name, r in rates.items():
            qvel[model.joint(name).dofadr[0]] = r * qd0
        return qvel

    def joint_states(self, model, q):
        """(qpos (B, nq), qvel per unit input speed (B, nv)) at input angles q (array): what
        :meth:`initial_qpos` / :meth:`initial_qvel` give, solved for every angle at once (the
        reduced backend's joint columns, :mod:`mjbench.backends.joints`)."""
        c = self.c
        q = np.atleast_1d(np.asarray(q, float))
        z, v, _ = c.exact(q)
        _, th = c.frames(z)
        jr = c.joint_rates(z, v)
        sl = c.slide_positions(z)
        qpos = np.tile(np.asarray(model.qpos0, float), (len(q), 1))
        qvel = np.zeros((len(q), model.nv))
        for e in c.edges:
            jn = model.joint(e.name)
            a, d = int(jn.qposadr[0]), int(jn.dofadr[0])
            if e.kind == "R":
                tp = th[:, c.index[e.parent]] if e.parent != GROUND else 0.0
                qpos[:, a] = th[:, c.index[e.child]] - tp
                qvel[:, d] = jr[:, e.k] if e.line_first else -jr[:, e.k]
            else:
                qpos[:, a] = sl[:, e.k]
                qvel[:, d] = jr[:, e.k]
        qpos[:, int(model.joint(self.input_joint).qposadr[0])] = q
        return qpos, qvel
