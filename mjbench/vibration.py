"""Residual vibration of a platform driven through an elastic transmission (seeds 001, 003).

Model (seed 001 Eq 4 / seed 003 Eq 6), ψ = transmission deflection (platform side, rad):

    ψ̈ + 2ξω_n·ψ̇ + ω_n²·ψ = −ρ·φ̈(t),   ψ(0) = ψ̇(0) = 0

with φ the motor angle (the law) and ρ = λ = z·r/R (belt) or z (elastic joint).  At t = T the
motor is at rest and the residual mechanical energy is (seed 001 Eqs 26-31, seed 003 Eqs 24-29)

    E(T) = ½·J·(ρ/ω_d)²·[G² + ω_n²·F²]

with F = ∫₀ᵀ φ̈(τ)·e^{−ξω_n(T−τ)}·sin ω_d(T−τ) dτ and G = ∫₀ᵀ ∂f/∂t dτ.  Both are parts of one
complex integral W = ∫₀ᵀ φ̈(τ)·e^{s(T−τ)} dτ, s = −ξω_n + iω_d:  F = Im W,  G = Im(s·W)
(g = ω_n·φ̈·e^{…}·cos(ω_d(T−τ) + δ) of Eq 29 is exactly Im(s·e^{s(T−τ)})·φ̈).

Three independent evaluations of E(T):

* ``closed``: W computed exactly — for polynomial laws (Bezier, integer exponents) by the
  terminating integration-by-parts series W = Σ_k [p⁽ᵏ⁾(0)·e^{sT} − p⁽ᵏ⁾(T)] / s^{k+1}; for
  pseudo-polynomial laws term by term, ∫₀¹ u^e·e^{sTu} du by Gauss–Jacobi quadrature with the
  weight u^e (exact for the singular factor, spectrally convergent for the entire e^{sTu};
  machine precision with ≥ |sT| + 40 nodes);
* ``ode``: the reduced ODE above by ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-12);
* ``multibody``: the MuJoCo model of :mod:`mjbench.mechanisms.platform`, RK4, the driven joint
  kinematically imposed at every integrator stage (:func:`simulate_multibody`).

Also: residual envelope at T and peak after T, ZV / ZVD input shapers (Singer & Seering 1990) applied to a law,
±ω_n sensitivity, and the optimiser (:func:`optimize`: BFGS, or SLSQP when constraints on peak
speed / acceleration / torque are given; both quasi-Newton).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .control import REGISTRY as CONTROLLERS
from .errors import ParameterError
from .metrics import RESIDUAL_METRICS  # noqa: F401 - the names residual_from_trajectory writes
from .mechanisms.platform import Oscillator, Platform
from .motionlaws import BezierLaw, MotionLaw, PseudoPolynomialLaw, shaped_form
from .schema import CheckParams, OptimizeParams
from .scenario import make_mechanism
from .machine import Machine
from .scenario import make_drive, make_mechanism
from .backends import simulate


# ====================================================================== shaped laws
class ShapedLaw(MotionLaw):
    """A law convolved with an impulse sequence (input shaper): φ_s(t) = Σ A_j·φ(t − t_j), Σ A_j = 1.
    The move lasts T + t_last."""

    kind = "shaped"

    def __init__(self, law: MotionLaw, amplitudes, times, name="shaped"):
        self.base = law
        self.A = np.asarray(amplitudes, dtype=float)
        self.tj = np.asarray(times, dtype=float)
        if abs(self.A.sum() - 1.0) > 1e-12:
            raise ParameterError(f"shaper amplitudes {self.A.tolist()} must sum to 1")
        self.name = name
        super().__init__(law.Phi, law.T + float(self.tj.max()))

    def motion_form(self):
        """Σ A_j·φ(t − t_j) as a law: :func:`mjbench.motionlaws.shaped_motion` over the base law's."""
        return shaped_form(self.base, self.A, self.tj)

    def describe(self):
        return {"kind": self.kind, "name": self.name, "base": self.base.describe(),
                "amplitudes": self.A.tolist(), "times": self.tj.tolist(), "T_total": self.T}


def zv_shaper(osc: Oscillator):
    """ZV shaper (Singer & Seering): A = [1, K]/(1+K), t = [0, π/ω_d], K = exp(−ξπ/√(1−ξ²))."""
    K = math.exp(-osc.xi * math.pi / math.sqrt(1.0 - osc.xi ** 2))
    return np.array([1.0, K]) / (1.0 + K), np.array([0.0, math.pi / osc.omega_d])


def zvd_shaper(osc: Oscillator):
    """ZVD shaper: A = [1, 2K, K²]/(1+K)², t = [0, π/ω_d, 2π/ω_d]."""
    K = math.exp(-osc.xi * math.pi / math.sqrt(1.0 - osc.xi ** 2))
    Td = math.pi / osc.omega_d
    return np.array([1.0, 2 * K, K * K]) / (1.0 + K) ** 2, np.array([0.0, Td, 2 * Td])


