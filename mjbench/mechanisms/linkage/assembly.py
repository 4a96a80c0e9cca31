"""Assembly, mobility and the branch over one input turn, with the errors that name what is wrong.

:meth:`AssemblyMixin.build`: Levenberg–Marquardt assembly at the stated pose (pulled towards the
stated link angles), the degrees of freedom counted by the rank of the constraint Jacobian,
continuation over one turn (the branch must close on itself), then the reduced-model table
(:mod:`.reduced`).  Every failure is a :class:`~mjbench.errors.GeometryError` naming joints,
loops and input angles (docs/linkages.md §2.2, §7).
"""
from __future__ import annotations

import math

import numpy as np

from ...errors import GeometryError
from ..linkage_kin import TWO_PI, SolveError, _angle_ranges
from .gears import check_racks, set_constants, symmetric_gears
from .kinematics import _deg

COARSE_STEPS = 90  #: continuation steps over one turn (subdivided automatically where needed)
COND_TOL = 1e-9  #: σ_min/σ_max of the scaled constraint Jacobian below this = singular (dead centre)
MAX_TURNS = 4  #: input turns after which the path followed through change points must repeat


class AssemblyMixin:
    """The branch of the compiled description (:class:`.model._Compiled`)."""

    def build(self):
        """Assemble at the stated pose, check the mobility, follow the branch over one input turn
        and tabulate the reduced model.  GeometryError naming joints and input angles otherwise."""
        p, sysm = self.p, self.sys
        q0 = float(p.input_angle)
        self.q0 = q0
        if self.gears:  # gear rows hold at the stated pose (gears.py)
            set_constants(self, self.gears, self.guess(q0))
        z_free, res_free = sysm.assemble(self.guess(q0), q0, free=True)
        if res_free < 1e-9:  # the loops close near the stated pose (input free): count the freedom there
            self._mobility(z_free)
        z_ref, res = sysm.assemble(z_free if res_free < 1e-9 else self.guess(q0), q0)
        if not res < 1e-9:
            self._no_assembly(q0, z_ref)
        if not res_free < 1e-9:
            self._mobility(z_ref)
        check_racks(self, self.gears, z_ref)
        rack = any(g.type == "rack" for g in p.gears)
        for turns in range(1, MAX_TURNS + 1):  # the path followed by continuity closes after `turns` input turns
            try:
                qs, Z, V, A, changes = sysm.continuation(z_ref, q0, TWO_PI * turns, COARSE_STEPS * turns,
                                                         cond_tol=COND_TOL, cross=True)
            except SolveError as e:
                self._branch_failure(e, z_ref, q0)
            dz = Z[-1] - Z[0]
            link_turns = dz[2::3] / TWO_PI
            w = np.round(link_turns)
            if self.gears:  # a symmetric gear may turn N1/N2 times per input turn (gears.py)
                w = np.where(symmetric_gears(self) & (np.abs(link_turns - w) > 1e-9), link_turns, w)
            pos_err = np.max(np.abs(np.delete(dz, np.s_[2::3]))) / self.L if self.n else 0.0
            ang_err = np.max(np.abs(dz[2::3] - TWO_PI * w))
            if pos_err <= 1e-7 and ang_err <= 1e-7:
                break
            if rack:
                raise GeometryError(
                    f"linkage {p.name!r}: after one input turn from the stated pose the linkage does not come back "
                    f"(position gap {pos_err * self.L:.3g} m): a rack turned by a pinion that turns with the input "
                    f"moves on for ever; drive the rack to and fro (a crank and rod) so that the machine repeats "
                    f"every turn")
        else:
            raise GeometryError(
                f"linkage {p.name!r}: after {MAX_TURNS} input turns from the stated pose the linkage has not returned "
                f"to it (position gap {pos_err * self.L:.3g} m): the path followed by continuity through its change "
                f"points ({_angles_text(changes)}) is not periodic; check link angles and dimensions")
        self.period = TWO_PI * turns  #: the input travel after which the followed path repeats [rad]
        self.w = w  # whole turns of every link over one period
        self.changes = sorted(changes)  #: input angles of the change points passed over one period [rad]
        self.coarse = (qs, Z, V, A)
        self.z_ref = z_ref
        self._bridges()
        self._tables()
        return self

    def _mobility(self, z):
        p, sysm = self.p, self.sys
        Jm = sysm.jac(z[None])[0] * sysm.row_scale[:, None] / sysm.col_scale[None, :]
        sv = np.linalg.svd(Jm[:-1], compute_uv=False)
        rank = int(np.sum(sv > 1e-9 * max(sv[0], 1e-300)))
        nz = sysm.nz
        dof = nz - rank
        grubler = 3 * self.n - 2 * len(p.joints) - len(p.gears)
        head = (f"linkage {p.name!r} has {dof} degree{'s' if dof != 1 else ''} of freedom at the stated pose "
                f"(3·{self.n} link coordinates − rank {rank} of the joint constraints; Grübler count {grubler})")
        if dof == 0:
            k_in = self.jindex[p.input]
            names = sorted({nm for k in self.closures for nm in self.cycle_of(k) if p.joints[k_in].name in self.cycle_of(k)})
            raise GeometryError(f"{head}: it is a rigid structure — the loop(s) through joints {', '.join(names)} lock "
                                f"the input joint {p.input!r}; a single-input machine needs exactly 1 "
                                f"(remove a link or a joint, or free one)")
        U, S, Vt = np.linalg.svd(Jm)
        if dof >= 2:
            null = Vt[-(dof - 1):] / sysm.col_scale[None, :]
            names = self._moving_joints(z, null)
            k_in = self.jindex[p.input]
            open_ = "" if any(p.input in self.cycle_of(k) for k in self.closures) else (
                f" (the input joint {p.input!r} is in no closed loop: it drives only the links hanging from it)")
            raise GeometryError(f"{head}: with the input joint {p.joints[k_in].name!r} held, joints {', '.join(names)} "
                                f"can still move{open_}; a single-input machine needs exactly 1 (add a link or a "
                                f"joint, or lock the extra freedom)")
        if S[-1] < COND_TOL * S[0]:
            names = self._moving_joints(z, Vt[-1:] / sysm.col_scale[None, :])
            raise GeometryError(f"linkage {p.name!r}: the stated pose (input angle {_deg(float(p.input_angle))}) is a "
                                f"dead centre or change point of the input: joints {', '.join(names)} can move with "
                                f"the input held, so the pose does not pick a branch; state the pose at another input "
                                f"angle (the branch is then followed through the change point by continuity)")

    def _moving_joints(self, z, null):
        r = np.abs(self.joint_rates(np.repeat(z[None], len(null), 0), null))
        for k, jt in enumerate(self.kjoints):
            if jt.kind == "P":
                r[:, k] /= self.L
        r = r.max(axis=0)
        return [self.p.joints[k].name for k in np.flatnonzero(r > 1e-6 * max(r.max(), 1e-300))
                if self.p.joints[k].name != self.p.input]

    def _gap_joint(self, z, q):
        F = self.sys.phi(z[None], q)[0]
        best, name = -1.0, ""
        for k, jt in enumerate(self.kjoints):
            g = math.hypot(F[2 * k], F[2 * k + 1]) if jt.kind == "R" else abs(F[2 * k])
            if g > best:
                best, name = g, jt.name
        return name, best

    def _closable(self, q, guesses):
        """Smallest scaled closure residual at input angle q over assemblies from the guesses."""
        best, zb = math.inf, None
        for g in guesses:
            z, res = self.sys.assemble(g, q)
            if res < best:
                best, zb = res, z
        return best, zb

    def _no_assembly(self, q0, z):
        p = self.p
        name, gap = self._gap_joint(z, q0)
        qs = q0 + TWO_PI * np.arange(72) / 72
        ok, prev = np.zeros(72, bool), None
        for i, q in enumerate(qs):
            res, zz = self._closable(q, [self.guess(q)] + ([prev] if prev is not None else []))
            ok[i] = res < 1e-9
            prev = zz if ok[i] else prev
        if not ok.any():
            raise GeometryError(f"linkage {p.name!r} cannot be assembled at any input angle: the closest assembly at "
                                f"{_deg(q0)} leaves a gap of {gap:.4g} m at joint {name!r} (loop {', '.join(self._loop_names(name))}); "
                                f"check the link dimensions")
        raise GeometryError(f"linkage {p.name!r}: the loop {', '.join(self._loop_names(name))} cannot close for input "
                            f"angles {_ranges_text(qs, ~ok)} (5° scan), including the stated pose at {_deg(q0)} "
                            f"(gap {gap:.4g} m at joint {name!r}); the input cannot make the full turn")

    def _loop_names(self, jname):
        k = self.jindex[jname]
        if k in self.closures:
            return self.cycle_of(k)
        loops = [self.cycle_of(c) for c in self.closures if jname in self.cycle_of(c)]
        return loops[0] if loops else [jname]

    def _branch_failure(self, e, z_ref, q0):
        """The GeometryError of a branch that cannot be followed over the turn (``e``: the solver's
        SolveError): the input angles where a loop cannot close; else where the input locks (the
        branch ends: a dead centre) or where branches meet and none continues the velocity."""
        p, sysm = self.p, self.sys
        qf, zf = e.q, e.z
        try:
            sysm.continuation(z_ref, q0, -TWO_PI, COARSE_STEPS, cond_tol=COND_TOL, cross=True)
            qb, zb = qf - TWO_PI, zf
        except SolveError as e2:
            qb, zb = e2.q, e2.z
        lo, hi = qf, qb + TWO_PI
        qm = 0.5 * (lo + hi)
        res, zm = self._closable(qm, [zf, zb])
        if res > 1e-8:
            name, gap = self._gap_joint(zm, qm)
            raise GeometryError(
                f"linkage {p.name!r}: the loop {', '.join(self._loop_names(name))} cannot close for input angles "
                f"{_deg(lo)}..{_deg(hi)} (at {_deg(qm)} the closest assembly leaves a {gap:.4g} m gap at joint "
                f"{name!r}); the input locks at {_deg(lo)} and cannot make the full turn — a crank needs a linkage "
                f"that assembles at every input angle (e.g. Grashof: shortest + longest ≤ sum of the other two, crank "
                f"the shortest)")
        Jm = sysm.jac(zf[None])[0] * sysm.row_scale[:, None] / sysm.col_scale[None, :]
        Vt = np.linalg.svd(Jm)[2]
        names = self._moving_joints(zf, Vt[-1:] / sysm.col_scale[None, :])
        if e.kind == "singular":
            raise GeometryError(
                f"linkage {p.name!r}: branches meet at input angle {_deg(qf)} (joints {', '.join(names)} can move "
                f"with the input held) and none continues the velocity there: continuity cannot choose the branch, "
                f"the input cannot drive the linkage through it")
        raise GeometryError(
            f"linkage {p.name!r}: the linkage locks at input angle {_deg(qf)}: the branch ends there (a dead centre: "
            f"joints {', '.join(names)} can move with the input held) and the input cannot drive it further")


def _angles_text(qs):
    """'a, b' (degrees) of input angles; 'none' if empty."""
    return ", ".join(_deg(q) for q in qs) or "none"


def _ranges_text(qs, mask):
    """'a..b, c..d' (degrees) for the runs of True in mask over the grid qs (wrapping)."""

    return ", ".join(f"{_deg(lo)}..{_deg(hi)}" for lo, hi in _angle_ranges(qs, mask))
