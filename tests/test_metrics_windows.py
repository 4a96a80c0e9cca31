"""χ and extremes of many windows at once (mjbench.metrics.chis_of, the interval statistics read by
slices, the edges' cubic, the Hermite crossings' Newton) against independent paths: the same run
recorded at every co-step (its samples are every co-step), NumPy's polynomial fit through the four
nearest samples, the plain 20-step Newton iteration, and a brute-force scan of the statistics."""
import math

import numpy as np
import pytest

from mjbench import metrics as M
from mjbench import scenario as S
from mjbench.backends import simulate
from mjbench.trajectory import Trajectory

H = 1e-4


@pytest.fixture(scope="module")
def runs():
    scn = S.load("incerti2012")
    return {rd: simulate(S.make_machine(scn, "pid"), "reduced", 1.0, record_dt=rd) for rd in (H, 5e-4)}


def test_many_windows_at_once_are_those_of_every_co_step(runs):
    fine, coarse = runs[H], runs[5e-4]
    cyc = M.cycles_of(coarse)
    t0s = np.concatenate([cyc[:, 0], [0.2337, 0.375, 0.5]])
    t1s = np.concatenate([cyc[:, 1], [0.4111, 0.5, 0.52]])
    chis = M.chis_of(coarse, t0s, t1s)
    phi = float(fine.meta["z"]) * fine.q
    for a, b, c in zip(t0s, t1s, chis):
        sel = (fine.t >= a - 1e-12) & (fine.t <= b + 1e-12)
        w = fine.omega[sel]
        # the fine record's window ends on its own grid (0.1 ms): its mean from the angle at those ends
        tt = fine.t[sel]
        truth = (w.max() - w.min()) / ((phi[sel][-1] - phi[sel][0]) / (tt[-1] - tt[0]))
        assert c == pytest.approx(truth, rel=2e-3), (a, b)
        assert c == M.chi_of(coarse, a, b)  # one window at a time: the same number


def test_values_at_is_the_cubic_through_the_four_nearest_samples(runs):
    tr = runs[5e-4]
    t, x = tr.t, tr.omega
    rng = np.random.default_rng(3)
    tts = np.concatenate([rng.uniform(t[0], t[-1], 200), t[[0, 7, -1]], [t[1] + 1e-3 * (t[2] - t[1])]])
    got = M.values_at(t, x, tts)
    for tt, g in zip(tts, got):
        j = int(np.searchsorted(t, tt))
        if j < len(t) and abs(t[j] - tt) <= 1e-12:
            assert g == x[j]
            continue
        lo = max(0, min(j - 2, len(t) - 4))
        ts, xs = t[lo:lo + 4], x[lo:lo + 4]
        ref = np.polyval(np.polyfit(ts - ts[0], xs, 3), tt - ts[0])
        assert g == pytest.approx(ref, rel=1e-9, abs=1e-9 * np.max(np.abs(x)))


def _newton20(t, q, qd, i, target):
    """The crossing's Newton iteration run plainly: up to 20 steps, stopping only at a zero slope or a
    step below 1e-15 (NumPy scalars)."""
    h = t[i + 1] - t[i]
    q0, q1, d0, d1 = q[i], q[i + 1], qd[i] * h, qd[i + 1] * h
    s = (target - q0) / (q1 - q0) if q1 != q0 else 0.0
    for _ in range(20):
        s2, s3 = s * s, s * s * s
        f = (2 * s3 - 3 * s2 + 1) * q0 + (s3 - 2 * s2 + s) * d0 + (-2 * s3 + 3 * s2) * q1 + (s3 - s2) * d1 - target
        df = (6 * s2 - 6 * s) * q0 + (3 * s2 - 4 * s + 1) * d0 + (-6 * s2 + 6 * s) * q1 + (3 * s2 - 2 * s) * d1
        if df == 0:
            break
        step = f / df
        s = min(1.0, max(0.0, s - step))
        if abs(step) < 1e-15:
            break
    return float(t[i] + s * h)


def test_hermite_crossings_equal_the_plain_iteration_bit_for_bit(runs):
    tr = runs[5e-4]
    t, q, qd = tr.t, tr.q - tr.q[0], tr.qd
    umax = np.maximum.accumulate(q)
    rng = np.random.default_rng(5)
    targets = np.concatenate([2 * np.pi * np.arange(1, int(q[-1] / (2 * np.pi)) + 1),
                              rng.uniform(0.01, q[-1] - 0.01, 300)])
    for tg in targets:
        j = int(np.searchsorted(umax, tg))
        assert M._hermite_cross(t, q, qd, j - 1, tg) == _newton20(t, q, qd, j - 1, tg)


def _brute_extrema(t, mx, tmx, mn, tmn, t0, t1):
    """Every interval's statistics scanned one by one (row r: the interval [t_{r-1}, t_r]): the
    finite extremes of those inside [t0, t1], and of those cut by its edges when they occurred inside."""
    eps = 1e-12 * max(1.0, abs(t1))
    hi, lo = [], []
    for r in range(1, len(t)):
        a, b = t[r - 1], t[r]
        if b < t0 - eps or a > t1 + eps:
            continue
        inside = a >= t0 - eps and b <= t1 + eps
        if math.isfinite(mx[r]) and (inside or t0 - eps <= tmx[r] <= t1 + eps):
            hi.append(mx[r])
        if math.isfinite(mn[r]) and (inside or t0 - eps <= tmn[r] <= t1 + eps):
            lo.append(mn[r])
    return max(hi, default=-np.inf), min(lo, default=np.inf)


def test_extremes_skip_non_finite_statistics_like_a_scan():
    n = 41
    t = np.linspace(0.0, 2.0, n)
    rng = np.random.default_rng(11)
    x = np.sin(3 * t)
    tr = Trajectory(n, "test", columns=("t_s", "motor_speed_rad_s"))
    tr.data[:, 0], tr.data[:, 1], tr.n = t, x, n
    st = np.empty((n, 4))
    x0 = np.concatenate([[x[0]], x[:-1]])  # an interval's extremes beyond both its end samples
    st[:, 0] = np.maximum(x0, x) + rng.uniform(0.05, 0.1, n)
    st[:, 2] = np.minimum(x0, x) - rng.uniform(0.05, 0.1, n)
    st[:, 1] = st[:, 3] = t - rng.uniform(0.0, 1.0, n) * (t[1] - t[0])  # when: inside the interval
    st[0] = np.nan
    st[[5, 17], 0], st[9, 2], st[23, 0] = np.nan, -np.inf, np.inf
    tr.stats, tr.stat_columns = st, tuple(f"motor_speed_rad_s:{k}" for k in ("max", "t_max", "min", "t_min"))
    for t0, t1 in ((0.0, 2.0), (0.1, 0.35), (0.9, 1.55), (0.3, 1.0)):  # edges on samples
        mx, mn = M.window_extrema(tr, "motor_speed_rad_s", t0, t1)
        bx, bn = _brute_extrema(t, st[:, 0], st[:, 1], st[:, 2], st[:, 3], t0, t1)
        assert (mx, mn) == (bx, bn), (t0, t1)  # (the edge samples lie inside the statistics' range)
        c = M.chis_of(tr, [t0], [t1], average="midrange")[0]
        assert c == pytest.approx((bx - bn) / (0.5 * (bx + bn)), rel=1e-15)
