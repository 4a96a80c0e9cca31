"""The plant (mechanics + drive) as a ``control.StateSpace``: continuous, or the kernel's co-step
at h and its lift to the controller period; frequency responses, poles and modes."""
from __future__ import annotations

import cmath
import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from .mechanics import Mechanics, freeze_angle, multibody_mechanics, reduced_mechanics, to_input_coordinates
from .point import OperatingPoint, operating_point
from .signals import LOCK_FACTOR, _ct


# ============================================================================ plants
def _expm_zoh(A, B, h):
    from scipy.linalg import expm

    n, m = A.shape[0], B.shape[1]
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = expm(M * h)
    return E[:n, :n], E[:n, n:]


def _outputs(mech: Mechanics, internal, n_states, I_row, I_D=0.0):
    names = ["q", "qd", "I", *internal]
    C = np.zeros((len(names), n_states))
    D = np.zeros((len(names), 1))
    nm = mech.A.shape[0]
    C[0, :nm], C[1, :nm] = mech.rows["q"], mech.rows["qd"]
    C[2] = I_row
    D[2, 0] = I_D
    for i, s in enumerate(internal):
        C[3 + i, :nm] = mech.rows[s]
    return names, C, D


def plant(mech: Mechanics, drive, internal=(), h=None, name="plant"):
    """Mechanics + DC-motor drive → ``control.StateSpace`` with input ``V``.

    ``h=None``: continuous time (L·İ = V − R·I − k_m·z·q̇; L = 0: algebraic current).
    ``h`` [s]: the kernel's co-step at h (discrete time, module doc)."""
    ct = _ct()
    R, L, km, z = float(drive.R), float(drive.L), float(drive.k_m), float(drive.z)
    Am, Bm = mech.A, mech.B
    nm = Am.shape[0]
    cqd = mech.rows["qd"][None, :]
    if h is None:
        if L > 0:
            A = np.block([[Am, Bm * z * km], [-(km * z / L) * cqd, np.array([[-R / L]])]])
            B = np.vstack([np.zeros((nm, 1)), [[1.0 / L]]])
            states = list(mech.states) + ["I"]
            I_row = np.zeros(nm + 1)
            I_row[-1] = 1.0
            names, C, D = _outputs(mech, internal, nm + 1, I_row)
        else:
            A = Am - Bm @ cqd * (z * km) ** 2 / R
            B = Bm * z * km / R
            states = list(mech.states)
            names, C, D = _outputs(mech, internal, nm, -(km * z / R) * cqd[0], 1.0 / R)
        return ct.ss(A, B, C, D, 0, inputs=["V"], outputs=names, states=states, name=name)
    h = float(h)
    if L > 0:
        x = h * R / L
        decay = math.exp(-x)
        w = -math.expm1(-x) / x  # mean of exp(-s/τ_e) over the step
    else:
        decay = w = 0.0
    Ad, Bd = _expm_zoh(Am, Bm, h)
    # τ = z·k_m·(w·I + (1 − w)·(V − k_m·z·q̇)/R)
    t_I, t_qd, t_V = z * km * w, -(z * km) ** 2 * (1 - w) / R, z * km * (1 - w) / R
    Amm = Ad + Bd @ cqd * t_qd
    AmI = Bd * t_I
    BmV = Bd * t_V
    # I⁺ = decay·I + g·(V − ½·k_m·z·(q̇ + q̇⁺)),  g = (1 − decay)/R
    g = (1.0 - decay) / R
    cq = cqd[0]
    AIm = -0.5 * g * km * z * (cq + cq @ Amm)
    AII = decay - 0.5 * g * km * z * float(cq @ AmI[:, 0])
    BI = g - 0.5 * g * km * z * float(cq @ BmV[:, 0])
    A = np.block([[Amm, AmI], [AIm[None, :], np.array([[AII]])]])
    B = np.vstack([BmV, [[BI]]])
    I_row = np.zeros(nm + 1)
    I_row[-1] = 1.0
    names, C, D = _outputs(mech, internal, nm + 1, I_row)
    return ct.ss(A, B, C, D, h, inputs=["V"], outputs=names, states=list(mech.states) + ["I"], name=name)


