"""Higher pairs of the generic linkage: gear pairs, belts and chains, racks (``[[mechanism.gears]]``).

A gear element couples the rotations of two links relative to their **carrier** (the link that
holds both axes; the frame by default, a planet arm for an epicyclic train) by one linear
relation — a kinematic constraint of the description like a joint, one row of the solver
(:class:`KGear`), one equality of the MJCF:

* ``external`` gear pair (teeth N₁, N₂): r₁·(θ₁ − θ_c) + r₂·(θ₂ − θ_c) = const — the two gears
  turn in opposite senses, θ̇₂ − θ̇_c = −(N₁/N₂)(θ̇₁ − θ̇_c);
* ``internal`` pair (a pinion N₁ inside a ring N₂ > N₁): r₁·(θ₁ − θ_c) − r₂·(θ₂ − θ_c) = const, the
  same sense, ratio +N₁/N₂; with an arm as carrier these give Willis' formula of a planetary stage,
  (θ̇_s − θ̇_a)/(θ̇_r − θ̇_a) = −N_r/N_s;
* ``belt`` / ``chain`` between two pulleys or sprockets: r₁·(θ₁ − θ_c) − r₂·(θ₂ − θ_c) = const (the
  same sense; ``crossed = true``: opposite), the ratio of the pitch radii (``diameters``, or teeth
  and the chain's ``pitch``: d = p / sin(π/N));
* ``rack`` and pinion: the rack's slide s along its prismatic joint with the carrier and the
  pinion's rotation: s ∓ r·(θ_p − θ_c) = const (the sign from the side of the pinion's centre the
  rack's pitch line passes).

Every row is written in metres (the pitch circles' arc lengths), so its residual is the **slip at
the pitch point**: the multibody run's coupling error (``closure_error_m``) is a length like a loop
closure's.  The constant is taken at the stated pose (link ``angle``\\ s, the input at
``input_angle``, slides where the sketch puts them): the stated pose is a meshed pose.

Geometry checks (one line naming the element, before anything is solved or simulated): the links
exist and differ; tooth counts are whole numbers ≥ 3 (an internal pair's ring has more teeth than
its pinion); each gear turns about a pivot of its carrier (or one the carrier shares: a sun
coaxial with its arm); with a ``module`` the centre distance is m·(N₁ ± N₂)/2 — tooth counts that
do not fit their centres do not mesh; a rack's pitch line is tangent to the pinion's pitch circle.

The MuJoCo side (:func:`add_gear_equalities`): one fixed tendon per element, Σ c_k·qpos_k over the
tree joints whose angles make up θ₁, θ₂, θ_c (and the rack's slide), held at its constant by a
tendon equality with the loop closures' solref/solimp (soft like every MuJoCo equality: its
measured slip is in docs/higher_pairs.md §1).  :class:`GearsMixin` gives the linkage the closure
residual as one law over the connect sites and the gear slips (:func:`gear_closure`).
"""

import math
from collections import namedtuple
from typing import Literal

import numpy as np
from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from ... import compiled as C
from ...compiled import law
from ...errors import GeometryError
from ...fields import OptQ, Strict
from ..base import closure_solref, connect_site_pairs
from .topology import GROUND, _ref

GEAR_KINDS = ("external", "internal", "belt", "chain", "rack")
MIN_TEETH = 3
#: a module's centre distance and a rack's pitch line must fit to this fraction of the pitch radius
MESH_TOL = 1e-6


