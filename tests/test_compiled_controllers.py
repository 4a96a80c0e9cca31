"""Every shipped controller and reference is one law: the compiled co-step loop (numba) gives the
same bits as the CPython loop on both backends, the controller object called from Python gives
the voltages the kernel recorded, a batch equals its single runs, and a controller written in a
test file (a lead-lag) runs compiled without touching mjbench.

Independent paths: the CPython execution of the same loop (the reference for the compiled one);
the controller *object* replayed on the kernel's recorded measurements (it runs its law with its
own parameters and state, outside the kernel); single runs for batches; scipy's ``lfilter`` for
the lead-lag's difference equation.  The physics of these controllers is validated elsewhere
(test_quickreturn: seed 004 SMC; test_coupler_speed: seed 002; test_linear; test_vibration).
Runs are short (0.05-0.1 s); each distinct composition is compiled once (then cached on disk)."""
import math
from collections import namedtuple
from typing import Literal

import numpy as np
import pytest
from pydantic import Field

import controllers
from controllers.base import Controller, Measurement
from controllers.reference import ConstantSpeed
from controllers.references.coupler_speed import CouplerSpeed
from mjbench import linear as LN
from mjbench import scenario as S
from mjbench.backends import simulate, simulate_many
from mjbench.compiled import law
from mjbench.errors import ParameterError
from mjbench.schema import Q, Strict

pytest.importorskip("numba")

H = 1e-4
BACKENDS = ("reduced", "multibody")


def both_loops(make, backend, t_end, record_dt=H):
    """Run the machine ``make()`` with the CPython loop and with the compiled loop: equal bits."""
    out = {}
    for loop in ("python", "compiled"):
        tr = simulate(make(), backend, t_end, record_dt=record_dt, loop=loop)
        assert tr.meta["loop"] == loop, tr.meta["loop_reason"]
        out[loop] = tr
    np.testing.assert_array_equal(out["python"].data, out["compiled"].data)
    assert np.all(np.isfinite(out["python"].data[:, :10]))
    return out["compiled"]


def replay(ctrl, tr, z, v_max):
    """The controller object (its law, its own P and state) on the kernel's recorded measurements
    (record_dt = h): the voltages it returns at its samples are the recorded ones, bit for bit."""
    from mjbench.kernel import control_every

    every = control_every(ctrl, H)
    ctrl.prepare(every * H)  # the period the kernel used (the co-step when period = 0)
    ctrl.reset()
    y = Measurement(z=z)
    t, q, qd, qdd, I, V = (tr.data[:, k] for k in range(7) if k != 4)
    n = 0
    for k in range(0, tr.n, every):
        a = 0.0 if k == 0 else float(qdd[k])  # the controller's first sample has no previous speed (the record's
        # row 0 holds the forward difference of the first step instead, trajectory.COLUMNS)
        u = ctrl(float(t[k]), y.set(float(t[k]), float(q[k]), float(qd[k]), a, float(I[k])))
        assert min(max(u, -v_max), v_max) == V[k], (k, u, V[k])
        n += 1
    return n


# ----------------------------------------------------------------------------- PID and open loop
PID_VARIANTS = {
    "open ramp": ("incerti2012", "open", ["modes.open.t_ramp=0.03"]),
    "pid Kp·t bounded": ("incerti2012", "pid", ["modes.pid.t_ramp_max=0.02"]),
    # K_p = 150 saturates the 20 V clip at start-up: the anti-windup acts
    "pid v_limit": ("incerti2012", "pid", ["modes.pid.kp_ramp=false", "modes.pid.kp=150", "modes.pid.v_limit=20"]),
}


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("case", list(PID_VARIANTS))
def test_pid_and_open_loop(case, backend):
    name, mode, sets = PID_VARIANTS[case]

    def make():
        return S.make_machine(S.load(name, sets), mode)

    tr = both_loops(make, backend, 0.1)
    m = make()
    assert replay(m.controller, tr, m.drive.z, m.drive.v_max) == tr.n
    if case == "pid v_limit":
        assert np.max(np.abs(tr.voltage)) == 20.0 and m.controller.offset != 0.0  # clipped, windup moved


