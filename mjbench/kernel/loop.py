"""The co-step loop, written once: :func:`_loop`, a template over the machine's axes and controllers.

One co-simulation step h of one run, in this order (docs/engine.md):

1. measurement: t_n, q_n, q̇_n from the plant, q̈_n = (q̇_n − q̇_{n−1})/h (0 at the first sample; the
   record's row 0 gets the forward difference of the first step once it is taken), I_n;
2. at each control sample (every ``controller.period``, a multiple of h): per axis the sensor
   (encoder, speed estimate, noise; ideal: the exact values) into the signal array, then every
   axis's reference, then every controller (each law reads and writes *named signals*:
   :mod:`mjbench.signals`, wired by :mod:`mjbench.kernel.wiring`), then per axis the clip to
   [u_min, u_max] and the one-sample delay; the command is held in between;
3. every ``record_dt``: the divergence check and one record row (preallocated), with the interval
   statistics (extremes of q̇, I, the applied voltage and torque over every co-step since the last
   row);
4. per axis: the current loop (a current reference → voltage), the amplifier (ideal, averaged or
   switching PWM), the motor torque from the exact step-mean current, the gear efficiency;
5. one plant step with every axis's torque held (MuJoCo's ``mj_step``, or RK4 on the reduced model);
6. per axis: I_{n+1} by the drive's exact update with the mean of φ̇_n and φ̇_{n+1}; the statistics.

The interval statistics' running extremes live in the kernel state ``ks`` (``ks[KA_a + KS_W_MAX]``
…), not in local variables: 16 per axis would be as many more live values, which the compiled loop
spills around its co-step anyway (in memory they cost a load and a compare each; the five-bar's
reduced run ≈ 3.5 % shorter, the same values).

**Template.**  ``for _a in AXES:`` repeats its body for each axis and ``for _c in CONTROLLERS:`` for
each controller, with ``_a`` (``_c``) the axis (controller) index and every name ending in ``_a``
(``_c``) renamed for it (``q_a`` → ``q_0``, ``CTRL_c`` → ``CTRL_0``): :func:`.unroll.source` unrolls the
template for a composition (one axis and one controller: the loop of a one-motor machine).  Every
formula is a law of a component; the slot functions, flags and layout offsets are globals of the
module the source runs in (:mod:`mjbench.kernel.program`): numba treats them as constants (dead
branches pruned, laws inlined); CPython looks them up.  CPython and numba execute the same unrolled
source, so they give the same bits.
"""
from __future__ import annotations

import textwrap

from ..compiled import clip, isfinite, track  # noqa: F401 - globals of the loop

MAX_SPEED = 1e4  #: rad/s: beyond this an input speed is a diverged simulation, not physics
MAX_CURRENT = 1e5  #: A


