"""What may be fitted and how: the missing and legible Table I values, the search variables u ∈ [0, 1]
and their map to physical values, the box, shape and feasibility bounds, the targets."""
from __future__ import annotations

import math

from mjbench import scenario as S
from mjbench.errors import GeometryError, ParameterError, ScenarioError
import numpy as np


# --------------------------------------------------------------------------- Incerti 2012 specification
#: parameters the seed does not give (Table I illegible) → scenario key
MISSING = {
    "a": "mechanism.a", "b": "mechanism.b", "c": "mechanism.c", "h_x": "mechanism.h_x",
    "f1": "mechanism.f1", "f2": "mechanism.f2", "f3": "mechanism.f3",
    "m1": "mechanism.m1", "m2": "mechanism.m2", "m3": "mechanism.m3",
    "R": "drive.R",
}


#: legible Table I / §III values: never fitted (the message quotes the seed's value)
LEGIBLE = {
    "h_y": "mechanism.h_y", "theta1": "mechanism.theta1", "theta2": "mechanism.theta2",
    "theta3": "mechanism.theta3", "J_G1": "mechanism.J_G1", "J_G2": "mechanism.J_G2",
    "J_G3": "mechanism.J_G3", "L": "drive.L", "k_m": "drive.k_m", "J_m": "drive.J_m",
    "J_a": "drive.J_a", "J_b": "drive.J_b", "z": "drive.z", "T_0": "drive.T_0", "lam": "drive.lam",
    "kp": "modes.pid.kp", "ki": "modes.pid.ki", "kd": "modes.pid.kd", "omega0": "modes.pid.omega0",
    "voltage": "modes.open.voltage",
}


#: seed of the scenarios this calibration applies to
PAPERS = ("Incerti 2012",)  #: the scenarios' [scenario] paper for which the calibration is defined


DEFAULT_PARAMS = tuple(MISSING)


#: box bounds of lengths [m] and R [Ω]
BOUNDS = {"a": (0.03, 0.20), "b": (0.10, 0.60), "c": (0.10, 0.60), "h_x": (0.10, 0.60), "R": (0.3, 5.0)}


PHI_MIN, PHI_MAX = 0.2, 0.8          # f_i / l_i


KAPPA_MIN = 1.0 / 30.0               # J_Gi / (m_i l_i²) lower bound (upper: φ(1 − φ))


MU_MIN = math.radians(20.0)          # minimum transmission angle [rad]


LINK = {"1": "a", "2": "b", "3": "c"}


#: targets: name → (paper value, tolerance used to scale the residual, unit)
TARGETS = {
    "chi_open": (0.543, 5e-4, "-"),             # §III, open loop 25 V, Eq 22
    "chi_pid_window": (0.026, 5e-4, "-"),       # §III, PID K_p·t, window 0.375–0.5 s
    "mean_speed_open": (30.0, 1.0, "rad/s"),    # Fig. 4a (reading of a plot)
}


PENALTY = 1e3


#: finite-difference step in u (search vector in [0, 1]): 1e-2, well above the ~1e-4 jitter of a
#: sampled max/min (χ) at a 1 ms record
DIFF_STEP = 1e-2


def check_params(names, scn=None):
    """Validate a parameter list: only missing Table I values may be fitted."""
    names = [n.strip() for n in names if n.strip()]
    if not names:
        raise ParameterError("--params: give at least one missing parameter to fit, e.g. a,b,c,h_x,m2,m3,R")
    if scn is not None:
        paper = scn.scenario.paper
        if paper not in PAPERS:
            raise ScenarioError(f"scenario {scn.name!r} (paper {paper or '?'!r}): calibration "
                                f"is defined for the Incerti 2012 scenarios only")
    for n in names:
        if n in LEGIBLE:
            val = S.get(scn, LEGIBLE[n]) if scn is not None else None
            raise ParameterError(
                f"--params {n}: {LEGIBLE[n]} = {val!r} is given by the seed (Table I / §III, legible); "
                f"calibration only fits the missing values {sorted(MISSING)}")
        if n not in MISSING:
            raise ParameterError(f"--params {n}: unknown parameter; the missing (fittable) ones are "
                                 f"{sorted(MISSING)}")
    if len(set(names)) != len(names):
        raise ParameterError(f"--params {','.join(names)}: a parameter is listed twice")
    return names


# --------------------------------------------------------------------------- mapping u ∈ [0,1]ⁿ → values
def _base_values(scn):
    return {n: float(S.get(scn, k)) for n, k in MISSING.items()}


def _lin(u, lo, hi):
    return lo + u * (hi - lo)


def _unlin(v, lo, hi):
    return (v - lo) / (hi - lo)