def shape(law: MotionLaw, osc: Oscillator, kind: str = "ZV", same_total_time: bool = False) -> ShapedLaw:
    """Apply a ZV or ZVD shaper designed for ``osc`` to ``law``.  ``same_total_time``: shorten the
    base law so that the shaped move still ends at the law's T (a fair, equal-time comparison)."""
    A, tj = {"ZV": zv_shaper, "ZVD": zvd_shaper}[kind.upper()](osc)
    base = law
    if same_total_time:
        Tb = law.T - tj[-1]
        if Tb <= 0:
            raise ParameterError(f"{kind} shaper lasts {tj[-1]:.4g} s >= T = {law.T} s")
        base = _retimed(law, Tb)
    return ShapedLaw(base, A, tj, name=f"{kind.upper()}{' (total T)' if same_total_time else ''}")


def _retimed(law, T):
    if isinstance(law, PseudoPolynomialLaw):
        return PseudoPolynomialLaw(law.Phi, T, law.gammas)
    if isinstance(law, BezierLaw):
        return BezierLaw(law.Phi, T, law.m, law.p, law.interior)
    raise ParameterError(f"cannot retime a {type(law).__name__}")


# ====================================================================== closed form
_JACOBI_CACHE: dict = {}


def _gauss_jacobi_01(e: float, n: int):
    """Nodes u and weights w on [0, 1] for ∫₀¹ u^e·g(u) du ≈ Σ w·g(u) (e > −1)."""
    key = (e, n)
    r = _JACOBI_CACHE.get(key)
    if r is None:
        from scipy.special import roots_jacobi

        x, w = roots_jacobi(n, 0.0, e)  # weight (1+x)^e on [-1, 1]
        r = (0.5 * (x + 1.0), w * 0.5 ** (e + 1.0))
        if len(_JACOBI_CACHE) > 256:
            _JACOBI_CACHE.clear()
        _JACOBI_CACHE[key] = r
    return r


def convolution_W(law: MotionLaw, osc: Oscillator, t_end: float | None = None) -> complex:
    """W(t_end) = ∫₀^{t_end} φ̈(τ)·e^{s(t_end−τ)} dτ [rad/s] (exact; see module doc).
    ``t_end`` ≥ the law's T (default T): after T φ̈ = 0 and W(t) = e^{s(t−T)}·W(T)."""
    s = osc.s
    if isinstance(law, ShapedLaw):
        Tb = law.base.T
        Wb = convolution_W(law.base, osc)  # base move ending at Tb
        t_end = law.T if t_end is None else t_end
        return complex(Wb * np.sum(law.A * np.exp(s * (t_end - law.tj - Tb))))
    T = law.T
    if isinstance(law, PseudoPolynomialLaw):
        a, e = law.accel_terms()
        beta = s * T
        n = int(abs(beta)) + 48
        W = 0j
        for ai, ei in zip(a, e):
            if ai == 0.0:
                continue
            u, w = _gauss_jacobi_01(float(ei), n)
            W += ai * np.dot(w, np.exp(beta * u))
        W *= T
    elif isinstance(law, BezierLaw):
        bp = law.accel_bpoly()
        deg = bp.c.shape[0] - 1
        eT = np.exp(s * T)
        W, sk = 0j, s
        for k in range(deg + 1):
            d = bp.derivative(k) if k else bp
            W += (float(d(0.0)) * eT - float(d(T))) / sk
            sk *= s
    else:
        W = _quad_W(law, osc, T)
    if t_end is not None and t_end != T:
        W *= np.exp(s * (t_end - T))
    return complex(W)


def _quad_W(law, osc, T):
    from scipy.integrate import quad

    s = osc.s

    def re(tau):
        return float(law.evaluate(tau, 2)[2]) * np.exp(s * (T - tau)).real

    def im(tau):
        return float(law.evaluate(tau, 2)[2]) * np.exp(s * (T - tau)).imag

    kw = dict(limit=400, epsabs=0.0, epsrel=1e-13)
    return quad(re, 0, T, **kw)[0] + 1j * quad(im, 0, T, **kw)[0]


def FG(law, osc, t_end=None):
    """(F, G) of seed 001 Eq 30 / seed 003 Eq 28 [rad/s, rad/s²]."""
    W = convolution_W(law, osc, t_end)
    return W.imag, (osc.s * W).imag


def residual_state(law, osc, t_end=None):
    """(ψ, ψ̇) at t_end (default T) [rad, rad/s] by the closed form (Eqs 5, 28)."""
    F, G = FG(law, osc, t_end)
    k = -osc.ratio / osc.omega_d
    return k * F, k * G


def energy_from_state(psi, psid, osc, motor_speed=0.0):
    """E = ½J[(ψ̇ + ρφ̇)² + ω_n²ψ²] [J] (seed 001 Eq 25): :meth:`Oscillator.energy`."""
    return osc.energy(psi, psid, motor_speed)


