"""Generic linearisation: any controller law is linearised numerically from its compiled form
(mjbench.linearise), its state included.  Where a hand-written counterpart exists (PID, servo,
SMC in its boundary layer) the two agree to 1e-6; a controller written here with a state and no
linear() gets its counterpart, checked against its difference equation solved by hand, and
``linearize`` gives margins for it; the generic hold offset equals the hand-written ones.

Independent paths: the hand-written matrices (controllers/*.linear), a transfer function of the
difference equation written out here (python-control's ``tf``), the law itself simulated on a step."""
from __future__ import annotations

import math
from collections import namedtuple

import control as ct
import numpy as np
import pytest

from mjbench import linear as LN
from mjbench import scenario as S
from mjbench.compiled import law
from mjbench.control import Controller, LAW_INPUTS
from mjbench.kernel import control_every
from mjbench.linearise import hold_offset, law_counterpart

H = 1e-4


def _freq(sys_, w):
    """The frequency response of every input → V at frequencies w [rad/s] (complex (n_in, len(w)))."""
    out = []
    for j in range(sys_.ninputs):
        out.append(np.asarray(ct.frequency_response(sys_[0, j], w).complex).reshape(-1))
    return np.array(out)


def _agree(a, b, tol=1e-6):
    w = np.logspace(-1, np.log10(0.9 * math.pi / a.dt), 60)
    Fa, Fb = _freq(a, w), _freq(b, w)
    scale = max(np.max(np.abs(Fa)), 1e-300)
    err = np.max(np.abs(Fa - Fb)) / scale
    assert err <= tol, err
    return err