class GearSpec(Strict):
    """``[[mechanism.gears]]``: a gear pair, a belt or chain, or a rack and pinion."""

    name: str = ""
    type: Literal["external", "internal", "belt", "chain", "rack"] = "external"
    gears: tuple[str, str] = Field(description="the two links: gear 1, gear 2 (internal: pinion, ring; "
                                               "rack: pinion, rack)")
    carrier: str = Field(GROUND, description="the link that holds both axes (a planet arm; default the frame)")
    teeth: list[int] | None = Field(None, description="tooth counts [N1, N2] (rack: [N] of the pinion)")
    module: OptQ("length", gt=0.0) = Field(None, description="gear module m: the centre distance is checked")
    diameters: tuple[OptQ("length", gt=0.0), OptQ("length", gt=0.0)] | None = Field(
        None, description="belt/chain: pitch diameters of the two pulleys")
    pitch: OptQ("length", gt=0.0) = Field(None, description="chain or toothed belt: tooth pitch p (d = p/sin(π/N))")
    radius: OptQ("length", gt=0.0) = Field(None, description="rack: the pinion's pitch radius")
    crossed: bool = Field(False, description="belt: crossed (the pulleys turn in opposite senses)")

    @model_validator(mode="after")
    def _values(self):
        nm = self.name or "/".join(self.gears)
        t = self.type
        if self.teeth is not None:
            if any(int(n) != n or n < MIN_TEETH for n in self.teeth):
                raise PydanticCustomError("mjbench_value", "gear {n}: teeth = {t}: tooth counts are whole numbers >= {m}",
                                          {"n": nm, "t": self.teeth, "m": MIN_TEETH})
        if t in ("external", "internal"):
            if self.teeth is None or len(self.teeth) != 2:
                raise PydanticCustomError("mjbench_value", "gear {n}: a gear pair needs teeth = [N1, N2]", {"n": nm})
            if t == "internal" and not self.teeth[1] > self.teeth[0]:
                raise PydanticCustomError("mjbench_value", "gear {n}: teeth = {t} do not mesh: an internal gear (the "
                                          "ring, second) needs more teeth than its pinion", {"n": nm, "t": self.teeth})
            extra = [k for k in ("diameters", "pitch", "radius") if getattr(self, k) is not None]
        elif t in ("belt", "chain"):
            if (self.diameters is None) == (self.teeth is None or self.pitch is None):
                raise PydanticCustomError("mjbench_value", "gear {n}: a {k} needs diameters = [d1, d2], or teeth = "
                                          "[N1, N2] and pitch", {"n": nm, "k": t})
            if self.teeth is not None and len(self.teeth) != 2:
                raise PydanticCustomError("mjbench_value", "gear {n}: teeth = [N1, N2]", {"n": nm})
            extra = [k for k in ("module", "radius") if getattr(self, k) is not None]
        else:
            if (self.radius is None) == (self.module is None or self.teeth is None):
                raise PydanticCustomError("mjbench_value", "gear {n}: a rack needs the pinion's radius, or module and "
                                          "teeth = [N]", {"n": nm})
            if self.teeth is not None and len(self.teeth) != 1:
                raise PydanticCustomError("mjbench_value", "gear {n}: a rack's teeth = [N] (the pinion's)", {"n": nm})
            extra = [k for k in ("diameters", "pitch") if getattr(self, k) is not None]
        if self.crossed and t not in ("belt", "chain"):
            extra.append("crossed")
        if extra:
            raise PydanticCustomError("mjbench_value", "gear {n}: {k} do not apply to a {t}",
                                      {"n": nm, "k": ", ".join(extra), "t": t})
        return self

    @property
    def label(self) -> str:
        return self.name or "/".join(self.gears)


# ============================================================================ structure
def gear_problems(p) -> list:
    """Problems of the description's gear elements (unknown or repeated links, a rack without its
    slide), each naming the element."""
    out = []
    links = set(p.links)
    for k, g in enumerate(p.gears):
        where = f"gears[{k}] ({g.label!r})"
        for ln in (*g.gears, g.carrier):
            if ln != GROUND and ln not in links:
                out.append(f"{where}: link {ln!r} is not defined (links: {', '.join(sorted(links))}, ground)")
        if out:
            continue
        a, b = g.gears
        if len({a, b, g.carrier}) < 3:
            out.append(f"{where}: the two gears and the carrier must be three different links "
                       f"(gears {a!r}, {b!r}, carrier {g.carrier!r})")
        if g.type == "rack" and _rack_joint(p, g) is None:
            out.append(f"{where}: the rack {b!r} must slide on its carrier {g.carrier!r} (a prismatic joint "
                       f"between them)")
    return out


def gear_edges(p) -> list:
    """(name, link 1, link 2, "gear") of every gear element: edges of the joint graph."""
    return [(f"gear:{g.label}", g.gears[0], g.gears[1], "gear") for g in p.gears
            if g.gears[0] != g.gears[1]]


def _rack_joint(p, g):
    """Index of the prismatic joint between the rack and its carrier, or None."""
    for k, j in enumerate(p.joints):
        if j.type != "prismatic":
            continue
        la, lb = _ref(j.at[0])[0], _ref(j.at[1])[0]
        if {la, lb} == {g.gears[1], g.carrier}:
            return k
    return None