def to_values(u, names, base):
    """Search vector u (in [0,1]) → dict of all missing values (held ones from ``base``)."""
    v = dict(base)
    x = dict(zip(names, np.asarray(u, dtype=float)))
    for n in ("a", "b", "c", "h_x", "R"):
        if n in x:
            v[n] = _lin(x[n], *BOUNDS[n])
    phi = {}
    for i, L in LINK.items():
        if f"f{i}" in x:
            phi[i] = _lin(x[f"f{i}"], PHI_MIN, PHI_MAX)
            v[f"f{i}"] = phi[i] * v[L]
        else:
            phi[i] = v[f"f{i}"] / v[L]
    return v, phi, x


def values(u, names, base, J_G):
    """All missing values for the search vector u, masses mapped through the shape factor."""
    v, phi, x = to_values(u, names, base)
    for i, L in LINK.items():
        if f"m{i}" in x:
            kmax = phi[i] * (1.0 - phi[i])
            kappa = _lin(x[f"m{i}"], KAPPA_MIN, max(kmax, KAPPA_MIN))
            v[f"m{i}"] = J_G[i] / (kappa * v[L] ** 2)
    return v


def to_u(vals, names, base, J_G):
    """Inverse of :func:`values` for the fitted names (clipped to [0, 1])."""
    u = []
    for n in names:
        if n in BOUNDS:
            u.append(_unlin(vals[n], *BOUNDS[n]))
        elif n[0] == "f":
            u.append(_unlin(vals[n] / vals[LINK[n[1]]], PHI_MIN, PHI_MAX))
        else:
            i = n[1]
            L = vals[LINK[i]]
            phi = vals[f"f{i}"] / L
            kappa = J_G[i] / (vals[n] * L * L)
            u.append(_unlin(kappa, KAPPA_MIN, max(phi * (1 - phi), KAPPA_MIN + 1e-12)))
    return np.clip(np.array(u, dtype=float), 0.0, 1.0)


def shape_factors(vals, J_G):
    """κ_i = J_Gi / (m_i l_i²) and φ_i = f_i / l_i of the three links."""
    out = {}
    for i, L in LINK.items():
        l = vals[L]
        out[i] = (J_G[i] / (vals[f"m{i}"] * l * l), vals[f"f{i}"] / l)
    return out


def feasibility(scn, vals, J_G):
    """(violation ≥ 0, message): 0 for a crank-rocker with full turn, μ_min ≥ MU_MIN and
    plausible link shapes; a positive measure of the violation otherwise."""
    viol, why = 0.0, []
    for i, (kappa, phi) in shape_factors(vals, J_G).items():
        kmax = phi * (1 - phi)
        if kappa > kmax * (1 + 1e-9) or kappa < KAPPA_MIN * (1 - 1e-9):
            viol += max(kappa - kmax, KAPPA_MIN - kappa, 0.0) / KAPPA_MIN
            why.append(f"link {i}: shape factor J_G/(m l²) = {kappa:.4g} outside [{KAPPA_MIN:.4g}, {kmax:.4g}]")
        if not (PHI_MIN - 1e-9 <= phi <= PHI_MAX + 1e-9):
            viol += abs(phi - min(max(phi, PHI_MIN), PHI_MAX))
            why.append(f"link {i}: f/l = {phi:.4g} outside [{PHI_MIN}, {PHI_MAX}]")
    try:
        mech = S.make_mechanism(_with(scn, vals))
    except GeometryError as e:
        a, b, c = vals["a"], vals["b"], vals["c"]
        d = math.hypot(vals["h_x"], float(S.get(scn, "mechanism.h_y")))
        s = sorted((a, b, c, d))
        grashof = max(0.0, s[0] + s[3] - s[1] - s[2]) + max(0.0, a - s[0])
        return viol + 1.0 + grashof / d, "; ".join(why + [str(e)])
    alpha = np.linspace(0.0, 2 * np.pi, 361)
    mu = float(np.min(mech.transmission_angle(alpha)))
    if mu < MU_MIN:
        viol += (MU_MIN - mu)
        why.append(f"minimum transmission angle {math.degrees(mu):.1f}° < {math.degrees(MU_MIN):.0f}°")
    return viol, "; ".join(why)


def _with(scn, vals):
    """The scenario with the missing values set (validated by the schema)."""
    return S.with_values(scn, {MISSING[n]: float(v) for n, v in vals.items()})


def bounds_text():
    return {**{k: list(v) for k, v in BOUNDS.items()}, "f_i/l_i": [PHI_MIN, PHI_MAX],
            "J_Gi/(m_i l_i^2)": [KAPPA_MIN, "f_i(l_i-f_i)/l_i^2"],
            "min_transmission_angle_deg": math.degrees(MU_MIN), "crank": "full turn (Grashof crank-rocker)"}