def residual_energy(law, osc, t_end=None) -> float:
    """E(T) [J] by the closed form: ½J(ρ/ω_d)²(G² + ω_n²F²) (seed 001 Eq 31)."""
    F, G = FG(law, osc, t_end)
    return 0.5 * osc.J * (osc.ratio / osc.omega_d) ** 2 * (G * G + osc.omega_n ** 2 * F * F)


PEAK_WINDOW = 2.0  #: [s] window after T over which the actual residual peak |ψ| is reported


def residual_peak(law, osc, window: float = PEAK_WINDOW, n: int = 20001) -> float:
    """Largest |ψ| [rad, platform] actually reached over [T, T + window] with the motor at rest
    after T (ideal servo), from the closed form ψ(T + τ) = −(ρ/ω_d)·Im(W(T)·e^{sτ}) on n points
    (relative error ≲ (ω_d·window/n)²/8 ≈ 4e-6 for the platforms here)."""
    W = convolution_W(law, osc)
    tau = np.linspace(0.0, float(window), int(n))
    psi = -osc.ratio / osc.omega_d * np.imag(W * np.exp(osc.s * tau))
    return float(np.max(np.abs(psi)))


def residual_envelope(psi, psid, osc) -> float:
    """Envelope [rad, platform] at T of the free vibration that starts from (ψ, ψ̇) when the motor
    stops (:meth:`Oscillator.envelope`; :func:`residual_peak` is the peak actually reached)."""
    return osc.envelope(psi, psid)


residual_amplitude = residual_envelope  # the former name (it computes the envelope above)


# ====================================================================== reduced ODE
#: right-hand-side evaluations an ODE check may spend (a healthy law needs ≈ 2 500 at rtol 1e-12;
#: a degenerate one, the small difference of 1e6-sized terms, needed 1.1e7 — two minutes)
ODE_MAX_NFEV = 200_000


class ODEBudgetExceeded(ParameterError):
    """The ODE check needed more right-hand-side evaluations than :data:`ODE_MAX_NFEV`."""


def ode_response(law, osc, t_end=None, t_eval=None, rtol=1e-12, atol=None, method="DOP853",
                 max_nfev=ODE_MAX_NFEV):
    """Integrate ψ̈ + 2ξω_nψ̇ + ω_n²ψ = −ρφ̈ from rest; returns (t, ψ, ψ̇) at ``t_eval``
    (default: 2001 points on [0, t_end]); the integration is split at T (end of the law).
    Raises :class:`ODEBudgetExceeded` after ``max_nfev`` right-hand-side evaluations (None: no
    budget), so a law too stiff to integrate at ``rtol`` cannot hang the caller."""
    t_end = law.T if t_end is None else float(t_end)
    if t_eval is None:
        t_eval = np.linspace(0.0, t_end, 2001)
    t_eval = np.clip(np.asarray(t_eval, dtype=float), 0.0, t_end)
    wn, xi, rho = osc.omega_n, osc.xi, osc.ratio
    acc = law.acceleration
    scale = abs(rho * law.Phi) / max(wn * wn * law.T ** 2, 1e-300)
    atol = 1e-15 * max(scale, 1e-300) if atol is None else atol

    count = [0]

    def spend():
        count[0] += 1
        if max_nfev is not None and count[0] > max_nfev:
            raise ODEBudgetExceeded(f"the ODE check of the {law.kind} law needed more than {max_nfev:,} right-hand-side "
                                    f"evaluations at rtol = {rtol:g} (a healthy law needs a few thousand): the law is "
                                    f"too stiff or degenerate to integrate")

    def rhs(t, y):
        spend()
        return (y[1], -2 * xi * wn * y[1] - wn * wn * y[0] - rho * float(acc(t)))

    def rhs_free(t, y):
        spend()
        return (y[1], -2 * xi * wn * y[1] - wn * wn * y[0])

    Tm = min(law.T, t_end)
    ev1 = t_eval[t_eval <= Tm]
    from scipy.integrate import solve_ivp

    s1 = solve_ivp(rhs, (0.0, Tm), [0.0, 0.0], method=method, rtol=rtol, atol=atol, t_eval=ev1)
    ts, ys = [s1.t], [s1.y]
    yT = s1.y[:, -1] if s1.t.size and s1.t[-1] == Tm else \
        solve_ivp(rhs, (0.0, Tm), [0.0, 0.0], method=method, rtol=rtol, atol=atol).y[:, -1]
    if t_end > Tm:
        ev2 = t_eval[t_eval > Tm]
        s2 = solve_ivp(rhs_free, (Tm, t_end), yT, method=method, rtol=rtol, atol=atol, t_eval=ev2)
        ts.append(s2.t)
        ys.append(s2.y)
    return np.concatenate(ts), np.concatenate([y[0] for y in ys]), np.concatenate([y[1] for y in ys]), yT


def residual_energy_ode(law, osc, **kw) -> float:
    _, _, _, yT = ode_response(law, osc, t_end=law.T, t_eval=np.array([law.T]), **kw)
    return float(energy_from_state(yT[0], yT[1], osc))


