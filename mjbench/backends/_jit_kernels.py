"""The numba kernels of :mod:`mjbench.backends._jit` (imported only when the compiled step is used)."""
import math

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic


@intrinsic
def _call_pp(typingctx, fn, a, b):
    """``fn(a, b)`` for a C function ``void fn(void*, void*)`` given by its address (MuJoCo's
    ``mj_step(const mjModel*, mjData*)``): the addresses are run-time integers, so a function using
    it is cached on disk like any other (a ctypes function object as an argument is not)."""
    sig = types.void(types.intp, types.intp, types.intp)

    def codegen(context, builder, signature, args):
        vp = ir.IntType(8).as_pointer()
        f = builder.inttoptr(args[0], ir.FunctionType(ir.VoidType(), [vp, vp]).as_pointer())
        builder.call(f, [builder.inttoptr(args[1], vp), builder.inttoptr(args[2], vp)])
        return context.get_dummy_value()
    return sig, codegen


@numba.njit(cache=True, inline="always")
def _acc(qs, vv, ti, Jai, ci, ki, ni, bi, C, m, viscous):
    u = qs * ki
    fl = np.floor(u)  # a float, as the NumPy path (math.floor would return an integer)
    f = u - fl
    j = (np.int64(fl) % ni) + bi
    J = ((C[j, 3 * m] * f + C[j, 2 * m]) * f + C[j, m]) * f + C[j, 0]
    H = ((C[j, 3 * m + 1] * f + C[j, 2 * m + 1]) * f + C[j, m + 1]) * f + C[j, 1]
    E = ((C[j, 3 * m + 2] * f + C[j, 2 * m + 2]) * f + C[j, m + 2]) * f + C[j, 2]
    if viscous:
        D = ((C[j, 3 * m + 3] * f + C[j, 2 * m + 3]) * f + C[j, m + 3]) * f + C[j, 3]
        return (ti - (ci + D) * vv - E - H * vv * vv) / (Jai + J)
    return (ti - ci * vv - E - H * vv * vv) / (Jai + J)


@numba.njit(cache=True, inline="always")
def _rk4(qi, vi, ti, Jai, ci, ki, ni, bi, CT, m, viscous, h):
    """One RK4 step of one simulation with the torque ti held → (q, q̇); NaN for a non-finite
    state (as the NumPy path and the scalar path's failed table lookup)."""
    if not (math.isfinite(qi) and math.isfinite(vi)):
        return math.nan, math.nan
    h2 = 0.5 * h
    h6 = h / 6.0
    a1 = _acc(qi, vi, ti, Jai, ci, ki, ni, bi, CT, m, viscous)
    v2 = vi + h2 * a1
    a2 = _acc(qi + h2 * vi, v2, ti, Jai, ci, ki, ni, bi, CT, m, viscous)
    v3 = vi + h2 * a2
    a3 = _acc(qi + h2 * v2, v3, ti, Jai, ci, ki, ni, bi, CT, m, viscous)
    v4 = vi + h * a3
    a4 = _acc(qi + h * v3, v4, ti, Jai, ci, ki, ni, bi, CT, m, viscous)
    return qi + h6 * (vi + 2.0 * v2 + 2.0 * v3 + v4), vi + h6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)


@numba.njit(cache=True)
def step(q, v, tau, CT, base, nn, kk, Ja, c, h, m, viscous):
    """Advance every simulation one RK4 step in place (see the module docstring)."""
    for i in range(q.shape[0]):
        q[i], v[i] = _rk4(q[i], v[i], tau[i], Ja[i], c[i], kk[i], nn[i], base[i], CT, m, viscous, h)


