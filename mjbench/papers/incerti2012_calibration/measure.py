"""The figures a set of values gives: χ open loop, χ of the PID window, the mean open-loop speed
(one scenario, or many at once on the batched backends)."""
from __future__ import annotations

from mjbench import metrics as M
from mjbench import scenario as S
from mjbench.backends import simulate, simulate_many
import numpy as np

from .params import TARGETS


# --------------------------------------------------------------------------- model evaluation
def _peak(ts, ws, i):
    """Vertex of the parabola through the samples i−1, i, i+1 (value at an interior extremum)."""
    if 0 < i < len(ws) - 1:
        y0, y1, y2 = ws[i - 1], ws[i], ws[i + 1]
        den = y0 - 2.0 * y1 + y2
        if den != 0.0:
            return y1 - 0.125 * (y2 - y0) ** 2 / den
    return ws[i]


def chi_refined(t, w, t0, t1, average="mean"):
    """χ of Eq 22 like :func:`metrics.chi`, with the max and min refined by a parabola through
    the three samples around each: smooth in the parameters at a coarse record step (the
    sampled max/min jitters by ~1e-4 in χ at 1 ms), for the search only."""
    sel = M._window(t, t0, t1)
    ts, ws = t[sel], w[sel]
    wmax, wmin = _peak(ts, ws, int(np.argmax(ws))), _peak(ts, ws, int(np.argmin(ws)))
    av = M.time_mean(ts, ws) if average == "mean" else 0.5 * (wmax + wmin)
    return (wmax - wmin) / av


def measure(scn, dt=None, record_dt=None, backend="reduced", t_open=None, refine=False):
    """(χ open loop last cycle, χ PID window, mean open-loop motor speed [rad/s]) of a scenario.

    dt, record_dt default to the scenario's [simulation] values; the open loop runs
    simulation.t_end (steady state, last full cycle), the PID up to the end of the χ window."""
    dt = float(dt if dt is not None else scn.simulation.dt)
    rec = float(record_dt if record_dt is not None else scn.simulation.record_dt)
    rec = max(rec, dt)
    win = scn.metrics.chi_window
    avg = scn.metrics.chi_average
    t_open = float(t_open if t_open is not None else scn.simulation.t_end)
    opts = _options(scn, backend, dt)
    tr = simulate(S.make_machine(scn, "open"), backend, t_open, record_dt=rec, options=opts)
    so = M.summary(tr, average=avg)
    chi_open = so.get("chi_last_cycle", float("nan"))
    if refine and "last_cycle_start_s" in so:
        chi_open = chi_refined(tr.t, tr.omega, so["last_cycle_start_s"], so["last_cycle_end_s"], avg)
    tp = simulate(S.make_machine(scn, "pid"), backend, float(win[1]), record_dt=rec, options=dict(opts))
    chi = chi_refined if refine else M.chi
    chi_pid = chi(tp.t, tp.omega, float(win[0]), float(win[1]), avg)
    return {"chi_open": float(chi_open), "chi_pid_window": float(chi_pid),
            "mean_speed_open": so["mean_motor_speed_rad_s"]}


def _options(scn, backend, dt):
    opts = scn.multibody_options() if backend == "multibody" else {"method": "rk4", "model": scn.reduced.model}
    opts["timestep"] = dt
    return opts


def measure_many(scns, dt=None, record_dt=None, backend="reduced", t_open=None, refine=False):
    """:func:`measure` of many scenarios (same dt, record step, χ window and run lengths), their
    open-loop and PID runs each simulated together (``simulate_many``: the batched reduced model,
    or the MuJoCo batch of :mod:`mjbench.backends.batch`).  Returns a list of measurement dicts, or the error message (str) of a
    scenario whose run diverged."""
    if not scns:
        return []
    s0 = scns[0]
    dt = float(dt if dt is not None else s0.simulation.dt)
    rec = max(float(record_dt if record_dt is not None else s0.simulation.record_dt), dt)
    win, avg = s0.metrics.chi_window, s0.metrics.chi_average
    t_open = float(t_open if t_open is not None else s0.simulation.t_end)
    opts = _options(s0, backend, dt)
    ro = simulate_many([S.make_machine(s, "open") for s in scns], backend, t_open, record_dt=rec, options=dict(opts))
    rp = simulate_many([S.make_machine(s, "pid") for s in scns], backend, float(win[1]), record_dt=rec,
                       options=dict(opts))
    chi = chi_refined if refine else M.chi
    out = []
    for i in range(len(scns)):
        if ro.diverged[i] or rp.diverged[i]:
            out.append(ro.messages[i] or rp.messages[i])
            continue
        tr, tp = ro.trajectory(i), rp.trajectory(i)
        so = M.summary(tr, average=avg)
        chi_open = so.get("chi_last_cycle", float("nan"))
        if refine and "last_cycle_start_s" in so:
            chi_open = chi_refined(tr.t, tr.omega, so["last_cycle_start_s"], so["last_cycle_end_s"], avg)
        out.append({"chi_open": float(chi_open),
                    "chi_pid_window": float(chi(tp.t, tp.omega, float(win[0]), float(win[1]), avg)),
                    "mean_speed_open": so["mean_motor_speed_rad_s"]})
    return out


def residuals_of(meas):
    return np.array([(meas[k] - tgt) / tol for k, (tgt, tol, _) in TARGETS.items()])
