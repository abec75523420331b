"""Handling envelope and stable set (eq. 5-8, 31-34)."""

from __future__ import annotations

import numpy as np
import pytest

from cosim.params import G, VehicleParams, kmh
from cosim.planning.envelope import (
    envelope_margin,
    inverse_dynamics_yaw_rate,
    paper_map_tau_min,
    stable_set,
)
from cosim.planning.trajectory import BoundaryConditions, cluster_derivatives

VEH = VehicleParams()
GRID = np.arange(1.0, 10.0001, 0.05)
# (vx0 km/h, vxf km/h, W m, mu, paper's tau_min s)
PAPER = [(80, 90, 3.75, 0.4, 2.75), (110, 90, -3.75, 0.6, 2.56), (105, 110, 3.75, 0.8, 2.23)]


def test_steady_turn_yaw_rate_is_speed_over_radius() -> None:
    """On a circle at constant speed the model's yaw rate settles at V / R."""
    V, R = 25.0, 300.0
    n = 4001
    speed = np.full((1, n), V)
    a_n = np.full((1, n), V**2 / R)
    omega = inverse_dynamics_yaw_rate(speed, a_n, np.array([10.0 / (n - 1)]), VEH)
    assert omega[0, -1] == pytest.approx(V / R, rel=1e-6)
    assert omega[0, 0] == 0.0


def _numpy_yaw_rate(speed: np.ndarray, u: np.ndarray, dt: np.ndarray,
                    omega0: np.ndarray) -> np.ndarray:
    """The trapezoidal steps vectorised in numpy (one step for all rows at a time): the
    reference the compiled loop must match to the last bit."""
    M, Iz, lf, lr, Cr = VEH.mass, VEH.yaw_inertia, VEH.lf, VEH.lr, VEH.cr
    V = np.maximum(speed, 0.5)
    k = (lf + lr) * Cr / (Iz * V)
    a01, a10, a11 = -V, k, -k * lr
    h = 0.5 * dt[:, None]
    g0 = h * (u[:, :-1] + u[:, 1:])
    g1 = g0 * (lf * M / Iz)
    m01, m10, m11 = -h * a01[:, 1:], -h * a10[:, 1:], 1.0 - h * a11[:, 1:]
    det = 1.0 * m11 - m01 * m10
    i00, i01, i10, i11 = m11 / det, -m01 / det, -m10 / det, 1.0 / det
    p01, p10, p11 = h * a01[:, :-1], h * a10[:, :-1], 1.0 + h * a11[:, :-1]
    t00, t01 = i00 * 1.0 + i01 * p10, i00 * p01 + i01 * p11
    t10, t11 = i10 * 1.0 + i11 * p10, i10 * p01 + i11 * p11
    c0, c1 = i00 * g0 + i01 * g1, i10 * g0 + i11 * g1
    omega = np.empty_like(speed)
    vy, om = np.zeros(speed.shape[0]), omega0.copy()
    omega[:, 0] = om
    for j in range(speed.shape[1] - 1):
        vy, om = (t00[:, j] * vy + t01[:, j] * om + c0[:, j],
                  t10[:, j] * vy + t11[:, j] * om + c1[:, j])
        omega[:, j + 1] = om
    return omega


def test_compiled_yaw_rate_is_numpy_to_the_last_bit() -> None:
    """The compiled trapezoid keeps numpy's arithmetic operation by operation: the same
    bits on random rows, speeds through the 0.5 m/s floor included."""
    rng = np.random.default_rng(7)
    for n, n_s in ((1, 64), (37, 128), (99, 256)):
        speed = rng.uniform(0.0, 40.0, (n, n_s))
        u = rng.normal(0.0, 3.0, (n, n_s))
        dt = rng.uniform(0.001, 0.2, n)
        omega0 = rng.normal(0.0, 0.1, n)
        got = inverse_dynamics_yaw_rate(speed, u, dt, VEH, omega0)
        assert np.array_equal(got, _numpy_yaw_rate(speed, u, dt, omega0))