# ----------------------------------------------------------------------------- SMC
SMC_VARIANTS = {  # started at the set-point speed: the surface is crossed inside the window
    "sign": ["initial.qd0=5.0"],
    "boundary + didt difference": ["initial.qd0=5.0", "modes.smc.boundary=20", "modes.smc.didt=difference"],
    "model false": ["initial.qd0=5.0", "modes.smc.model=false", "modes.smc.boundary=20"],
}


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("case", list(SMC_VARIANTS))
def test_smc(case, backend):
    def make():
        return S.make_machine(S.load("yigit2023", SMC_VARIANTS[case]), "smc")

    tr = both_loops(make, backend, 0.1)
    m = make()
    n = replay(m.controller, tr, m.drive.z, m.drive.v_max)
    assert n == (tr.n - 1) // 10 + 1  # Ts = 1 ms = 10 co-steps
    st = m.controller.state()  # after the replay: the run's own state
    if case == "sign":
        # bang-bang: the switching term K = 1000 V dominates except where s = 0 exactly (t = 0)
        assert st["switches"] > 0 and np.mean(np.abs(tr.voltage) == 48.0) > 0.98
    else:
        assert abs(st["s_last"]) > 0 and not math.isnan(st["t_prev"])


# ----------------------------------------------------------------------------- servo + motion laws
@pytest.mark.parametrize("backend", BACKENDS)
def test_servo_with_bezier_law_reference(backend):
    def make():
        return S.make_machine(S.load("incerti-bezier"), "servo")

    tr = both_loops(make, backend, 0.1)
    m = make()
    assert replay(m.controller, tr, m.drive.z, m.drive.v_max) == tr.n
    law_ = m.controller.reference.motion
    assert np.max(np.abs(law_.velocity(tr.t))) > 1.0  # the move is under way in the window


def test_servo_with_pseudopolynomial_and_shaped_laws():
    """The belt platform tracks its pseudo-polynomial law, and the same law input-shaped (ZV): the
    shaped law is the law :func:`mjbench.motionlaws.shaped_motion` over the base law's."""
    from mjbench import vibration as VB

    def make(shaped=False):
        scn = S.load("incerti-belt")
        if not shaped:
            return S.make_machine(scn, "servo")
        base = scn.law.build()
        m = S.make_machine(scn, "servo")
        A, tj = VB.zv_shaper(m.mechanism.oscillator())
        m.controller.reference = VB.ShapedLaw(base, A, tj).as_reference()
        return m

    for shaped in (False, True):
        tr = both_loops(lambda: make(shaped), "reduced", 0.1)
        m = make(shaped)
        assert replay(m.controller, tr, m.drive.z, m.drive.v_max) == tr.n


# ----------------------------------------------------------------------------- coupler speed
M1 = "hulako2025-model1"
RUNNING = ["initial.q0=1.0", "initial.qd0=5.0"]


def coupler_machine(**ref):
    """Seed-002 Model-1 running at ≈ 5 rad/s from q0 = 1 rad with the given Eq 17 reference."""
    m = S.make_machine(S.load(M1, RUNNING), "pid")
    if ref:
        m.controller.reference = CouplerSpeed(m.mechanism, z=m.drive.z, **ref)
    return m


def _s0():
    return float(S.make_mechanism(S.load(M1)).arc_length(1.0))


COUPLER_VARIANTS = {  # profile → the variants of one composition (derivative, kick, ramp, cap are parameters)
    "constant": [dict(vc=0.1), dict(vc=0.1, derivative="analytic", t_ramp=0.03),
                 dict(vc=0.12, derivative="zero", qd_max=5.5), dict(vc=0.1, kick=True)],
    "piecewise": [dict(vc=0.1, profile="piecewise", s=[0.0, None], v=[0.1, 0.15], blend=0.004),
                  dict(vc=0.1, profile="piecewise", s=[0.0, None], v=[0.1, 0.15], blend=0.004, derivative="analytic"),
                  dict(vc=0.1, profile="piecewise", s=[0.0, None], v=[0.1, 0.15])],
    "table": [dict(vc=0.1, profile="table", s=[0.0, None], v_rel=[1.0, 2.0]),
              dict(vc=0.1, profile="table", s=[0.0, None], v_rel=[1.0, 2.0], derivative="analytic")],
}