# ====================================================================== multibody
def simulate_multibody(platform, law, t_end=None, dt=1e-4, record_dt=None):
    """Run the platform's MuJoCo model with the motor joint following ``law`` exactly (the
    papers' ideal servo).

    Classical RK4 over MuJoCo's dynamics, written out here because the motor's generalised force
    must be recomputed at every stage: at each stage (t, q, v) one ``mj_forward`` gives
    f = qfrc_passive − qfrc_bias (tendon springs and dampers included) and the mass matrix, and
    the motor force u that makes its acceleration equal the law's is
    u = (φ̈(t) − (M⁻¹f)_m)/(M⁻¹)_mm (inverse dynamics of the driven joint); the stage
    acceleration is then M⁻¹(f + u·e_m).  (No global ``mjcb_control`` callback: the model has
    no constraints, so this is exactly MuJoCo's RK4 with a stage-wise control.)  Returns a dict
    of arrays: t, motor angle φ, motor speed φ̇, platform angle / speed / acceleration,
    deflection ψ, ψ̇ [rad, rad/s, rad/s²]."""
    import mujoco

    t_end = law.T if t_end is None else float(t_end)
    spec = platform.build_spec(options={"timestep": dt})
    m = spec.compile()
    if m.neq:
        raise ParameterError("simulate_multibody: the prescribed-motion RK4 needs a model without constraints")
    d = mujoco.MjData(m)
    va = int(m.joint(platform.input_joint).dofadr[0])
    pa, pv = int(m.joint("platform").qposadr[0]), int(m.joint("platform").dofadr[0])
    rho = float(platform.ratio)
    nv = m.nv
    e = np.zeros((1, nv))
    e[0, va] = 1.0
    y = np.zeros((1, nv))
    x = np.zeros((1, nv))
    f = np.zeros((1, nv))

    def qacc(t, q, v):
        d.qpos[:] = q
        d.qvel[:] = v
        d.time = t
        d.qfrc_applied[:] = 0.0
        mujoco.mj_forward(m, d)
        np.subtract(d.qfrc_passive, d.qfrc_bias, out=f[0])
        mujoco.mj_solveM(m, d, x, f)
        mujoco.mj_solveM(m, d, y, e)
        u = (float(law.acceleration(t)) - x[0, va]) / y[0, va]
        return x[0] + u * y[0]

    nsteps = int(round(t_end / dt))
    decim = 1 if record_dt is None else max(1, int(round(record_dt / dt)))
    nrec = nsteps // decim + 1
    rec = np.empty((nrec, 6))
    q = np.array(platform.initial_qpos(m, 0.0))
    v = np.zeros(nv)
    h2, h6 = 0.5 * dt, dt / 6.0
    k = 0
    for n in range(nsteps + 1):
        t = n * dt
        a1 = qacc(t, q, v)
        if n % decim == 0:
            rec[k] = (t, q[va], v[va], q[pa], v[pv], a1[pv])
            k += 1
        if n == nsteps:
            break
        v2 = v + h2 * a1
        a2 = qacc(t + h2, q + h2 * v, v2)
        v3 = v + h2 * a2
        a3 = qacc(t + h2, q + h2 * v2, v3)
        v4 = v + dt * a3
        a4 = qacc(t + dt, q + dt * v3, v4)
        q = q + h6 * (v + 2 * v2 + 2 * v3 + v4)
        v = v + h6 * (a1 + 2 * a2 + 2 * a3 + a4)
    rec = rec[:k]
    out = {"t": rec[:, 0], "motor_angle": rec[:, 1], "motor_speed": rec[:, 2], "platform_angle": rec[:, 3],
           "platform_speed": rec[:, 4], "platform_accel": rec[:, 5]}
    out["psi"] = out["platform_angle"] - rho * out["motor_angle"]
    out["psid"] = out["platform_speed"] - rho * out["motor_speed"]
    return out


#: MuJoCo steps the E(T) check may take per law (4 mj_forward each: ≈ 1 min)
MB_MAX_STEPS = 1_000_000


def residual_energy_multibody(platform, law, dt=1e-4) -> float:
    r = simulate_multibody(platform, law, t_end=law.T, dt=dt, record_dt=law.T)
    osc = platform.oscillator()
    return float(energy_from_state(r["psi"][-1], r["psid"][-1], osc, r["motor_speed"][-1]))


# ====================================================================== degenerate laws
GAMMA_GAP_MIN = 0.1   #: exponents of a pseudo-polynomial law closer than this: collapsing together
GAMMA_LIMIT_MARGIN = 0.05  #: an exponent within this of its validity limit n: at the edge
COEFF_MAX = 100.0     #: |C_i| above this: large cancelling terms (the 3-4-5 law has |C| ≤ 15)
POLYGON_MARGIN = 1.0  #: Bezier interior ordinates beyond [−1, 2]·Φ: a polygon far outside the move


