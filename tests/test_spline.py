"""The periodic cubic spline of the tables (mjbench.spline) against SciPy's, an independent path."""
import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from mjbench.spline import periodic_cubic


@pytest.mark.parametrize("n", [3, 8, 1024, 2048])
def test_periodic_cubic_is_scipys_periodic_spline(n):
    P = 2 * np.pi
    x = np.arange(n + 1) * (P / n)
    x[-1] = P
    y = np.stack([np.sin(x) + 0.3 * np.cos(3 * x) + 2.0, np.exp(np.cos(x)), 1e-3 * np.sin(5 * x)], axis=1)
    y[-1] = y[0]
    ref = CubicSpline(x, y, bc_type="periodic", axis=0)
    c = periodic_cubic(y[:-1])
    h = P / n
    # the same polynomial per cell: SciPy's c[3-j]·(x − x_i)^j = ours c_j·t^j with t = (x − x_i)/h
    for j in range(4):
        np.testing.assert_allclose(c[j], ref.c[3 - j] * h ** j, rtol=0, atol=2e-15 * np.max(np.abs(y)))
    # and between the nodes (t = 0.37 in every cell)
    t = 0.37
    xs = x[:-1] + t * h
    ours = ((c[3] * t + c[2]) * t + c[1]) * t + c[0]
    np.testing.assert_allclose(ours, ref(xs), rtol=0, atol=4e-15 * np.max(np.abs(y)))


def test_periodic_cubic_reproduces_a_periodic_cubic_exactly_and_is_c2():
    """A trigonometric polynomial is not a cubic, but the spline must be C² across every node
    (closure of the circulant solve), including the wrap from the last cell to the first."""
    n = 64
    u = np.arange(n) * (2 * np.pi / n)
    y = np.cos(u) + 0.5 * np.sin(2 * u)
    c = periodic_cubic(y)
    nxt = lambda a: np.roll(a, -1)  # noqa: E731
    end = c[0] + c[1] + c[2] + c[3]
    d1_end = c[1] + 2 * c[2] + 3 * c[3]
    d2_end = 2 * c[2] + 6 * c[3]
    np.testing.assert_allclose(end, nxt(c[0]), atol=1e-14)
    np.testing.assert_allclose(d1_end, nxt(c[1]), atol=1e-13)
    np.testing.assert_allclose(d2_end, nxt(2 * c[2]), atol=1e-12)


def test_too_few_nodes_refused():
    with pytest.raises(ValueError, match="at least 3 nodes"):
        periodic_cubic(np.ones(2))