# ============================================================================ solver rows
class KGear:
    """One gear element in solver form: a row r·(θ₁ − θ_c) ± r₂·(θ₂ − θ_c) [+ s] − C [m].

    ``b1``, ``b2``, ``bc``: body indices (−1 ground) of gear 1, gear 2 (−1 for a rack: its slide is
    ``jk``, the index of the prismatic KJoint) and the carrier; ``k1``, ``k2`` the coefficients of
    θ₁ and θ₂ [m/rad], the carrier's is −(k1 + k2); ``C`` the constant."""

    def __init__(self, spec, b1, b2, bc, k1, k2, jk=None):
        self.spec, self.b1, self.b2, self.bc = spec, b1, b2, bc
        self.k1, self.k2, self.jk, self.C = float(k1), float(k2), jk, 0.0

    def _theta(self, z, b):
        return z[:, 3 * b + 2] if b >= 0 else np.zeros(z.shape[0])

    def value(self, sysm, z):
        z = np.atleast_2d(z)
        v = self.k1 * self._theta(z, self.b1) - (self.k1 + self.k2) * self._theta(z, self.bc)
        if self.jk is None:
            return v + self.k2 * self._theta(z, self.b2)
        return v + _slide(sysm, sysm.joints[self.jk], z)

    def phi(self, sysm, z):
        return self.value(sysm, z) - self.C

    def jac(self, sysm, z, row):
        """Writes the row's entries into ``row`` (B, 3n)."""
        for b, c in ((self.b1, self.k1), (self.bc, -(self.k1 + self.k2))):
            if b >= 0:
                row[:, 3 * b + 2] += c
        if self.jk is None:
            if self.b2 >= 0:
                row[:, 3 * self.b2 + 2] += self.k2
            return
        jt = sysm.joints[self.jk]  # d s = δd·w + d·n δθ_i (s = d·w, d = P_j − P_i, w = A_i u, n = S w)
        z = np.atleast_2d(z)
        i, j = jt.i, jt.j
        _, _, ci, si_ = sysm._body(z, i)
        w = _apply(ci, si_, jt.u)
        n = np.stack([-w[:, 1], w[:, 0]], axis=-1)
        d = sysm.point(z, j, jt.sj) - sysm.point(z, i, jt.si)
        if j >= 0:
            _, _, cj, sj_ = sysm._body(z, j)
            row[:, 3 * j:3 * j + 2] += w
            row[:, 3 * j + 2] += np.einsum("bk,bk->b", _apply(cj, sj_, np.array([-jt.sj[1], jt.sj[0]])), w)
        if i >= 0:
            row[:, 3 * i:3 * i + 2] -= w
            row[:, 3 * i + 2] += (-np.einsum("bk,bk->b", _apply(ci, si_, np.array([-jt.si[1], jt.si[0]])), w)
                                  + np.einsum("bk,bk->b", d, n))

    def gamma(self, sysm, z, v):
        """Velocity-product terms of the row (0 for rotations; the slide's for a rack)."""
        z, v = np.atleast_2d(z), np.atleast_2d(v)
        if self.jk is None:
            return np.zeros(z.shape[0])
        jt = sysm.joints[self.jk]
        i, j = jt.i, jt.j
        ci, si_, wi, term = sysm.centripetal(z, v, jt)
        w = _apply(ci, si_, jt.u)
        n = np.stack([-w[:, 1], w[:, 0]], axis=-1)
        d = sysm.point(z, j, jt.sj) - sysm.point(z, i, jt.si)
        dd = sysm.point_vel(z, v, j, jt.sj) - sysm.point_vel(z, v, i, jt.si)
        return (-np.einsum("bk,bk->b", term, w) - 2.0 * wi * np.einsum("bk,bk->b", dd, n)
                + np.einsum("bk,bk->b", d, w) * wi * wi)


def _apply(c, s, p):
    p0, p1 = float(p[0]), float(p[1])
    return np.stack([c * p0 - s * p1, s * p0 + c * p1], axis=-1)


def _slide(sysm, jt, z):
    """The prismatic joint's slide coordinate s = (P_j − P_i)·A_i u (as slide_positions)."""
    _, _, ci, si_ = sysm._body(z, jt.i)
    w = _apply(ci, si_, jt.u)
    d = sysm.point(z, jt.j, jt.sj) - sysm.point(z, jt.i, jt.si)
    return np.einsum("bk,bk->b", d, w)