def _ref_kw(kw):
    kw = dict(kw)
    if "s" in kw:  # a break 4 mm ahead of the start: the run crosses it (and its blend)
        kw["s"] = [0.0, _s0() + 0.004]
    return kw


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("profile", list(COUPLER_VARIANTS))
def test_pid_with_coupler_speed_reference(profile, backend):
    for kw in COUPLER_VARIANTS[profile]:
        kw = _ref_kw(kw)
        tr = both_loops(lambda: coupler_machine(**kw), backend, 0.06)
        m = coupler_machine(**kw)
        assert replay(m.controller, tr, m.drive.z, m.drive.v_max) == tr.n
        vc = m.controller.reference.vc_at(tr.q)
        if profile != "constant":  # the profile changes V_C inside the window
            assert np.ptp(vc) > 1e-3


def test_python_callable_profile_runs_python_and_equals_the_law():
    """A Python callable V_C(s) has no law: the run uses the CPython loop (and says why); with
    V_C = 0.1 it gives the same bits as the constant profile's law compiled."""
    cc = simulate(coupler_machine(vc=0.1), "reduced", 0.05, record_dt=H, loop="compiled")
    py = simulate(coupler_machine(vc=0.1, profile=lambda s: 0.1), "reduced", 0.05, record_dt=H, loop="compiled")
    assert cc.meta["loop"] == "compiled"
    assert py.meta["loop"] == "python" and "callable" in py.meta["loop_reason"]
    np.testing.assert_array_equal(py.data, cc.data)


# ----------------------------------------------------------------------------- linear.StepReference
@pytest.mark.parametrize("backend", BACKENDS)
def test_pid_with_step_reference(backend):
    def make():
        m = S.make_machine(S.load("incerti2012", ["modes.pid.kp_ramp=false", "modes.pid.kp=40"]), "pid")
        m.controller.reference = LN.StepReference(m.drive.z, 0.0, 3.0, 0.02, dq=0.01, dqd=0.5, h=H)
        return m

    tr = both_loops(make, backend, 0.05)
    m = make()
    assert replay(m.controller, tr, m.drive.z, m.drive.v_max) == tr.n
    ref = m.controller.reference
    ref.reset()
    z = m.drive.z
    for t in (0.02 - 0.6 * H, 0.02 - 0.4 * H, 0.02, 0.03):  # the step is seen within half a co-step
        on = t >= 0.02 - 0.5 * H
        phi, om, acc = ref(t, None)
        assert phi == pytest.approx(z * (3.0 * t + ((0.01 + 0.5 * (t - 0.02)) if on else 0.0)), rel=1e-14)
        assert om == pytest.approx(z * (3.5 if on else 3.0), rel=1e-15) and acc == 0.0


# ----------------------------------------------------------------------------- batches
@pytest.mark.parametrize("backend", BACKENDS)
def test_batch_equals_single_runs(backend):
    """A compiled batch (threads) of PID + coupler-speed variants equals the single runs, and the
    CPython batch equals the compiled one."""
    variants = [dict(vc=0.1), dict(vc=0.12, derivative="analytic"), dict(vc=0.1, kick=True, t_ramp=0.02)]
    res = simulate_many([coupler_machine(**kw) for kw in variants], backend, 0.05, record_dt=H, loop="compiled")
    assert res.meta["loop"] == "compiled" and not res.diverged.any()
    for i, kw in enumerate(variants):
        single = simulate(coupler_machine(**kw), backend, 0.05, record_dt=H, loop="compiled")
        np.testing.assert_array_equal(res.trajectory(i).data, single.data)
    py = simulate_many([coupler_machine(**kw) for kw in variants], backend, 0.05, record_dt=H, loop="python")
    assert py.meta["loop"] == "python"
    np.testing.assert_array_equal(py.data, res.data)
    assert not np.array_equal(res.data[0], res.data[1])


# ----------------------------------------------------------------------------- a controller of your own
LeadLagP = namedtuple("LeadLagP", "b0 b1 a1 z")