def law_warnings(law) -> list:
    """Signs that a law (typically an optimiser's result) is degenerate, as sentences: exponents
    collapsing together or at their validity limit, large cancelling coefficients (the law is
    the small difference of huge terms: sensitive to every digit), a Bezier polygon leaving
    [0, Φ], a motor that reverses during the move.  Empty when the law is healthy."""
    out = degeneracy(law)
    v = law.velocity(np.linspace(0.0, law.T, 2001))
    if np.any(np.sign(law.Phi) * v < -1e-9 * np.max(np.abs(v))):
        out.append("the motor reverses during the move (the speed changes sign)")
    return out


def degeneracy(law) -> list:
    """The numerical signs of :func:`law_warnings` (collapsing or edge exponents, huge cancelling
    coefficients, a far-away Bezier polygon): laws the optimiser does not enter (see
    :func:`optimize`) — their E(T) is the small difference of huge terms, and the ODE check of
    such a law needs millions of steps."""
    out = []
    if isinstance(law, PseudoPolynomialLaw):
        g = np.sort(law.gammas)
        gaps = np.diff(g)
        if gaps.size and gaps.min() < GAMMA_GAP_MIN:
            i = int(np.argmin(gaps))
            out.append(f"exponents collapsing together: γ = {g[i]:.4g} and {g[i + 1]:.4g} differ by {gaps[i]:.3g} "
                       f"(< {GAMMA_GAP_MIN:g})")
        if g[0] - law.n < GAMMA_LIMIT_MARGIN:
            out.append(f"exponent γ = {g[0]:.4g} at its validity limit n = {law.n} (the law's derivative "
                       f"{law.n} barely vanishes at T)")
        cmax = float(np.max(np.abs(law.C)))
        if cmax > COEFF_MAX:
            out.append(f"large cancelling coefficients: max |C_i| = {cmax:.3g} (> {COEFF_MAX:g}; the 3-4-5 "
                       "polynomial has 15)")
    if isinstance(law, BezierLaw):
        y = np.asarray(law.interior, dtype=float) / law.Phi
        if np.any(y < -POLYGON_MARGIN) or np.any(y > 1.0 + POLYGON_MARGIN):
            out.append(f"control polygon far outside [0, Φ]: interior ordinates / Φ = "
                       f"{', '.join(f'{v:.3g}' for v in y)} (large cancelling terms)")
    return out


# ====================================================================== optimisation
@dataclass
class Constraints:
    """Optional limits on the motor law (None = no limit): peak |φ̇| [rad/s], |φ̈| [rad/s²] and
    peak motor torque [N·m] estimated as (J_motor + ρ²·J)·|φ̈| (rigid transmission)."""

    max_speed: float | None = None
    max_accel: float | None = None
    max_torque: float | None = None
    J_motor: float = 0.0
    ngrid: int = 801

    def active(self):
        return any(v is not None for v in (self.max_speed, self.max_accel, self.max_torque))


@dataclass
class OptResult:
    law0: MotionLaw
    law: MotionLaw
    E0: float
    E: float
    nit: int
    nfev: int
    message: str
    method: str
    history: list = field(default_factory=list)
    held: int = 0         #: trial laws refused as degenerate during the search
    held_reason: str = ""  #: why the last one was refused (degeneracy())


def _residual_vector(law, osc):
    """r with |r|² = E(T): r = √h·(G, ω_n·F), h = ½J(ρ/ω_d)²."""
    F, G = FG(law, osc)
    sh = math.sqrt(0.5 * osc.J) * abs(osc.ratio) / osc.omega_d
    return np.array([sh * G, sh * osc.omega_n * F])


def optimize(law0: MotionLaw, osc: Oscillator, constraints: Constraints | None = None, method=None,
             gtol=1e-13, maxiter=500, fd_step=1e-6, callback=None) -> OptResult:
    """Minimise E(T) over the law's shape parameters from ``law0`` (seeds 001/003 §IV).

    Objective E(x)/E(x0) (scaled so the start is 1); gradient 2·Jᵣᵀ·r from the residual vector r
    (|r|² = E) with Jᵣ by central differences (r is smooth and O(√E0), so the gradient stays
    accurate when E itself is 1e-12 of the start).  Unconstrained: BFGS; with constraints:
    SLSQP (a quasi-Newton SQP).  Parameters that make the law invalid (exponents not distinct or
    ≤ n) evaluate as +inf-like penalties so the line search backs off."""
    from scipy.optimize import minimize

    x0 = np.asarray(law0.params, dtype=float)
    if x0.size == 0:
        raise ParameterError(f"the {law0.kind} law has no shape parameter to optimise (e.g. law.p = 0)")
    bad = degeneracy(law0)
    if bad:
        raise ParameterError(f"the initial {law0.kind} law is degenerate ({'; '.join(bad)}): optimize-law searches "
                             f"healthy laws only (exponent gaps >= {GAMMA_GAP_MIN:g}, |C_i| <= {COEFF_MAX:g}, Bezier "
                             f"ordinates within [-{POLYGON_MARGIN:g}, {1 + POLYGON_MARGIN:g}]·Φ); start from one")
    r0 = _residual_vector(law0, osc)
    E0 = float(r0 @ r0)
    scale = 1.0 / E0 if E0 > 0 else 1.0
    hist = []
    held = {"n": 0, "why": ""}
    fun = _scaled_energy(law0, osc, scale, fd_step, hist, held, callback)
    cons = _constraints(law0, osc, constraints)
    method = method or ("SLSQP" if cons else "BFGS")
    if method == "BFGS":
        res = minimize(fun, x0, jac=True, method="BFGS", options={"gtol": gtol, "maxiter": maxiter})
    elif method == "SLSQP":
        res = minimize(fun, x0, jac=True, method="SLSQP", constraints=cons,
                       options={"ftol": 1e-16, "maxiter": maxiter})
    else:
        res = minimize(fun, x0, jac=True, method=method, options={"maxiter": maxiter})
    law = law0.with_params(res.x)
    if degeneracy(law):  # (the walls keep every accepted point healthy; a last guard)
        law = law0
    return OptResult(law0=law0, law=law, E0=E0, E=residual_energy(law, osc), nit=int(res.get("nit", 0)),
                     nfev=int(res.nfev), message=str(res.message), method=method, history=hist,
                     held=held["n"], held_reason=held["why"])