# ============================================================================ geometry of a description
def _centre_in_carrier(c, gear_link, carrier):
    """The point of ``carrier`` (its frame) about which ``gear_link`` turns: a revolute joint
    between them, or a pivot shared by both with a third link (a sun coaxial with its arm)."""
    p = c.p
    piv = {}  # link → [(other link, own point, other point)]
    for k, j in enumerate(p.joints):
        if j.type != "revolute":
            continue
        l1, p1, l2, p2 = c.jlinks[k]
        piv.setdefault(l1, []).append((l2, p1, p2))
        piv.setdefault(l2, []).append((l1, p2, p1))
    for other, own, there in piv.get(gear_link, []):
        if other == carrier:
            return c.pts[carrier][there]
    for other, own, there in piv.get(gear_link, []):  # gear on X at X.there; carrier on X at the same point
        for o2, own2, there2 in piv.get(carrier, []):
            if o2 == other and np.allclose(c.pts[other][there2], c.pts[other][there], rtol=0, atol=1e-12):
                return c.pts[carrier][own2]
    return None


def compile_gears(c) -> list:
    """The solver rows of the description's gear elements (:class:`KGear`), their radii checked
    against tooth counts and module; GeometryError naming the element otherwise."""
    p = c.p
    out = []
    for g in p.gears:
        where = f"mechanism.gears ({g.label!r})"
        a, b = g.gears
        ia, ib, ic = c.index[a], c.index[b], c.index[g.carrier]
        ca = _centre_in_carrier(c, a, g.carrier)
        if ca is None:
            raise GeometryError(f"{where}: gear {a!r} does not turn about a pivot of its carrier {g.carrier!r} (a "
                                f"revolute joint between them, or a pivot both share with a third link)")
        if g.type == "rack":
            r = g.radius if g.radius is not None else 0.5 * g.module * g.teeth[0]
            jk = _rack_joint(p, g)
            kg = KGear(g, ia, -1, ic, 0.0, 0.0, jk)
            kg.r = (float(r), None)
            kg.centre = ca
            out.append(kg)
            continue
        cb = _centre_in_carrier(c, b, g.carrier)
        if cb is None:
            raise GeometryError(f"{where}: gear {b!r} does not turn about a pivot of its carrier {g.carrier!r}")
        dist = float(np.linalg.norm(np.asarray(cb) - np.asarray(ca)))
        if g.type in ("external", "internal"):
            n1, n2 = g.teeth
            if g.module is not None:
                r1, r2 = 0.5 * g.module * n1, 0.5 * g.module * n2
                want = r1 + r2 if g.type == "external" else r2 - r1
                if abs(dist - want) > MESH_TOL * max(r1, r2):
                    raise GeometryError(f"{where}: teeth {n1}/{n2} with module {1000 * g.module:g} mm do not mesh at "
                                        f"their centres: the centre distance is {1000 * dist:.6g} mm, the pitch circles "
                                        f"need {1000 * want:.6g} mm (m·(N1 {'+' if g.type == 'external' else '−'} N2)/2)")
            else:
                if not dist > 0:
                    raise GeometryError(f"{where}: the two gears' centres coincide (a gear pair needs a centre distance)")
                den = (n1 + n2) if g.type == "external" else (n2 - n1)
                r1, r2 = dist * n1 / den, dist * n2 / den
            sign = 1.0 if g.type == "external" else -1.0
        else:
            if g.diameters is not None:
                r1, r2 = 0.5 * g.diameters[0], 0.5 * g.diameters[1]
            else:
                r1, r2 = (0.5 * g.pitch / math.sin(math.pi / n) for n in g.teeth)
            sign = 1.0 if g.crossed else -1.0
        kg = KGear(g, ia, ib, ic, r1, sign * r2)
        kg.r = (r1, r2)
        out.append(kg)
    return out


def set_constants(c, kgears, z):
    """Each row's constant from the configuration ``z`` (the stated pose); a rack's sign from the side
    of its pinion's centre the pitch line passes, and that line's distance checked (GeometryError)."""
    sysm = c.sys
    for kg in kgears:
        if kg.jk is not None:
            _rack_sign(c, kg, z)
        kg.C = float(kg.value(sysm, z[None])[0])