@numba.njit(cache=True)
def run_pid(q0, qd0, I0, CT, base, nn, kk, Ja, c, m, viscous,
            R, k_m, z, T_0, lam, w, decay, v_max, i_max,
            kind, kp, ki, kd, ramp, tm, v_lim, omega0, phi0, volt, t_ramp, every,
            mj, mj_step, m_addr, d_addr, qpos, qvel, qfrc, qa, va, vd, sx, cidx, warn, bad,
            h, nsteps, decim, max_speed, max_current, out, nrows, t_div, state):
    """The co-step kernel (:func:`mjbench.kernel.run`) for an ideal drive, the speed PID with a
    constant-speed reference (:class:`controllers.pid.PID`, ``kind`` 0) or the open-loop voltage
    (:class:`controllers.openloop.ConstantVoltage`, ``kind`` 1) and the tabulated rigid reduced plant,
    compiled: every simulation i runs its whole loop here (see :mod:`mjbench.backends.fused`).
    With ``mj`` the plant is instead one MuJoCo model (N = 1,
    :class:`~mjbench.backends.multibody.MultibodyPlant`): the torque goes into ``qfrc[vd]``, the
    step is MuJoCo's own ``mj_step`` (C address ``mj_step``, model and data addresses), the state is
    read from ``qpos[qa]``, ``qvel[va]``, the loop closure from the connect sites' positions ``sx``
    (index pairs ``cidx``) and the instability flag from MuJoCo's warning counters ``warn[bad]``.
    Each line mirrors, operation for operation and in the same order, the Python code named in
    its comment, so the record is the same bits as ``kernel.run`` (tests/test_fused.py).
    ``v_max``/``i_max``/``v_lim`` = inf: no limit; ``phi0`` NaN: reference started from the first
    measurement.  Outputs: ``out`` (N, nrec, 11) rows, ``nrows``, ``t_div`` (NaN: no divergence)
    and ``state`` (N, 4) = q, q̇, I, V at the divergence."""
    inv_h = 1.0 / h
    for i in range(q0.shape[0]):
        Jai, ci, ki_, ni, bi = Ja[i], c[i], kk[i], nn[i], base[i]
        Ri, kmi, zi, T0i, lami, wi, di = R[i], k_m[i], z[i], T_0[i], lam[i], w[i], decay[i]
        vmax, imax, vl = v_max[i], i_max[i], v_lim[i]
        kpi, kii, kdi, tmi, om0, ev = kp[i], ki[i], kd[i], tm[i], omega0[i], every[i]
        q = q0[i]
        qd = qd0[i]
        I = I0[i]
        qd_prev = qd
        V = 0.0
        offset = 0.0
        eprev = 0.0
        have_prev = False
        phi_start = phi0[i]
        k = 0
        for n in range(nsteps + 1):
            t = n * h
            qdd = (qd - qd_prev) * inv_h
            if n % ev == 0 and kind[i] == 1:
                # ConstantVoltage.__call__
                tr = t_ramp[i]
                u = volt[i] * (t / tr) if (tr > 0 and t < tr) else volt[i]
                # DCMotorDrive.limit
                if vmax != math.inf:
                    u = -vmax if u < -vmax else (vmax if u > vmax else u)
                V = u
            elif n % ev == 0:
                # Measurement.set
                phi = zi * q
                omega = zi * qd
                omega_dot = zi * qdd
                # ConstantSpeed.__call__
                if math.isnan(phi_start):
                    phi_start = phi - om0 * t
                phi_r = phi_start + om0 * t
                acc_r = 0.0 * om0
                # PID.__call__
                e = om0 - omega
                epos = phi_r - phi
                prev = eprev if have_prev else epos
                if ramp[i]:
                    kpt = kpi * (t if t < tmi else tmi)
                else:
                    kpt = kpi
                u = kpt * e + kii * (epos - offset) + kdi * (acc_r - omega_dot)
                if vl != math.inf:
                    d = epos - prev
                    if (u > vl and d > 0) or (u < -vl and d < 0):
                        offset += d
                        u -= kii * d
                    u = vl if u > vl else (-vl if u < -vl else u)
                eprev = epos
                have_prev = True
                # DCMotorDrive.limit
                if vmax != math.inf:
                    u = -vmax if u < -vmax else (vmax if u > vmax else u)
                V = u
            if n % decim == 0:
                if not (abs(qd) < max_speed and abs(I) < max_current and math.isfinite(V)
                        and math.isfinite(q)) or (mj and warn[bad] != 0):
                    t_div[i] = t
                    state[i, 0] = q
                    state[i, 1] = qd
                    state[i, 2] = I
                    state[i, 3] = V
                    break
                om = zi * qd
                s = 1.0 if om > 0 else (-1.0 if om < 0 else 0.0)
                r = out[i, k]
                r[0] = t
                r[1] = q
                r[2] = qd
                r[3] = qdd
                r[4] = om
                r[5] = I
                r[6] = V
                r[7] = zi * (kmi * I - (T0i * s + lami * om))  # DCMotorDrive.crank_torque
                r[8] = kmi * I * om
                r[9] = V * I
                if mj:  # Mechanism.closure_reader: the largest connect-site offset [m]
                    cl = 0.0
                    for p in range(cidx.shape[0]):
                        v = abs(sx[cidx[p, 0]] - sx[cidx[p, 1]])
                        if v > cl:
                            cl = v
                    r[10] = cl
                else:
                    r[10] = 0.0
                k += 1
            if n == nsteps:
                break
            # DCMotorDrive.step_torque: z·(k_m·Ī − T_0·sgn(z·q̇)), Ī the step-mean current
            om = zi * qd
            i_ss = (V - kmi * om) / Ri
            if T0i == 0.0:
                tau = zi * (kmi * (i_ss + (I - i_ss) * wi))
            else:
                s = 1.0 if om > 0 else (-1.0 if om < 0 else 0.0)
                tau = zi * (kmi * (i_ss + (I - i_ss) * wi) - T0i * s)
            if mj:  # MultibodyPlant.advance: the held torque on the drive joint, one mj_step
                qfrc[vd] = tau
                _call_pp(mj_step, m_addr, d_addr)
                q1 = qpos[qa]
                qd1 = qvel[va]
            else:  # ReducedPlant.advance (the table's RK4 step, as `step` above)
                q1, qd1 = _rk4(q, qd, tau, Jai, ci, ki_, ni, bi, CT, m, viscous, h)
            qd_prev = qd
            # DCMotorDrive.current_step with the mean of φ̇_n and φ̇_{n+1}
            om = 0.5 * zi * (qd + qd1)
            i_ss = (V - kmi * om) / Ri
            I = i_ss + (I - i_ss) * di
            if imax != math.inf:
                I = -imax if I < -imax else (imax if I > imax else I)
            q = q1
            qd = qd1
        nrows[i] = k