def _scaled_energy(law0, osc, scale, fd_step, hist, held, callback):
    """fun(x) → (E/E0, its gradient 2·Jᵣᵀ·r) for the optimiser (module doc of :func:`optimize`); a
    parameter vector giving an invalid or degenerate law is a wall (1e6, counted in ``held``)."""
    def resid(x):
        try:
            law = law0.with_params(x)
        except ParameterError:
            return None
        why = degeneracy(law)
        if why:  # a wall: the line search backs off, the search stays among healthy laws
            held["n"] += 1
            held["why"] = why[0]
            return None
        return _residual_vector(law, osc)

    def fun(x):
        r = resid(x)
        if r is None:
            return 1e6, np.zeros_like(x)
        Jr = np.empty((r.size, x.size))
        for i in range(x.size):
            hstep = fd_step * max(1.0, abs(x[i]))
            xp, xm = x.copy(), x.copy()
            xp[i] += hstep
            xm[i] -= hstep
            rp, rm = resid(xp), resid(xm)
            if rp is None or rm is None:
                return 1e6, np.zeros_like(x)
            Jr[:, i] = (rp - rm) / (2 * hstep)
        val = float(r @ r) * scale
        hist.append(val)
        if callback is not None:
            callback(x, val)
        return val, 2.0 * scale * (Jr.T @ r)
    return fun


def _constraints(law0, osc, constraints) -> list:
    """The motor-law limits as one SLSQP inequality g(x) ≥ 0 (empty without an active limit)."""
    if constraints is None or not constraints.active():
        return []
    c = constraints
    tg = np.linspace(0.0, law0.T, c.ngrid)
    inertia = c.J_motor + osc.ratio ** 2 * osc.J

    def g(x):
        try:
            _, v, a = law0.with_params(x).evaluate(tg, 2)
        except ParameterError:
            return -np.ones(3)
        out = []
        if c.max_speed is not None:
            out.append(1.0 - np.max(np.abs(v)) / c.max_speed)
        if c.max_accel is not None:
            out.append(1.0 - np.max(np.abs(a)) / c.max_accel)
        if c.max_torque is not None:
            out.append(1.0 - inertia * np.max(np.abs(a)) / c.max_torque)
        return np.array(out)

    return [{"type": "ineq", "fun": g}]


# ====================================================================== summaries
def summary(law, osc, J_motor=0.0) -> dict:
    """E(T) (closed form), residual state, the free-vibration envelope at T (``residual_envelope_at_T_rad``)
    and the actual peak |ψ| over [T, T + 2 s] (``residual_peak_after_T_rad``), peaks of the motor law."""
    psi, psid = residual_state(law, osc)
    pk = law.peaks()
    env = residual_envelope(psi, psid, osc)
    return {"E_T_J": residual_energy(law, osc), "psi_T_rad": psi, "psid_T_rad_s": psid,
            "residual_envelope_at_T_rad": env,
            "residual_peak_after_T_rad": residual_peak(law, osc), "residual_peak_window_s": PEAK_WINDOW,
            "peak_motor_speed_rad_s": pk["speed"], "peak_motor_accel_rad_s2": pk["accel"],
            "peak_motor_jerk_rad_s3": pk["jerk"], "T_total_s": law.T,
            "peak_torque_rigid_Nm": (J_motor + osc.ratio ** 2 * osc.J) * pk["accel"]}


def sensitivity(laws: dict, osc: Oscillator, errors=(-0.05, -0.025, 0.0, 0.025, 0.05), keep="xi"):
    """E(T_end) and residual envelope at T_end of each law when the plant's ω_n is off by ``errors``
    (fractions) while the law was designed for ``osc``.  Returns {name: [(err, E, envelope), ...]}."""
    out = {}
    for name, law in laws.items():
        rows = []
        for err in errors:
            o = osc.scaled(1.0 + err, keep=keep)
            psi, psid = residual_state(law, o)
            rows.append((float(err), float(energy_from_state(psi, psid, o)), residual_envelope(psi, psid, o)))
        out[name] = rows
    return out