def _numpy_margin(bc: BoundaryConditions, tau: np.ndarray, mu: float, safety_factor: float,
                  yaw_model: str, n_s: int) -> np.ndarray:
    """eq. 5-6's margin in numpy (the trajectories' derivatives, Vx*, Ax, a_n, the yaw
    rate, the bound): the reference the compiled pass must match to the last bit."""
    def col(a: object) -> np.ndarray:
        return np.broadcast_to(np.asarray(a, dtype=float), tau.shape)[:, None]

    s = np.linspace(0.0, 1.0, n_s)
    rows = BoundaryConditions(col(bc.vx0), col(bc.vxf), col(bc.width), col(bc.ax0),
                              col(bc.vy0), col(bc.ay0))
    d = cluster_derivatives(rows, tau[:, None], tau[:, None] * s[None, :], (1, 2))
    (xd, yd), (xdd, ydd) = d[1], d[2]
    V = np.hypot(xd, yd)
    with np.errstate(invalid="ignore", divide="ignore"):
        Ax = (xd * xdd + yd * ydd) / V
        a_n = (xd * ydd - yd * xdd) / V
        if yaw_model == "kinematic":
            omega = a_n / V
        else:
            omega = inverse_dynamics_yaw_rate(V, a_n, tau / (n_s - 1), VEH,
                                              a_n[:, 0] / V[:, 0])
        grip2 = (mu * G) ** 2 - Ax**2
        bound = safety_factor * np.sqrt(np.where(grip2 > 0, grip2, np.nan)) / V
        ratio = np.abs(omega) / bound
    return np.where(np.isnan(ratio), np.inf, ratio).max(axis=1)


def test_compiled_margin_is_numpy_to_the_last_bit() -> None:
    """The compiled margin keeps numpy's arithmetic: the same bits on random rows, from
    rest and from general starts, both yaw models, candidates beyond grip and at rest."""
    rng = np.random.default_rng(11)
    for trial in range(60):
        n = int(rng.integers(1, 40))
        general = trial % 2 == 0
        bc = BoundaryConditions(rng.uniform(0.0, 45.0, n), rng.uniform(0.0, 45.0, n),
                                rng.uniform(-4.0, 4.0, n) if general else 3.75,
                                rng.normal(0.0, 1.0, n) if general else 0.0,
                                rng.normal(0.0, 0.5, n) if general else 0.0,
                                rng.normal(0.0, 0.5, n) if general else 0.0)
        tau = rng.uniform(0.3, 12.0, n)
        mu, factor = float(rng.uniform(0.2, 1.0)), float(rng.choice([0.5, 0.8]))
        model = "kinematic" if trial % 5 == 0 else "inverse_dynamics"
        n_s = int(rng.choice([7, 64, 128, 256]))
        got = envelope_margin(bc, tau, mu, VEH, safety_factor=factor, yaw_model=model,
                              n_s=n_s)
        assert got.tobytes() == _numpy_margin(bc, tau, mu, factor, model, n_s).tobytes()


@pytest.mark.parametrize(("v0", "vf", "W", "mu", "paper"), PAPER)
def test_tau_min_reproduces_the_paper(v0: float, vf: float, W: float, mu: float,
                                      paper: float) -> None:
    st = stable_set(BoundaryConditions(kmh(v0), kmh(vf), W), GRID, mu, VEH)
    assert abs(st.tau_min - paper) < 0.04
    # the stable set is the interval [tau_min, tau_max] on the grid
    assert st.stable[st.tau_min + 1e-9 <= GRID].all()
    assert not st.stable[st.tau_min - 1e-9 > GRID].any()


@pytest.mark.parametrize(("v0", "vf", "W", "mu", "paper"), PAPER)
def test_kinematic_yaw_rate_is_not_enough(v0: float, vf: float, W: float, mu: float,
                                          paper: float) -> None:
    """The oversteering car needs more yaw rate than V * curvature: shorter kinematic tau_min."""
    dyn = stable_set(BoundaryConditions(kmh(v0), kmh(vf), W), GRID, mu, VEH)
    kin = stable_set(BoundaryConditions(kmh(v0), kmh(vf), W), GRID, mu, VEH,
                     envelope="kinematic")
    assert kin.tau_min < dyn.tau_min - 0.05


def test_lower_friction_and_safety_factor_lengthen_tau_min() -> None:
    base = stable_set(BoundaryConditions(kmh(100), kmh(110), 3.75), GRID, 0.8, VEH).tau_min
    assert stable_set(BoundaryConditions(kmh(100), kmh(110), 3.75), GRID, 0.4, VEH).tau_min > base
    assert stable_set(BoundaryConditions(kmh(100), kmh(110), 3.75), GRID, 0.8, VEH,
                      safety_factor=0.5).tau_min > base


def test_rows_of_several_vehicles_in_one_call() -> None:
    taus = GRID[::10]
    a = envelope_margin(BoundaryConditions(kmh(80), kmh(90), 3.75), taus, 0.5, VEH)
    b = envelope_margin(BoundaryConditions(kmh(110), kmh(90), -3.75), taus, 0.5, VEH)
    rows = BoundaryConditions(np.repeat([kmh(80), kmh(110)], taus.size),
                              np.repeat([kmh(90), kmh(90)], taus.size),
                              np.repeat([3.75, -3.75], taus.size))
    both = envelope_margin(rows, np.tile(taus, 2), 0.5, VEH)
    np.testing.assert_allclose(both, np.concatenate([a, b]), rtol=1e-12)