def sample(plant_h, N: int = 1, name=None):
    """Lift a co-step plant (dt = h) to the controller period N·h (V held over the period) and
    add the state/output ``qd_prev``: q̇ one co-step before the sample (the kernel's
    backward-difference acceleration is (q̇ − qd_prev)/h)."""
    ct = _ct()
    N = int(N)
    if N < 1:
        raise ParameterError(f"sample: N = {N} must be >= 1")
    A, B, C, D = (np.asarray(M) for M in (plant_h.A, plant_h.B, plant_h.C, plant_h.D))
    n = A.shape[0]
    h = float(plant_h.dt)
    cqd = C[plant_h.output_labels.index("qd")]
    Ak, Bk = np.eye(n), np.zeros((n, 1))  # state after k co-steps: Ak·x + Bk·u
    for _ in range(N - 1):
        Ak, Bk = A @ Ak, A @ Bk + B
    Phi, Gam = A @ Ak, A @ Bk + B
    An = np.zeros((n + 1, n + 1))
    An[:n, :n] = Phi
    An[n, :n] = cqd @ Ak
    Bn = np.vstack([Gam, (cqd @ Bk)[None, :]])
    Cn = np.hstack([C, np.zeros((C.shape[0], 1))])
    row = np.zeros((1, n + 1))
    row[0, n] = 1.0
    Cn = np.vstack([Cn, row])
    Dn = np.vstack([D, [[0.0]]])
    return ct.ss(An, Bn, Cn, Dn, N * h, inputs=["V"], outputs=list(plant_h.output_labels) + ["qd_prev"],
                 states=list(plant_h.state_labels) + ["qd_prev"], name=name or f"{plant_h.name}_T")


def _angle_mode(angle, op):
    if angle is None:
        return "frozen" if op.qd != 0.0 else "state"
    if angle not in ("state", "frozen"):
        raise ParameterError(f"angle = {angle!r}: choose 'state' (full Jacobian) or 'frozen' (q a parameter)")
    return angle


def reduced_plant(machine, op: OperatingPoint, h=None, angle="state"):
    """The reduced model linearised at ``op``: continuous (``h=None``) or the co-step at h;
    ``angle`` "state" (full Jacobian) or "frozen" (:func:`freeze_angle`; None: frozen when q̇* ≠ 0)."""
    mech = reduced_mechanics(machine, op)
    if _angle_mode(angle, op) == "frozen":
        mech = freeze_angle(mech, len(machine.mechanism.internal))
    return plant(mech, machine.drive, machine.mechanism.internal, h, name="reduced")


def multibody_plant(machine, op: OperatingPoint, options=None, h=None, coordinates="model", angle="state"):
    """The MJCF model linearised at ``op`` by ``mjd_transitionFD`` (module doc): continuous or
    the co-step at h; ``coordinates`` "model" (qpos/qvel of every joint) or "input" (q, x, q̇, ẋ);
    ``angle`` as in :func:`reduced_plant` (input coordinates only)."""
    if coordinates not in ("model", "input"):
        raise ParameterError(f"coordinates = {coordinates!r}: choose 'model' or 'input'")
    mb = multibody_mechanics(machine, op, options)
    if coordinates == "input":
        mb = to_input_coordinates(mb, machine.mechanism)
        if _angle_mode(angle, op) == "frozen":
            mb = freeze_angle(mb, len(machine.mechanism.internal))
    return plant(mb, machine.drive, machine.mechanism.internal, h, name=f"multibody_{coordinates}")


# ============================================================================ comparisons, modes
def frequency_grid(h=None, lo=0.1, n=400, hi=None):
    """Log grid [rad/s] from ``lo`` to ``hi`` (default: 0.9 × the Nyquist frequency π/h, or 1e4)."""
    if hi is None:
        hi = 0.9 * math.pi / h if h else 1e4
    return np.logspace(math.log10(lo), math.log10(hi), int(n))


