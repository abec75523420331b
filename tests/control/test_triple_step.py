"""Tests of cosim.control.triple_step: eq. 25 <=> Hurwitz error polynomials
(eq. 42-43), and the law produces the wanted output dynamics on the design model."""

from __future__ import annotations

import dataclasses

import pytest
from hypothesis import given
from hypothesis import strategies as st

from cosim.control.triple_step import (
    LawErrors,
    check_gains,
    error_polynomial,
    is_hurwitz,
    mimo_law,
    siso_law,
)
from cosim.errors import InputError
from cosim.params import ControllerGains, VehicleParams
from cosim.vehicle.bicycle import BicyclePlant
from cosim.vehicle.plant import PlantStart

PAPER = ControllerGains()
VEHICLE = VehicleParams()


def test_paper_gains_give_hurwitz_error_polynomials() -> None:
    assert is_hurwitz(error_polynomial(PAPER.ky0, PAPER.kyI, PAPER.ky1))
    assert is_hurwitz(error_polynomial(PAPER.kphi0, PAPER.kphiI, PAPER.kphi1))
    check_gains(PAPER)


@pytest.mark.parametrize(
    ("k0", "ki", "k1"),
    [(10.0, 250.0, 20.0), (10.0, 10.0, 0.5), (-10.0, 10.0, 20.0), (10.0, -1.0, 20.0),
     (100.0, 500.0, 4.0)],
)
def test_gains_violating_eq25_are_not_hurwitz_and_rejected(k0: float, ki: float, k1: float) -> None:
    assert not is_hurwitz(error_polynomial(k0, ki, k1))
    bad = dataclasses.replace(PAPER, kphi0=k0, kphiI=ki, kphi1=k1)
    with pytest.raises(InputError, match="eq. 25"):
        check_gains(bad)


@given(
    k0=st.floats(-50.0, 200.0), ki=st.floats(-50.0, 800.0), k1=st.floats(-10.0, 50.0)
)
def test_eq25_is_exactly_the_hurwitz_condition(k0: float, ki: float, k1: float) -> None:
    eq25 = k0 > 0 and ki > 0 and k0 * k1 > ki
    margin = abs(k0 * k1 - ki) > 1e-3 and abs(k0) > 1e-3 and abs(ki) > 1e-3
    if margin:  # roots on the imaginary axis are numerically ambiguous
        assert is_hurwitz(error_polynomial(k0, ki, k1)) == eq25


def output_accelerations(
    plant: BicyclePlant, delta: float, dmz: float, kappa: float
) -> tuple[float, float]:
    """(ye'', phi_e'') of the design model with eq. 16 at constant Vx and KL."""
    v = VEHICLE
    fa = v.drag * plant.state[3] ** 2 - v.mass * plant.state[4] * plant.state[5]
    # make the wheel forces produce exactly dMz and Fa (no allocation error)
    ls = v.half_track
    plant.set_inputs(delta, (0.0, 0.0, fa / 2 - dmz / (2 * ls), fa / 2 + dmz / (2 * ls)))
    d = plant.derivative(plant.state)
    vx, r = plant.state[3], plant.state[5]
    # ye' = Vx phi_e + Vy, phi_e' = r - KL Vx  =>  ye'' = Vx (r - KL Vx) + Vy', phi_e'' = r'
    return vx * (r - kappa * vx) + d[4], d[5]


@pytest.mark.parametrize("seed", range(5))
def test_mimo_law_leaves_the_error_equations_42_43(seed: int) -> None:
    import random

    rnd = random.Random(seed)
    vx = rnd.uniform(15.0, 33.0)
    kappa = rnd.uniform(-2e-3, 2e-3)
    ye, phi_e = rnd.uniform(-0.5, 0.5), rnd.uniform(-0.05, 0.05)
    vy, r = rnd.uniform(-0.5, 0.5), rnd.uniform(-0.1, 0.1)
    iy, ip = rnd.uniform(-0.2, 0.2), rnd.uniform(-0.01, 0.01)
    ye_dot, phi_e_dot = vx * phi_e + vy, r - kappa * vx  # eq. 16
    delta, dmz = mimo_law(VEHICLE, PAPER, vx, kappa,
                          LawErrors(ye, phi_e, ye_dot, phi_e_dot, iy, ip))
    plant = BicyclePlant(VEHICLE, PlantStart(vx=vx, vy=vy, yaw_rate=r))
    ydd, pdd = output_accelerations(plant, delta, dmz, kappa)
    g = PAPER
    assert ydd == pytest.approx(-(g.ky0 * ye + g.kyI * iy + g.ky1 * ye_dot), abs=1e-9)
    assert pdd == pytest.approx(-(g.kphi0 * phi_e + g.kphiI * ip + g.kphi1 * phi_e_dot), abs=1e-9)


def test_siso_law_regulates_ye_only() -> None:
    vx, kappa, ye, phi_e, vy, r = 25.0, 1e-3, 0.2, 0.02, 0.1, 0.03
    ye_dot, phi_e_dot = vx * phi_e + vy, r - kappa * vx
    delta = siso_law(VEHICLE, PAPER, vx, kappa, LawErrors(ye, phi_e, ye_dot, phi_e_dot, 0.05))
    plant = BicyclePlant(VEHICLE, PlantStart(vx=vx, vy=vy, yaw_rate=r))
    ydd, _ = output_accelerations(plant, delta, 0.0, kappa)
    g = PAPER
    assert ydd == pytest.approx(-(g.ky0 * ye + g.kyI * 0.05 + g.ky1 * ye_dot), abs=1e-9)