def peak_torque_ode(law, osc, J_motor=0.0, n=4001):
    """Peak motor torque [N·m] along the move with the elastic transmission: J_motor·φ̈ + ρ·(J·ψ̈_platform)
    i.e. J_motor·φ̈ + ρ·J·(ψ̈ + ρφ̈) = J_motor·φ̈ − ρ(k ψ + c ψ̇)."""
    t, psi, psid, _ = ode_response(law, osc, t_eval=np.linspace(0, law.T, n))
    a = law.acceleration(t)
    tau = J_motor * a - osc.ratio * (osc.k * psi + osc.c * psid)
    return float(np.max(np.abs(tau)))


# ====================================================================== scenario study
def _limit(v):
    return None if v in (None, 0, 0.0) else float(v)


def study(scn, progress=None, multibody=None) -> dict:
    """Everything ``mjbench optimize-law`` reports for a scenario (a platform ``[mechanism]``,
    ``[law]``, ``[optimize]``, ``[check]``, ``[paper]``; with a ``servo`` mode also the laws run by
    the real motor and servo through the co-step kernel).

    Returns a dict with plain numbers under "report" (JSON-ready) and the objects (platform,
    oscillator, laws) under "objects" for the plots."""
    plat = _study_platform(scn)
    osc = plat.oscillator()
    law0 = scn.law.build()
    opt = scn.optimize or OptimizeParams()
    chk = scn.check or CheckParams()
    paper = dict(scn.paper)
    J_motor = float(plat.J_motor)
    cons = Constraints(_limit(opt.max_speed), _limit(opt.max_accel), _limit(opt.max_torque), J_motor=J_motor)
    do_mb = chk.multibody if multibody is None else bool(multibody)
    tick = (lambda: progress.update(1)) if progress is not None else (lambda: None)
    if do_mb and law0.T / chk.multibody_dt > MB_MAX_STEPS:  # before any work
        raise ParameterError(f"the MuJoCo check of a {law0.T:g} s law at check.multibody_dt = {chk.multibody_dt:g} s is "
                             f"{law0.T / chk.multibody_dt:,.0f} steps per law (more than {MB_MAX_STEPS:,}): raise "
                             f"check.multibody_dt, or skip it with --no-multibody")

    res = optimize(law0, osc, cons if cons.active() else None,
                   method=None if cons.active() else opt.method, gtol=opt.gtol, maxiter=opt.maxiter)
    tick()
    laws = {"initial": law0, "optimised": res.law}
    if "gammas_optimum" in paper and isinstance(law0, PseudoPolynomialLaw):
        laws["paper_optimum"] = PseudoPolynomialLaw(law0.Phi, law0.T, paper["gammas_optimum"])
    rep = {"scenario": scn.name, "paper_name": scn.scenario.paper,
           "platform": plat.describe(), "oscillator": osc.describe(),
           "omega_n_rad_s": osc.omega_n, "xi": osc.xi, "optimiser": _optimiser_report(res, cons),
           "laws": {}, "paper": {k: v for k, v in paper.items()}}
    _law_rows(rep, laws, osc, J_motor)
    tick()
    shaped = _shaped_laws(rep, law0, osc, chk.shapers, J_motor)
    tick()
    errs = chk.sensitivity
    sens_laws = {**laws, **shaped}
    rep["sensitivity"] = {"omega_n_errors": list(errs), "keep": "xi",
                          "table": {k: [{"err": e, "E_J": E, "envelope_rad": a} for e, E, a in rows]
                                    for k, rows in sensitivity(sens_laws, osc, errs).items()}}
    fine = np.linspace(-0.05, 0.05, 81)
    sens_fine = sensitivity(sens_laws, osc, fine)
    tick()
    if do_mb:
        dt = chk.multibody_dt
        for name in ("initial", "optimised", "paper_optimum"):
            if name in laws:
                rep["laws"][name]["E_T_multibody_J"] = residual_energy_multibody(plat, laws[name], dt=dt)
        rep["multibody"] = {"integrator": "RK4", "dt_s": dt, "drive": "kinematic (inverse dynamics per stage)"}
        tick()
    servo_runs = {}
    servo_mode = next((k for k, v in scn.modes.items() if v.type == "servo"), None)
    if servo_mode is not None:
        rep["servo"] = servo_study(scn, servo_mode, {k: laws[k] for k in ("initial", "optimised")},
                                   t_after=chk.t_after, runs=servo_runs)
        tick()
    E0, E1 = rep["laws"]["initial"]["E_T_J"], rep["laws"]["optimised"]["E_T_J"]
    rep["reduction_orders"] = float(np.log10(E0 / max(E1, 1e-300)))
    return {"report": rep, "objects": {"platform": plat, "osc": osc, "laws": laws, "shaped": shaped,
                                       "sens_fine": (fine, sens_fine), "servo_runs": servo_runs,
                                       "t_after": chk.t_after}}