def response(sys, omega, output=None, input=None):
    """Complex frequency response of one channel (default: the only one) at ``omega`` [rad/s]
    (z = e^{jωT} for a discrete system): C·(sI − A)⁻¹·B + D, solved for every frequency at once."""
    if output is not None or input is not None:
        sys = sys[output if output is not None else 0, input if input is not None else 0]
    A, B, C, D = (np.asarray(M, dtype=float) for M in (sys.A, sys.B, sys.C, sys.D))
    w = np.asarray(omega, dtype=float).reshape(-1)
    s = np.exp(1j * w * float(sys.dt)) if sys.dt else 1j * w
    n = A.shape[0]
    if n == 0:
        return np.full(len(w), complex(D[0, 0]))
    M = s[:, None, None] * np.eye(n)[None] - A[None]
    X = np.linalg.solve(M, np.broadcast_to(B[:, :1], (len(w), n, 1)))
    return (C[:1] @ X)[:, 0, 0] + D[0, 0]


def frequency_difference(a, b, omega=None, output="qd", input="V") -> dict:
    """max |G_a − G_b| / |G_a| over ``omega`` for one channel, and where it occurs."""
    if omega is None:
        omega = frequency_grid(float(a.dt) if a.dt else None)
    Ga, Gb = response(a, omega, output, input), response(b, omega, output, input)
    rel = np.abs(Ga - Gb) / np.abs(Ga)
    i = int(np.argmax(rel))
    return {"max_rel": float(rel[i]), "at_rad_s": float(omega[i]), "rms_rel": float(np.sqrt(np.mean(rel ** 2))),
            "omega_lo_rad_s": float(omega[0]), "omega_hi_rad_s": float(omega[-1])}


@dataclass
class Mode:
    """One pole: s-plane location (discrete poles mapped by s = ln z / T), natural frequency
    |s| [rad/s] and damping ratio −Re s/|s|."""

    pole: complex
    omega_n_rad_s: float
    zeta: float

    def as_dict(self):
        return {"pole": [self.pole.real, self.pole.imag], "omega_n_rad_s": self.omega_n_rad_s, "zeta": self.zeta}


def s_poles(sys) -> np.ndarray:
    """Poles in the s-plane (discrete: ln z / T; poles at z = 0 are dropped)."""
    p = np.asarray(sys.poles(), dtype=complex)
    if sys.dt:
        p = np.array([cmath.log(z) / float(sys.dt) for z in p if abs(z) > 1e-300], dtype=complex)
    return p


def modes(sys, oscillatory_only=False) -> list:
    """Every pole as a :class:`Mode` (one per complex pair, upper half), sorted by ω_n."""
    out = []
    for s in s_poles(sys):
        if s.imag < -1e-9 * max(1.0, abs(s)):
            continue
        if oscillatory_only and abs(s.imag) <= 1e-9 * max(1.0, abs(s)):
            continue
        wn = abs(s)
        out.append(Mode(complex(s), float(wn), float(-s.real / wn) if wn > 0 else float("nan")))
    return sorted(out, key=lambda m: m.omega_n_rad_s)


def locked_input_machine(machine):
    """The machine with its input coordinate locked (input inertia × LOCK_FACTOR): the
    internal (transmission) modes with the motor held still."""
    d = machine.drive
    J_lock = LOCK_FACTOR * max(float(d.J_eq) + float(np.mean(machine.mechanism.reduced(0.0)[0])), 1e-6)
    drive = dataclasses.replace(d, J_b=float(d.J_b) + J_lock)
    return dataclasses.replace(machine, drive=drive)


def transmission_modes(machine, op: OperatingPoint) -> dict:
    """Oscillatory modes of the reduced model in three limits: ``locked`` input (the motor
    held still), ``free`` input (mechanics alone, drive torque held: motor open-circuited) and
    ``driven`` (voltage-driven motor: back-EMF damping, continuous plant)."""
    ct = _ct()
    lk = locked_input_machine(machine)
    m_lock = reduced_mechanics(lk, operating_point(lk, op.q, op.qd, 0.0, op.t, op.x, op.xd))
    m_free = reduced_mechanics(machine, op)
    out = {"locked": modes(ct.ss(m_lock.A, m_lock.B, np.eye(len(m_lock.A)), 0), True),
           "free": modes(ct.ss(m_free.A, m_free.B, np.eye(len(m_free.A)), 0), True),
           "driven": modes(reduced_plant(machine, op), True)}
    return out