@law
def lead_lag_law(t, q, qd, qdd, I, phi_r, om_r, acc_r, P, S):
    """u_k = b0·e_k + b1·e_{k−1} − a1·u_{k−1}, e = φ̇_ref − φ̇ (motor side); S = [e_{k−1}, u_{k−1}]."""
    e = om_r - P.z * qd
    u = P.b0 * e + P.b1 * S[0] - P.a1 * S[1]
    S[0] = e
    S[1] = u
    return u


def tustin_lead_lag(K, wz, wp, T):
    """K·(1 + s/ωz)/(1 + s/ωp) by Tustin's rule at period T → (b0, b1, a1)."""
    c = 2.0 / T
    den = 1.0 + c / wp
    return K * (1.0 + c / wz) / den, K * (1.0 - c / wz) / den, (1.0 - c / wp) / den


class LeadLagParams(Strict):
    type: Literal["test-leadlag"] = "test-leadlag"
    K: Q("gain_v_per_rad_s") = Field(description="DC gain [V·s/rad]")
    wz: Q("gain_per_s", gt=0.0) = Field(description="zero [rad/s]")
    wp: Q("gain_per_s", gt=0.0) = Field(description="pole [rad/s]")
    omega0: Q("angular_velocity") = Field(description="motor-speed set-point")


@controllers.register
class LeadLag(Controller):
    """A speed lead-lag K·(1 + s/ωz)/(1 + s/ωp) discretised by Tustin at the sample period."""

    type_name = "test-leadlag"
    Params = LeadLagParams
    STATE = ("e_prev", "u_prev")
    law = lead_lag_law

    def __init__(self, K, wz, wp, omega0):
        self.K, self.wz, self.wp = float(K), float(wz), float(wp)
        self.reference = ConstantSpeed(omega0)
        self.reset()

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        return cls(p.K, p.wz, p.wp, p.omega0)

    def parameters(self, T, z):
        if not T > 0:
            raise ParameterError("test-leadlag needs its sample period (prepare(T) for Python calls)")
        return LeadLagP(*tustin_lead_lag(self.K, self.wz, self.wp, T), float(z))


def test_a_controller_defined_in_a_test_file_runs_compiled():
    from scipy.signal import lfilter

    def make():
        m = S.make_machine(S.load("incerti2012"), "open")
        m.controller = controllers.from_dict({"type": "test-leadlag", "K": 0.3, "wz": 20.0, "wp": 80.0,
                                              "omega0": 30.0}, m.drive, m.mechanism)
        return m

    tr = both_loops(make, "reduced", 0.05)
    assert tr.meta["loop"] == "compiled"
    # the recorded voltages are the lead-lag's difference equation on the recorded speed error
    b0, b1, a1 = tustin_lead_lag(0.3, 20.0, 80.0, H)  # period 0: T = the co-step h
    e = 30.0 - tr.omega
    np.testing.assert_allclose(tr.voltage, lfilter([b0, b1], [1.0, a1], e), rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(tr.voltage)) < 48.0  # not clipped: the filter is all there is
    m = make()
    assert replay(m.controller, tr, m.drive.z, m.drive.v_max) == tr.n
    # no linear() written: the counterpart comes from the law itself (mjbench.linearise), equal to the
    # Tustin transfer function of the difference equation, (b0 + b1·z⁻¹)/(1 + a1·z⁻¹) on z·(q̇_ref − q̇)
    import control as ct

    m = make()
    C = m.controller.linear(m, LN.operating_point(m, 0.0, 3.0), H, H)
    w = np.logspace(0, np.log10(0.9 * np.pi / H), 40)
    want = float(m.drive.z) * np.asarray(ct.frequency_response(ct.tf([b0, b1], [1.0, a1], H), w).complex).ravel()
    got = np.asarray(ct.frequency_response(C[0, LN.LAW_INPUTS.index("qd_ref")], w).complex).ravel()
    np.testing.assert_allclose(got, want, rtol=1e-6)
    assert list(C.state_labels) == ["e_prev", "u_prev"]  # the direct form's two states, named by STATE