def _rack_sign(c, kg, z):
    """k of s − k·(θ_p − θ_c): the pinion's surface speed at the pitch point along the rack's line."""
    sysm = c.sys
    jt = sysm.joints[kg.jk]
    zz = z[None]
    _, _, ci, si_ = sysm._body(zz, jt.i)
    w = _apply(ci, si_, jt.u)[0]
    Pi = sysm.point(zz, jt.i, jt.si)[0]
    bc = kg.bc
    O = sysm.point(zz, bc, np.asarray(kg.centre) - (c.com[bc] if bc >= 0 else 0.0))[0]
    n = np.array([-w[1], w[0]])
    dist = float((Pi - O) @ n)  # signed distance of the line from the pinion's centre along n = S·w
    r = kg.r[0]
    g = kg.spec
    if abs(abs(dist) - r) > MESH_TOL * r:
        raise GeometryError(f"mechanism.gears ({g.label!r}): the rack's pitch line (its prismatic joint's line) is "
                            f"{1000 * abs(dist):.6g} mm from the pinion's centre, but the pinion's pitch radius is "
                            f"{1000 * r:.6g} mm: they do not mesh")
    # pinion surface speed at the pitch point Q = O + dist·n, along w, per unit φ̇: (S(Q − O))·w = −dist
    # the rack's velocity relative to the carrier along w per unit ṡ: +1 if the carrier owns the line (i)
    sigma = 1.0 if jt.i == bc else -1.0
    kg.k1 = sigma * dist  # s·σ = −dist·φ  ⇒  s + σ·dist·φ = const: row = s + k1·θ_p − k1·θ_c
    kg.k2 = 0.0


# ============================================================================ MJCF
def add_gear_equalities(mech, spec, options, h) -> list:
    """One fixed tendon and one tendon equality per gear element (the module docstring): the
    tendon Σ c_k·qpos_k of the tree joints whose angles make θ₁, θ₂, θ_c (and the rack's slide),
    held at the stated pose's value.  Returns [(name, {joint: coefficient}, constant)]."""
    import mujoco

    c = mech.c
    solref, solimp = closure_solref(options, h)
    by_child = {e.child: e for e in c.edges}
    out = []
    z0, _, _ = c.exact([c.q0])
    vals, _ = mech._tree_values(z0)
    for kg in c.gears:
        coef = {}

        def add_angle(link, k):
            while link != GROUND:
                e = by_child[link]
                if e.kind == "R":
                    coef[e.name] = coef.get(e.name, 0.0) + k
                link = e.parent

        add_angle(c.links[kg.b1] if kg.b1 >= 0 else GROUND, kg.k1)
        add_angle(c.links[kg.bc] if kg.bc >= 0 else GROUND, -(kg.k1 + kg.k2))
        if kg.jk is None:
            add_angle(c.links[kg.b2] if kg.b2 >= 0 else GROUND, kg.k2)
        else:
            coef[c.p.joints[kg.jk].name] = coef.get(c.p.joints[kg.jk].name, 0.0) + 1.0
        coef = {k: v for k, v in coef.items() if v != 0.0}
        name = f"gear_{kg.spec.label}".replace("/", "_")
        t = spec.add_tendon(name=name)
        for jn, v in coef.items():
            t.wrap_joint(jn, float(v))
        const = float(sum(v * vals[jn] for jn, v in coef.items()))  # the tendon at the stated pose
        data = np.zeros(mujoco.mjNEQDATA)
        data[0] = const  # L − L(qpos0 = 0) = const
        spec.add_equality(name=name, type=mujoco.mjtEq.mjEQ_TENDON, name1=name, data=data.tolist(),
                          solref=solref, solimp=solimp)
        out.append((name, coef, const))
    return out


def add_gear_geoms(mech, bodies, rad):
    """Pitch circles of the gears (and the pinion) as thin discs on their links (display only)."""
    import mujoco

    c = mech.c
    for kg in c.gears:
        links = [kg.b1] + ([kg.b2] if kg.jk is None else [])
        for b, r in zip(links, kg.r):
            if b < 0 or r is None:
                continue
            name = c.links[b]
            own = _own_centre(c, name, kg)
            bodies[name].add_geom(name=f"shape_pitch_{kg.spec.label}_{name}".replace("/", "_"),
                                  type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[r, 0.4 * rad, 0],
                                  pos=[own[0], 1.5 * rad, own[1]], quat=[0.7071068, 0.7071068, 0, 0],
                                  rgba=[0.75, 0.7, 0.3, 0.6], contype=0, conaffinity=0, mass=0)


def _own_centre(c, link, kg):
    """The gear's centre in its own frame: the point of its pivot on (or shared with) the carrier."""
    p = c.p
    carrier = c.links[kg.bc] if kg.bc >= 0 else GROUND
    best = None
    for k, j in enumerate(p.joints):
        if j.type != "revolute":
            continue
        l1, p1, l2, p2 = c.jlinks[k]
        if link in (l1, l2):
            own = p1 if l1 == link else p2
            other = l2 if l1 == link else l1
            if other == carrier:
                return c.pts[link][own]
            best = best if best is not None else c.pts[link][own]
    return best if best is not None else np.zeros(2)