def test_acceleration_beyond_grip_is_outside() -> None:
    """A 0 -> 30 m/s change in 1 s needs |Ax| > mu g: margin inf."""
    m = envelope_margin(BoundaryConditions(0.5, 30.0, 3.75), [1.0], 0.4, VEH)
    assert np.isinf(m[0])


def test_paper_maps() -> None:
    # eq. 31 is the one that matches the paper's own case 5.1 (2.77 vs 2.75)
    assert paper_map_tau_min(1, kmh(80), 0.4) == pytest.approx(2.77, abs=0.01)
    st = stable_set(BoundaryConditions(kmh(80), kmh(90), 3.75), GRID, 0.4, VEH,
                    envelope="paper_maps", mode=1)
    assert st.tau_min == pytest.approx(2.77, abs=0.01)
    assert st.stable[GRID >= 2.8].all() and not st.stable[GRID < 2.75].any()
    # eq. 33 is negative over the speed range (a misprint): warned and floored
    with pytest.warns(UserWarning, match="eq. 33"):
        st3 = stable_set(BoundaryConditions(kmh(110), kmh(110), -3.75), GRID, 0.6, VEH,
                         envelope="paper_maps", mode=3, tau_floor=1.0)
    assert st3.tau_min == 1.0


def test_tau_min_map_matches_the_envelope() -> None:
    """eq. 7's map F(vx0), computed from the envelope, against direct fine-grid runs."""
    from cosim.planning.envelope import TauMinMap, fill_maps

    fmap = TauMinMap(kmh(90), -3.75, 0.6, VEH, tau_lo=1.0, tau_hi=10.0)
    fmap._fill_whole()  # every grid speed at once (a query computes those it reads)
    fine = np.arange(1.0, 10.0001, 0.005)
    for v in (12.3, 21.7, 30.9):
        direct = stable_set(BoundaryConditions(v, kmh(90), -3.75), fine, 0.6, VEH).tau_min
        assert float(fmap(v)) == pytest.approx(direct, abs=0.005)
    assert np.isnan(fmap(80.0))  # outside the map
    # one float takes a path on plain floats: the same values as numpy's, bit for bit
    speeds = np.concatenate((np.linspace(0.0, 52.0, 2001), fmap.speeds, [1.0, 50.0]))
    lo, hi = fmap.bounds(speeds)
    value = fmap(speeds)
    for i, v in enumerate(speeds.tolist()):
        got = (*fmap.bounds(v), fmap(v))
        assert isinstance(got[0], float)
        np.testing.assert_array_equal(got, (lo[i], hi[i], value[i]))
    # filled lazily, a query computes the few speeds it reads: the same answers as the
    # whole grid's, bit for bit
    for v in (0.7, 1.0, 13.5, 27.3, 49.9, 50.0):
        lazy = TauMinMap(kmh(90), -3.75, 0.6, VEH, tau_lo=1.0, tau_hi=10.0)
        np.testing.assert_array_equal((*lazy.bounds(v), lazy(v)),
                                      (*fmap.bounds(v), fmap(v)))
        assert lazy._coarse.sum() <= 6
    # several maps filled together (a re-check's C2 TVs, `fill_maps`): the same again
    other = TauMinMap(kmh(100), 3.75, 0.6, VEH, tau_lo=1.0, tau_hi=10.0)
    other._fill_whole()
    a, b = (TauMinMap(kmh(v), w, 0.6, VEH, tau_lo=1.0, tau_hi=10.0)
            for v, w in ((90, -3.75), (100, 3.75)))
    fill_maps([(a, 13.5), (b, 27.3), (a, 30.2), (b, 80.0)])
    assert (a._coarse.sum(), b._coarse.sum(), a._refined.sum(), b._refined.sum()) == (12, 6, 8, 4)
    for lazy, whole, v in ((a, fmap, 13.5), (b, other, 27.3), (a, fmap, 30.2)):
        np.testing.assert_array_equal((*lazy.bounds(v), lazy(v)),
                                      (*whole.bounds(v), whole(v)))


def test_a_map_whose_coarse_pass_leaves_speeds_without_a_stable_tau_builds() -> None:
    # the gap policy's vxf 27.14 m/s on a wet road (mu 0.4): speeds with no stable tau
    # give the refining bisection nan bounds, which must not reach its iteration count
    # (int(nan): "cannot convert float NaN to integer")
    from cosim.params import PlannerConfig, VehicleParams
    from cosim.planning.planner import _built_tau_min_map

    cfg = PlannerConfig()
    m = _built_tau_min_map(27.139073060960747, 3.75, 0.4, VehicleParams(), cfg.tau_min_floor,
                           cfg.tau_max, cfg.safety_factor, cfg.envelope)
    tau = m(27.0)
    assert np.isnan(tau) or tau >= cfg.tau_min_floor
