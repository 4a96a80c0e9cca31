"""The two-input grid table's evaluation: the compiled SIMD evaluation (an LLVM intrinsic,
:func:`mjbench.compiled._numba._bicubic`) gives the bits of the law's Python body; the law agrees with
the NumPy evaluation (:class:`GridTable`: its own layout of the coefficients, its cell coordinate by
division where the law multiplies by 1/h: within rounding), and the spline reproduces a bicubic
polynomial up to rounding."""
import math

import numpy as np
import pytest

from mjbench.mechanisms.linkage.multi import CELL_SLOTS, GridTable, bicubic_lanes, grid2_eval


def _table(k, rng):
    x0 = np.linspace(0.2, 1.4, 9)
    x1 = np.linspace(-0.5, 0.7, 7)
    X0, X1 = np.meshgrid(x0, x1, indexing="ij")
    vals = np.stack([np.sin((c + 1) * X0) * np.cos(X1 - 0.1 * c) + 0.3 * c for c in range(k)], axis=-1)
    return GridTable([x0, x1], [False, False], vals + 1e-3 * rng.standard_normal(vals.shape)), x0, x1


@pytest.mark.parametrize("k", (3, 8, 11, 14))
def test_the_law_gives_the_numpy_evaluation(k):
    rng = np.random.default_rng(k)
    tab, x0, x1 = _table(k, rng)
    assert tab.slots == 4 * math.ceil(k / 4) and tab.P.rows.shape[1] == 16 * tab.slots
    assert tab.scratch == tab.slots + CELL_SLOTS
    Q = np.column_stack([rng.uniform(x0[0], x0[-1], 200), rng.uniform(x1[0], x1[-1], 200)])
    Q[:3] = [(x0[0], x1[0]), (x0[-1], x1[-1]), (x0[4], x1[3])]  # the first and last node, an inner node
    want = tab(Q)
    out = np.full(4 + tab.scratch, -7.0)
    for q, w in zip(Q, want):
        grid2_eval(float(q[0]), float(q[1]), tab.P, out, 4)
        np.testing.assert_allclose(out[4:4 + k], w, rtol=1e-13, atol=1e-13 * np.max(np.abs(w)))
        assert np.all(out[4 + k:4 + tab.slots] == 0.0)  # the padding lanes
    grid2_eval(x0[0] - 0.1, x1[0], tab.P, out, 4)
    assert np.all(np.isnan(out[4:4 + k]))


def test_the_table_reproduces_a_bicubic_polynomial():
    x0 = np.linspace(0.0, 1.0, 6)
    x1 = np.linspace(0.0, 2.0, 8)
    X0, X1 = np.meshgrid(x0, x1, indexing="ij")

    def f(a, b):
        return 1.0 + 2 * a - a ** 2 * b + 0.5 * a ** 3 * b ** 3 - b ** 2

    tab = GridTable([x0, x1], [False, False], f(X0, X1)[..., None])  # not-a-knot: cubics exactly
    rng = np.random.default_rng(0)
    Q = rng.uniform([0, 0], [1, 2], (100, 2))
    out = np.zeros(8)
    for a, b in Q:
        grid2_eval(a, b, tab.P, out, 0)
        assert out[0] == pytest.approx(f(a, b), rel=1e-12, abs=1e-12)


def test_the_compiled_evaluation_gives_the_python_bits():
    numba = pytest.importorskip("numba")
    from mjbench.compiled import jit

    jit.init()

    @numba.njit
    def compiled(R, r, s, t, out, o, nvec):
        bicubic_lanes(R, r, s, t, out, o, nvec)

    rng = np.random.default_rng(3)
    for nvec in (1, 2, 3, 4):
        R = rng.standard_normal((5, 64 * nvec))
        for s, t in rng.uniform(0, 1, (20, 2)):
            a, b = np.zeros(5 + 4 * nvec), np.zeros(5 + 4 * nvec)
            compiled(R, 3, s, t, a, 5, nvec)
            bicubic_lanes(R, 3, s, t, b, 5, nvec)
            np.testing.assert_array_equal(a, b)
            assert np.all(a[:5] == 0.0)  # nothing written before the offset


