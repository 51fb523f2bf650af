"""The compiled exact answers of the SQP step's QP (games/exact_qp.py), against LAPACK and the
KKT conditions."""

import numpy as np
import pytest
from scipy.linalg import lapack

from intersection_cosim.games.exact_qp import BOX, INTERIOR, NOT_FOUND, exact_qp, exact_qps

N = 30


def _qp(seed: int, box: float = 5.0):
    """A coupled positive definite H (N x N), an iterate a, g with the unconstrained minimiser
    a + U(-0.3, 0.3) [m/s^2]; box rows a +- ``box``, speed rows that never bind (unit scale)."""
    rng = np.random.default_rng(seed)
    G = rng.normal(size=(N, N))
    H = G @ G.T / N + 0.5 * np.eye(N)
    a = rng.uniform(-1.0, 1.0, N)
    g = H @ -rng.uniform(-0.3, 0.3, N)
    l = np.concatenate((a - box, np.full(N, -1e9)))
    u = np.concatenate((a + box, np.full(N, 1e9)))
    return H, g, a, l, u, np.ones(2 * N)


@pytest.mark.parametrize("seed", range(5))
def test_an_interior_answer_is_lapacks_cholesky_solve(seed):
    H, g, a, l, u, rs = _qp(seed)
    status, x, y = exact_qp(H, g, a, l, u, rs, 6)
    assert status == INTERIOR and np.all(y == 0.0)
    _, ref, info = lapack.dposv(H, g)
    assert info == 0
    assert np.abs(x - (a - ref)).max() < 1e-12


def test_only_the_upper_triangle_of_h_is_read():
    """As LAPACK's dposv: a Gauss-Newton H is symmetric only to rounding; the factorisation
    reads one triangle, whatever the other holds."""
    H, g, a, l, u, rs = _qp(7)
    skewed = H + np.tril(np.full((N, N), 0.25), -1)
    x1 = exact_qp(H, g, a, l, u, rs, 6)[1]
    x2 = exact_qp(skewed, g, a, l, u, rs, 6)[1]
    assert np.array_equal(x1, x2)


@pytest.mark.parametrize("seed", range(5))
def test_a_box_answer_meets_the_kkt_conditions(seed):
    """With a trust region of 0.1 m/s^2 the minimiser (up to 0.3 m/s^2 away) is cut off: the
    answer lies in the box, its gradient is balanced by the multipliers of the active bounds
    only, with the signs of those bounds, and no speed row carries one."""
    H, g, a, l, u, rs = _qp(seed, box=0.1)
    status, x, y = exact_qp(H, g, a, l, u, rs, 10)
    assert status == BOX
    assert np.all(x >= a - 0.1 - 1e-12) and np.all(x <= a + 0.1 + 1e-12)
    grad = H @ (x - a) + g
    assert np.abs(grad + y[:N]).max() < 1e-10
    at_hi, at_lo = np.isclose(x, a + 0.1, atol=1e-12), np.isclose(x, a - 0.1, atol=1e-12)
    assert at_hi.sum() + at_lo.sum() >= 3
    assert np.all(y[:N][at_hi] >= 0.0) and np.all(y[:N][at_lo] <= 0.0)
    assert np.all(y[:N][~(at_hi | at_lo)] == 0.0) and np.all(y[N:] == 0.0)


def test_no_answer_without_passes_for_an_active_speed_row_or_for_bad_data():
    H, g, a, l, u, rs = _qp(3, box=0.1)
    assert exact_qp(H, g, a, l, u, rs, 0)[0] == NOT_FOUND  # box rows bind, no passes allowed
    # a speed row binds: v0 = 1 m/s, the minimiser brakes at 3 m/s^2 (dt = 0.1 s)
    l2, u2 = np.full(2 * N, -1e9), np.full(2 * N, 1e9)
    l2[:N], u2[:N], l2[N:] = -6.0, 3.0, -1.0 / 0.1
    assert exact_qp(np.eye(N), np.full(N, 3.0), np.zeros(N), l2, u2, rs, 6)[0] == NOT_FOUND
    indefinite = H - 10.0 * np.eye(N)
    assert exact_qp(indefinite, g, a, l, u, rs, 6)[0] == NOT_FOUND
    assert exact_qp(np.full((N, N), np.nan), g, a, l, u, rs, 6)[0] == NOT_FOUND


def test_many_qps_at_once_agree_with_one_at_a_time():
    qps = [_qp(s, box=0.1 if s % 2 else 5.0) for s in range(6)]
    H, g, a, l, u = (np.stack([q[i] for q in qps]) for i in range(5))
    status, x, y = exact_qps(H, g, a, l, u, qps[0][5], 6)
    for i, q in enumerate(qps):
        s1, x1, y1 = exact_qp(*q, 6)
        assert status[i] == s1 and np.array_equal(x[i], x1) and np.array_equal(y[i], y1)
    assert set(status) == {INTERIOR, BOX}