CASES = {
    "pid": ("incerti2012", "pid", ["modes.pid.kp_ramp=false", "modes.pid.kp=2"], 0.3, 30.0),
    "pid Kp·t at t*": ("incerti2012", "pid", [], 0.3, 30.0),
    "pid sampled, geared": ("press-slidercrank", "pi", ["modes.pi.period=1e-3"], 0.2, 3.0),
    "servo": ("incerti-bezier", "servo", [], 0.2, 5.0),
    "smc boundary": ("yigit2023", "smc", ["modes.smc.boundary=20"], 0.7, 5.0),
    "smc boundary, di/dt difference": ("yigit2023", "smc", ["modes.smc.boundary=20", "modes.smc.didt=difference"],
                                       0.7, 5.0),
    "smc boundary, no model": ("yigit2023", "smc", ["modes.smc.boundary=20", "modes.smc.model=false"], 0.7, 5.0),
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_generic_counterpart_equals_the_hand_written_one(case):
    name, mode, sets, q, qd = CASES[case]
    m = S.make_machine(S.load(name, sets), mode)
    op = LN.operating_point(m, q=q, qd=qd, t=0.05)
    T = control_every(m.controller, H) * H
    hand = m.controller.linear(m, op, T, H)
    gen = law_counterpart(m.controller, m, op, T, H)
    assert hand.ninputs == gen.ninputs == len(LAW_INPUTS)
    assert gen.nstates == hand.nstates  # the same dynamics, no spurious state
    cols = list(range(len(LAW_INPUTS)))
    if mode == "smc":  # SMC's set-point ω_d is a parameter, not a signal: the hand-written counterpart maps it
        # to qd_ref by convention, the law (and so the generic one) reads no reference: the measurement only
        cols = [LAW_INPUTS.index(k) for k in ("q", "qd", "qd_prev", "I")]
    _agree(hand[:, cols], gen[:, cols], 1e-6)
    D = np.asarray(hand.D)[:, cols]
    np.testing.assert_allclose(np.asarray(gen.D)[:, cols], D, rtol=1e-6, atol=1e-6 * np.max(np.abs(D)))


@pytest.mark.parametrize("case", ["pid", "servo"])
def test_the_generic_hold_offset_equals_the_hand_written_one(case):
    name, mode, sets, q, qd = CASES[case]
    m = S.make_machine(S.load(name, sets), mode)
    op = LN.operating_point(m, q=q, qd=qd, t=0.05)
    hand = type(m.controller).hold_offset(m.controller, m, op)
    gen = hold_offset(m.controller, m, op)
    assert gen == pytest.approx(hand, rel=1e-9, abs=1e-12)


# ============================================================================ a controller with a state
LLP = namedtuple("LLP", "kp a b z")


@law(outputs=("u",))
def lead_lag_law(qd, om_ref, P, S):
    """A first-order observer-like filter on the speed error, e_k = ω_ref − z·q̇:
    x_{k+1} = a·x_k + (1 − a)·e_k, u_k = K_p·(e_k + b·x_k) (no hand-written linear())."""
    e = om_ref - P.z * qd
    u = P.kp * (e + P.b * S[0])
    S[0] = P.a * S[0] + (1.0 - P.a) * e
    return u


class LeadLag(Controller):
    type_name = "lead_lag_generic_test"
    STATE = ("x",)
    law = lead_lag_law

    def __init__(self, kp, a, b, omega0, period=1e-3):
        from mjbench.control import ConstantSpeed

        self.kp, self.a, self.b, self.period = kp, a, b, period
        self.reference = ConstantSpeed(omega0)

    @classmethod
    def from_params(cls, p, **kw):  # pragma: no cover - built in code
        raise NotImplementedError

    def parameters(self, T, z):
        return LLP(self.kp, self.a, self.b, z)


def test_a_controller_without_linear_gets_its_counterpart_from_its_law():
    m = S.make_machine(S.load("incerti2012"), "pid")
    m.controller = LeadLag(0.8, 0.6, 0.5, 30.0)
    op = LN.operating_point(m, q=0.2, qd=30.0)
    T = 1e-3
    gen = m.controller.linear(m, op, T, H)  # the default capability: law_counterpart
    # by hand: U(z)/E(z) = K_p·(1 + b·(1 − a)/(z − a)), e = z_g·(qd_ref − qd)
    zg = float(m.drive.z)
    want = ct.tf([0.8, 0.8 * (-0.6 + 0.5 * 0.4)], [1.0, -0.6], T)
    w = np.logspace(-1, np.log10(0.9 * math.pi / T), 50)
    got_ref = np.asarray(ct.frequency_response(gen[0, LAW_INPUTS.index("qd_ref")], w).complex).reshape(-1)
    got_qd = np.asarray(ct.frequency_response(gen[0, LAW_INPUTS.index("qd")], w).complex).reshape(-1)
    exp = zg * np.asarray(ct.frequency_response(want, w).complex).reshape(-1)
    np.testing.assert_allclose(got_ref, exp, rtol=1e-7)
    np.testing.assert_allclose(got_qd, -exp, rtol=1e-7)
    assert gen.nstates == 1 and list(gen.state_labels) == ["x"]
    # it does not read the angle, the acceleration or the current
    for k in ("q_ref", "qdd_ref", "q", "qd_prev", "I"):
        assert np.allclose(_freq(gen[0, LAW_INPUTS.index(k)], w[:3]), 0.0)


def test_linearize_gives_margins_for_a_controller_written_by_a_user(monkeypatch):
    """Margins from the generic counterpart equal those from the difference equation's matrices
    written by hand (the same plant, python-control's loop)."""
    m = S.make_machine(S.load("incerti2012"), "pid")
    kp, a, b = 10.0, 0.6, 0.5
    m.controller = LeadLag(kp, a, b, 30.0)
    op = LN.operating_point(m, q=0.2, qd=30.0)
    _, mg = LN.analyse(m, op, H, "reduced")
    assert mg.stable and math.isfinite(mg.phase_margin_deg) and mg.phase_margin_deg > 0 and mg.Ms >= 1.0
    zg = float(m.drive.z)
    e = zg * np.array([[0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0]])

    def by_hand(self, machine, op, T, h, angle="state"):
        return ct.ss([[a]], (1 - a) * e, [[kp * b]], kp * e, T, inputs=list(LAW_INPUTS), outputs=["V"],
                     states=["x"])

    monkeypatch.setattr(LeadLag, "linear", by_hand)
    _, mh = LN.analyse(m, op, H, "reduced")
    for k in ("phase_margin_deg", "gain_margin_dB", "Ms", "w_gain_crossover_rad_s", "bandwidth_rad_s"):
        assert getattr(mg, k) == pytest.approx(getattr(mh, k), rel=1e-6), k