def _loop(n0, n1, K, X):
    """Co-steps n0 … n1−1 of one run; returns the next step index.  State between calls lives in
    ``K.ks`` and the components' state arrays; a divergence sets ``K.div[0]`` and stops."""
    h = K.h
    inv_h = 1.0 / h
    nsteps = K.nsteps
    decim = K.decim
    every = K.every
    ks = K.ks
    out = K.out
    st = K.stats
    ncol = K.ncol
    nst = K.nstat
    div = K.div
    Y = K.y
    TAU = K.tau
    QO = K.qo
    Pp = X.plant_P
    Sp = X.plant_S
    k = int(ks[KS_K])
    for _c in CONTROLLERS:
        Pc_c = X.ctrl_P[_c]
        Sc_c = X.ctrl_S[_c]
    for _a in AXES:
        Pd_a = X.drive[_a]
        Psen_a = X.sense_P[_a]
        Ssen_a = X.sense_S[_a]
        Pref_a = X.ref_P[_a]
        Sref_a = X.ref_S[_a]
        Pcl_a = X.cloop_P[_a]
        Scl_a = X.cloop_S[_a]
        Pamp_a = X.amp_P[_a]
        Samp_a = X.amp_S[_a]
        Peff_a = X.eff_P[_a]
        z_a = Pd_a.z
        u_lo_a = Y[SUMIN_a]
        u_hi_a = Y[SUMAX_a]
        ka_a = KA_a
        q_a = ks[ka_a + KS_Q]
        qd_a = ks[ka_a + KS_QD]
        qd_prev_a = ks[ka_a + KS_QD_PREV]
        I_a = ks[ka_a + KS_I]
        u_a = ks[ka_a + KS_U]
        dm_a = ks[ka_a + KS_DM]
        dmd_a = ks[ka_a + KS_DMD]
        Vb_a = ks[ka_a + KS_VB]
        Ibar_a = ks[ka_a + KS_IBAR]
        ilo_a = ks[ka_a + KS_ILO]
        ihi_a = ks[ka_a + KS_IHI]
        qm_a = ks[ka_a + KS_QM]
        qdm_a = ks[ka_a + KS_QDM]
        qddm_a = ks[ka_a + KS_QDDM]
        pend_a = ks[ka_a + KS_PEND]
        V_a = ks[ka_a + KS_V]
        tq_a = ks[ka_a + KS_TQ]
    n = n0
    at_ctrl = n0 % every  # steps since the last control sample and the last record row (counters:
    at_rec = n0 % decim  # no integer division per step)
    while n < n1:
        t = n * h
        for _a in AXES:
            qdd_a = (qd_a - qd_prev_a) * inv_h
        if at_ctrl == 0:
            # ---- sample: sensors → references → controllers → clip → delay (signals by name)
            Y[SI_T] = t
            for _a in AXES:
                if HAS_SENSE_a:
                    qm_a, qdm_a, qddm_a, Im_a = SENSE_a(t, q_a, qd_a, qdd_a, I_a, dm_a, dmd_a, Psen_a, Ssen_a)
                else:
                    qm_a = q_a
                    qdm_a = qd_a
                    qddm_a = qdd_a
                    Im_a = I_a
                Y[SQ_a] = qm_a
                Y[SQD_a] = qdm_a
                Y[SQDD_a] = qddm_a
                Y[SI_a] = Im_a
                Y[SV_a] = Vb_a
                Y[STAU_a] = tq_a
                Y[SUH_a] = u_a
            for _a in AXES:
                if HAS_REF_a:
                    REF_a(Y, Pref_a, Sref_a)
            for _c in CONTROLLERS:
                CTRL_c(Y, Pc_c, Sc_c)
            for _a in AXES:
                u_a = clip(Y[SU_a], u_lo_a, u_hi_a)
                if HAS_DELAY_a:
                    u_now_a = u_a
                    u_a = pend_a
                    pend_a = u_now_a
        if at_rec == 0:
            # ---- divergence check, then one record row and its interval statistics
            bad = 0
            for _a in AXES:
                if bad == 0 and not (abs(qd_a) < MAX_SPEED and abs(I_a) < MAX_CURRENT and isfinite(u_a)
                                     and isfinite(q_a)):
                    bad = 1 + _a
            if bad == 0 and HAS_UNSTABLE and UNSTABLE(Pp, Sp):
                bad = 1
            if bad > 0:
                div[0] = 1.0
                div[1] = t
                div[6] = bad - 1
                for _a in AXES:
                    if bad == 1 + _a:
                        div[2] = q_a
                        div[3] = qd_a
                        div[4] = I_a
                        div[5] = u_a
                break
            b = k * ncol
            out[b + C_T] = t
            for _a in AXES:
                w_a = z_a * (qd_a + dmd_a)  # motor speed φ̇ (a compliant gear: the motor's own)
                if HAS_CLOOP_a:
                    volt_a = Vb_a  # the current loop's output (its reference is recorded as current_ref_A)
                elif AMP_MODE_a == 0:
                    volt_a = DLIMIT_a(I_a, u_a, w_a, Pd_a)  # what the (current-limiting) amplifier applies next
                else:
                    volt_a = u_a  # the command (the PWM bridge's mean voltage is voltage_bridge_V)
                c = b + CA_a
                out[c + C_Q] = q_a
                out[c + C_QD] = qd_a
                out[c + C_QDD] = qdd_a
                out[c + C_W] = w_a
                DREC_a(out, c + C_DRV, I_a, volt_a, w_a, Pd_a)  # current, voltage, torque, powers
            out[b + C_CLOSURE] = CLOSURE(Pp, Sp) if HAS_CLOSURE else 0.0
            if NEXTRA > 0:
                PWRITE(out, b + C_EXTRA, Pp, Sp)
            for _a in AXES:
                c = b + CT_a
                if SENSE_COLS_a:
                    out[c] = qm_a
                    out[c + 1] = qdm_a
                    out[c + 2] = qddm_a
                    c += 3
                if AMP_COLS_a:
                    out[c] = Vb_a
                    out[c + 1] = Ibar_a
                    c += 2
                if MINMAX_COLS_a:
                    out[c] = ilo_a
                    out[c + 1] = ihi_a
                    c += 2
                if IREF_COL_a:
                    out[c] = u_a
            sb = k * nst
            for _a in AXES:
                e = sb + SA_a
                for j in range(NSTAT_AXIS):  # (the extremes' layout in ks is the statistics row's)
                    st[e + j] = ks[KA_a + KS_W_MAX + j]
                # the next interval starts at this sample (its state belongs to both; the applied
                # voltage and torque to the steps after it only)
                ks[KA_a + KS_W_MAX] = w_a
                ks[KA_a + KS_W_MIN] = w_a
                ks[KA_a + KS_W_T_MAX] = t
                ks[KA_a + KS_W_T_MIN] = t
                ks[KA_a + KS_I_MAX] = I_a
                ks[KA_a + KS_I_MIN] = I_a
                ks[KA_a + KS_I_T_MAX] = t
                ks[KA_a + KS_I_T_MIN] = t
                ks[KA_a + KS_VB_MAX] = -math.inf
                ks[KA_a + KS_VB_MIN] = math.inf
                ks[KA_a + KS_TQ_MAX] = -math.inf
                ks[KA_a + KS_TQ_MIN] = math.inf
            k += 1
        if n == nsteps:
            n += 1
            break
        # ---- per axis: current loop → amplifier → motor torque → gear; the plant step; the currents
        for _a in AXES:
            if HAS_CLOOP_a:
                V_a = CLOOP_a(n, u_a, I_a, Pcl_a, Scl_a)
            else:
                V_a = u_a
            w0_a = z_a * (qd_a + dmd_a)
            Iend_a = 0.0
            if AMP_MODE_a == 2:
                Ibar_a, Iend_a, Vb_a, ilo_a, ihi_a = AMP_a(t, I_a, V_a, w0_a, Pamp_a, Samp_a)
            else:
                if AMP_MODE_a == 1:
                    Vb_a = AMP_a(t, I_a, V_a, w0_a, Pamp_a, Samp_a)
                else:
                    Vb_a = DLIMIT_a(I_a, V_a, w0_a, Pd_a)
                Ibar_a = DMEAN_a(I_a, Vb_a, w0_a, Pd_a)
            Tm_a = DTORQUE_a(Ibar_a, w0_a, Pd_a)
            if HAS_EFF_a:
                Tm_a = EFF_a(Tm_a, w0_a, Peff_a)
            tq_a = z_a * Tm_a
            TAU[_a] = tq_a
        PLANT(TAU, t, Pp, Sp, QO)
        t1 = t + h
        for _a in AXES:
            q1_a = QO[4 * _a]
            qd1_a = QO[4 * _a + 1]
            dm_a = QO[4 * _a + 2]
            dmd_a = QO[4 * _a + 3]
            if n == 0 and k > 0:  # row 0's acceleration: the forward difference of the first step
                out[CA_a + C_QDD] = (qd1_a - qd_a) * inv_h
            qd_prev_a = qd_a
            wm_a = 0.5 * (w0_a + z_a * (qd1_a + dmd_a))
            if AMP_MODE_a == 2:
                I_a = AMP_END_a(Iend_a, w0_a, wm_a, Pamp_a)
            else:
                I_a = DSTEP_a(I_a, Vb_a, wm_a, Pd_a)
            q_a = q1_a
            qd_a = qd1_a
            w1_a = z_a * (qd_a + dmd_a)
            track(ks, KA_a + KS_W_MAX, w1_a, t1)  # (the speed and current at the step's end,
            track(ks, KA_a + KS_I_MAX, I_a, t1)  # the voltage and torque applied over it)
            track(ks, KA_a + KS_VB_MAX, Vb_a, t)
            track(ks, KA_a + KS_TQ_MAX, tq_a, t)
        at_ctrl += 1
        if at_ctrl == every:
            at_ctrl = 0
        at_rec += 1
        if at_rec == decim:
            at_rec = 0
        n += 1
    ks[KS_K] = k
    for _a in AXES:
        ka_a = KA_a
        ks[ka_a + KS_Q] = q_a
        ks[ka_a + KS_QD] = qd_a
        ks[ka_a + KS_QD_PREV] = qd_prev_a
        ks[ka_a + KS_I] = I_a
        ks[ka_a + KS_U] = u_a
        ks[ka_a + KS_DM] = dm_a
        ks[ka_a + KS_DMD] = dmd_a
        ks[ka_a + KS_VB] = Vb_a
        ks[ka_a + KS_IBAR] = Ibar_a
        ks[ka_a + KS_ILO] = ilo_a
        ks[ka_a + KS_IHI] = ihi_a
        ks[ka_a + KS_QM] = qm_a
        ks[ka_a + KS_QDM] = qdm_a
        ks[ka_a + KS_QDDM] = qddm_a
        ks[ka_a + KS_PEND] = pend_a
        ks[ka_a + KS_V] = V_a
        ks[ka_a + KS_TQ] = tq_a
    return n