def _study_platform(scn):
    """The scenario's platform (a ParameterError unless it is one with a ``[law]``)."""

    plat = make_mechanism(scn)
    if not isinstance(plat, Platform):
        raise ParameterError(f"optimize-law needs a platform mechanism ([mechanism] type = \"platform\"), "
                             f"scenario {scn.name!r} has {scn.mechanism.type!r}")
    if scn.law is None:
        raise ParameterError(f"optimize-law: scenario {scn.name!r} has no [law] table")
    return plat


def _optimiser_report(res: OptResult, cons: Constraints) -> dict:
    return {"method": res.method, "iterations": res.nit, "evaluations": res.nfev,
            "message": res.message,
            "constraints": {"max_speed": cons.max_speed, "max_accel": cons.max_accel,
                            "max_torque": cons.max_torque},
            "degenerate_trials_refused": res.held,
            "degenerate_bounds": {"gamma_gap_min": GAMMA_GAP_MIN, "gamma_limit_margin": GAMMA_LIMIT_MARGIN,
                                  "coeff_max": COEFF_MAX, "polygon_margin": POLYGON_MARGIN},
            **({"held_back": f"{res.held} trial laws were degenerate and refused (last: {res.held_reason}); "
                             f"the optimum may lie at the edge of the healthy laws"} if res.held else {})}


def _law_rows(rep, laws, osc, J_motor) -> None:
    """Each law's closed-form summary, then its ODE residual energy and elastic peak torque."""
    for name, law in laws.items():
        rep["laws"][name] = {"law": law.describe(), **summary(law, osc, J_motor), "warnings": law_warnings(law)}
    for name, law in laws.items():
        try:
            rep["laws"][name]["E_T_ode_J"] = residual_energy_ode(law, osc)
            rep["laws"][name]["peak_torque_elastic_Nm"] = peak_torque_ode(law, osc, J_motor)
        except ODEBudgetExceeded as e:  # reported, never a hang
            rep["laws"][name].update(E_T_ode_J=None, peak_torque_elastic_Nm=None, ode_note=str(e))


def _shaped_laws(rep, law0, osc, shapers, J_motor) -> dict:
    """The initial law input-shaped (each shaper, at its own and at the same total time)."""
    shaped = {}
    for kind in shapers:
        for same in (False, True):
            try:
                sl = shape(law0, osc, kind, same_total_time=same)
            except ParameterError:
                continue
            shaped[sl.name] = sl
            rep["laws"][sl.name] = {"law": sl.describe(), **summary(sl, osc, J_motor)}
    return shaped


# ====================================================================== real motor and servo
def servo_machine(scn, mode, law):
    """The scenario's machine in ``mode`` (a servo) tracking ``law`` instead of the [law] table."""

    mech, drive = make_mechanism(scn), make_drive(scn)
    p = scn.modes[mode]
    ctrl = CONTROLLERS.get(p.type).from_params(p, drive=drive, mechanism=mech, scenario=scn,
                                               reference=law.as_reference(t0=p.reference.t0))
    return Machine(mech, drive, ctrl, q0=scn.initial.q0, qd0=scn.initial.qd0, I0=scn.initial.I0)


def residual_from_trajectory(tr, osc, T, t_after):
    """Residual-vibration figures of a machine run: :meth:`Oscillator.residual_metrics`."""
    return osc.residual_metrics(tr, T, t_after)


def servo_study(scn, mode, laws: dict, t_after=0.5, runs=None, backend="reduced", peak_window=PEAK_WINDOW) -> dict:
    """Each law run by the real motor + servo of ``mode`` (the co-step kernel, ``backend``) for
    T + max(t_after, peak_window) s, next to its ideal-servo figures: {"laws": {name: {...}},
    "drive": ..., "controller": ...}.  The residual peak is over [T, T + peak_window]."""

    out = {"mode": mode, "backend": backend, "drive": scn.drive.to_dict(),
           "controller": scn.modes[mode].to_dict(), "dt_s": scn.simulation.dt, "laws": {}}
    for name, law in laws.items():
        mc = servo_machine(scn, mode, law)
        osc = mc.mechanism.oscillator()
        opts = {"timestep": scn.simulation.dt} if backend == "reduced" else scn.multibody_options()
        tr = simulate(mc, backend, law.T + max(t_after, peak_window), record_dt=scn.simulation.dt, options=opts)
        r = residual_from_trajectory(tr, osc, law.T, peak_window)
        err = law.position(tr.t) - tr.q
        r["max_tracking_error_rad"] = float(np.max(np.abs(err)))
        psi, psid = residual_state(law, osc)
        r["ideal_E_T_J"] = residual_energy(law, osc)
        r["ideal_residual_envelope_at_T_rad"] = residual_envelope(psi, psid, osc)
        r["ideal_residual_peak_after_T_rad"] = residual_peak(law, osc, peak_window)
        out["laws"][name] = r
        if runs is not None:
            runs[name] = tr
    return out