#: the linkage's closure residual with gears: the flat site_xpos and its connect pairs, the live qpos,
#: the gears' qpos addresses and coefficients (rows: gear, CSR-like), their constants
GearClosureP = namedtuple("GearClosureP", "sx pairs qpos gstart gadr gcoef gconst")


@law
def gear_closure(P, S):
    """The largest loop-closure residual [m]: the connect sites' offsets and every gear's slip at its
    pitch point |Σ c_k·qpos_k − const| (``P.closure``)."""
    C_ = P.closure
    r = 0.0
    sx = C_.sx
    pairs = C_.pairs
    for p in range(len(pairs)):
        v = abs(sx[pairs[p, 0]] - sx[pairs[p, 1]])
        if v > r:
            r = v
    for g in range(len(C_.gconst)):
        s = -C_.gconst[g]
        for k in range(C_.gstart[g], C_.gstart[g + 1]):
            s += C_.gcoef[k] * C_.qpos[C_.gadr[k]]
        if abs(s) > r:
            r = abs(s)
    return r


class GearsMixin:
    """The linkage's closure residual when it has gears (:func:`gear_closure`)."""

    def closure_form(self, model, data):
        if not self.c.gears:
            return super().closure_form(model, data)
        import mujoco

        pairs = connect_site_pairs(model)
        idx = np.array([(3 * a + j, 3 * b + j) for a, b in pairs for j in range(3)], dtype=np.int64).reshape(-1, 2)
        start, adr, coef, const = [0], [], [], []
        for e in range(model.neq):
            if model.eq_type[e] != mujoco.mjtEq.mjEQ_TENDON:
                continue
            t = int(model.eq_obj1id[e])
            a, n = int(model.tendon_adr[t]), int(model.tendon_num[t])
            for w in range(a, a + n):
                adr.append(int(model.jnt_qposadr[model.wrap_objid[w]]))
                coef.append(float(model.wrap_prm[w]))
            start.append(len(adr))
            const.append(float(model.eq_data[e][0]) + float(model.tendon_length0[t]))
        P = GearClosureP(data.site_xpos.reshape(-1), idx, data.qpos, np.array(start, dtype=np.int64),
                         np.array(adr, dtype=np.int64), np.array(coef, float), np.array(const, float))
        return C.Form(gear_closure, P)


def check_racks(c, kgears, z):
    """After assembly: every rack still meshes with its pinion at the assembled pose, on the side
    its row was written for (GeometryError otherwise)."""
    for kg in kgears:
        if kg.jk is None:
            continue
        k = kg.k1
        _rack_sign(c, kg, z)
        if k * kg.k1 < 0:
            raise GeometryError(f"mechanism.gears ({kg.spec.label!r}): the assembly put the rack's pitch line on the "
                                f"other side of the pinion than the stated pose: check the link angles")
        kg.k1 = k


def symmetric_gears(c) -> np.ndarray:
    """Per link: True for a gear whose mass centre lies on its axis and whose only pivot, spring and
    load points are that axis — a link that may turn a non-integer number of times per input turn
    (a 24/36 pair) without changing the reduced model, which stays periodic over one input turn."""
    p = c.p
    out = np.zeros(c.n, dtype=bool)
    names = {ln for g in p.gears for ln in (g.gears[:1] if g.type == "rack" else g.gears)}
    for ln in names:
        b = c.index.get(ln, -1)
        if b < 0:
            continue
        kg = next(k for k in c.gears if ln in (c.links[k.b1] if k.b1 >= 0 else "",
                                               c.links[k.b2] if k.b2 >= 0 else ""))
        ctr = _own_centre(c, ln, kg)
        used = [c.pts[ln][pt] for k, (l1, p1, l2, p2) in enumerate(c.jlinks) for lk, pt in ((l1, p1), (l2, p2))
                if lk == ln]
        used += [c.pts[ln][_ref(r)[1]] for s in p.springs for r in s.between if _ref(r)[0] == ln]
        used += [c.pts[ln][_ref(ld.point)[1]] for ld in p.loads if ld.point and _ref(ld.point)[0] == ln]
        tol = 1e-12 * c.L
        out[b] = (np.linalg.norm(c.com[b] - ctr) <= tol and all(np.linalg.norm(u - ctr) <= tol for u in used)
                  and not any(ld.link == ln for ld in p.loads))
    return out