def def_source(filename: str, line: int):
    """(the text of the function whose ``def``, or its first decorator, is at 1-based ``line`` of
    ``filename``: its ``def`` line and every following line that is blank or indented deeper, dedented;
    the 1-based line of that ``def``), or None if the file cannot be read.  What ``inspect.getsource``
    gives, without tokenizing the file (≈ 10 ms); also :mod:`.inline`'s reader of the laws."""
    try:
        with open(filename, encoding="utf-8") as f:
            lines = f.read().splitlines(keepends=True)
    except (OSError, UnicodeDecodeError):
        return None
    j = line - 1
    while j < len(lines) and not lines[j].lstrip().startswith("def "):
        j += 1  # (decorators)
    if j >= len(lines):
        return None
    indent = len(lines[j]) - len(lines[j].lstrip())
    end = j + 1
    while end < len(lines) and (not lines[end].strip() or len(lines[end]) - len(lines[end].lstrip()) > indent):
        end += 1
    while not lines[end - 1].strip():
        end -= 1
    return textwrap.dedent("".join(lines[j:end])), j + 1


#: the template's source as loaded (the compiled loop is generated from exactly the code CPython
#: runs, even if the file changes on disk while this process lives)
TEMPLATE = def_source(__file__, _loop.__code__.co_firstlineno)[0]


__all__ = ["MAX_SPEED", "MAX_CURRENT", "TEMPLATE"]