def test_an_output_too_short_for_the_channels_is_an_error_not_a_write_past_its_end():
    tab, x0, x1 = _table(11, np.random.default_rng(0))
    with pytest.raises(IndexError, match="do not fit"):
        grid2_eval(0.5, 0.1, tab.P, np.zeros(10), 0)
    with pytest.raises(IndexError, match="do not fit"):  # the lanes fit, the remembered cell does not
        grid2_eval(0.5, 0.1, tab.P, np.zeros(tab.slots + 1), 0)


@pytest.mark.parametrize("periodic", (False, True))
def test_the_remembered_cell_gives_the_bits_of_a_fresh_evaluation(periodic, monkeypatch):
    """grid2_eval keeps the cell it evaluated last and skips the cell search while the point stays in
    it: along a path that crosses cells, leaves the ranges, lands on the last node and (periodic)
    wraps, every evaluation equals, bit for bit, one made with a fresh scratch (no cell kept), and
    whatever stale or foreign values the cell's slots hold are never used for a cell outside the table."""
    rng = np.random.default_rng(7)
    if periodic:
        x0 = np.linspace(0.0, 2 * math.pi, 13)[:-1]
        x1 = np.linspace(0.0, 2 * math.pi, 9)[:-1]
    else:
        x0, x1 = np.linspace(0.2, 1.4, 9), np.linspace(-0.5, 0.7, 7)
    X0, X1 = np.meshgrid(x0, x1, indexing="ij")
    vals = np.stack([np.sin((c + 1) * X0) * np.cos(X1 - 0.1 * c) for c in range(11)], axis=-1)
    tab = GridTable([x0, x1], [periodic, periodic], vals)
    L = tab.slots
    s = np.linspace(0.0, 1.0, 3000)
    lo0, hi0 = (x0[0], x0[-1]) if not periodic else (-7.0, 13.0)  # (periodic: beyond one turn both ways)
    lo1, hi1 = (x1[0], x1[-1]) if not periodic else (9.0, -4.0)
    path = np.column_stack([lo0 + (hi0 - lo0) * s + 0.02 * np.sin(40 * s), lo1 + (hi1 - lo1) * s ** 2])
    path = np.vstack([path, [(x0[-1], x1[-1]), (x0[-1] + 1e-3, x1[2]), (x0[3], x1[2]),  # last node, outside
                             (np.nan, x1[1]), (x0[3] + 1e-9, x1[2])]])
    k = tab.kloop
    kept = np.zeros(2 + L + CELL_SLOTS)  # zeros: the cell (0, 0)
    for a, b in path:
        fresh = np.full(2 + L + CELL_SLOTS, -1.0)  # no cell kept
        grid2_eval(float(a), float(b), tab.P, kept, 2)
        grid2_eval(float(a), float(b), tab.P, fresh, 2)
        np.testing.assert_array_equal(kept[2:2 + k], fresh[2:2 + k])
    for junk in ((1e9, 3.0), (-3.0, 2.0), (2.0, 1e300), (np.nan, 1.0)):  # slots holding anything else
        kept[2 + L:] = junk
        fresh = np.full(2 + L + CELL_SLOTS, -1.0)
        grid2_eval(float(x0[3]) + 0.01, float(x1[2]) + 0.01, tab.P, kept, 2)
        grid2_eval(float(x0[3]) + 0.01, float(x1[2]) + 0.01, tab.P, fresh, 2)
        np.testing.assert_array_equal(kept[2:2 + k], fresh[2:2 + k])
        assert list(kept[2 + L:]) == [3.0, 2.0]  # the cell found is kept
    # inside the kept cell the cell search is skipped
    import mjbench.mechanisms.linkage.multi as M

    def no_search(*a):
        raise AssertionError("the cell was searched again")
    monkeypatch.setattr(M, "grid_cell", no_search)
    grid2_eval(float(x0[3]) + 0.02, float(x1[2]) + 0.05, tab.P, kept, 2)
    grid2_eval(float(x0[3]) + 0.02, float(x1[2]) + 0.05, tab.P, fresh, 2)
    np.testing.assert_array_equal(kept[2:2 + k], fresh[2:2 + k])


def test_the_rows_start_on_a_cache_line_also_when_read_back_from_the_cache():
    import pickle

    tab, _, _ = _table(11, np.random.default_rng(1))
    for t in (tab, pickle.loads(pickle.dumps(tab))):
        assert t.P.rows.ctypes.data % 64 == 0 and t.P.rows.flags.c_contiguous
        np.testing.assert_array_equal(t.P.rows, tab.P.rows)
