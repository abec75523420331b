"""Tests of cosim.params' known cars: CommonRoad's parameter sets transcribed as the
package has them, Cf / Cr derived from its tyre, presets loadable from a scenario."""

from __future__ import annotations

import dataclasses
import math

import pytest

from cosim.params import (
    COMMONROAD_CARS,
    COMMONROAD_TYRE,
    VEHICLE_PRESETS,
    G,
    VehicleParams,
    vehicle_from_table,
)

vehiclemodels = pytest.importorskip("vehiclemodels")


@pytest.mark.parametrize("name", sorted(COMMONROAD_CARS))
def test_commonroad_cars_are_the_packages_parameter_files(name: str) -> None:
    import importlib

    module = importlib.import_module(f"vehiclemodels.parameters_{name}")
    p = getattr(module, f"parameters_{name}")()
    car = COMMONROAD_CARS[name]
    for f in dataclasses.fields(car):
        if f.name != "name":
            assert getattr(car, f.name) == getattr(p, f.name), f.name
    for key, value in COMMONROAD_TYRE.items():
        assert getattr(p.tire, key) == value, key


@pytest.mark.parametrize("name", sorted(COMMONROAD_CARS))
def test_axle_cornering_stiffness_is_21_92_times_the_axle_load(name: str) -> None:
    """CommonRoad's MB takes K_y = p_ky1 Fz per wheel, its ST mu C_S Fz with C_S = -p_ky1 /
    p_dy1 and mu = p_dy1: both |p_ky1| = 21.92 /rad per unit load."""
    car = COMMONROAD_CARS[name]
    v = VEHICLE_PRESETS[f"commonroad_{name}"]
    assert -COMMONROAD_TYRE["p_ky1"] == pytest.approx(21.92)
    load_f = car.m * G * car.b / (car.a + car.b)
    assert v.cf == pytest.approx(21.92 * load_f, rel=1e-12)
    assert v.cr == pytest.approx(21.92 * (car.m * G - load_f), rel=1e-12)
    assert (v.lf, v.lr, v.mass, v.drag) == (car.a, car.b, car.m, 0.0)
    assert v.cf * v.lf == pytest.approx(v.cr * v.lr, rel=1e-12)  # so: neutral steer


def test_table1_stays_the_default() -> None:
    assert VEHICLE_PRESETS["table1"] == VehicleParams()
    assert VehicleParams().preset == "table1"


def test_a_scenario_table_overrides_only_the_keys_it_gives() -> None:
    v2 = VEHICLE_PRESETS["commonroad_vehicle2"]
    table = {**dataclasses.asdict(VehicleParams()), "preset": "commonroad_vehicle2",
             "mass": 1200.0}
    v = vehicle_from_table(table, {"preset", "mass"})
    assert v == dataclasses.replace(v2, mass=1200.0)
    assert math.isclose(v.cf, v2.cf)


def test_scenario_with_a_preset(tmp_path) -> None:
    from cosim.scenario import load_scenario, scenario_to_dict, with_overrides

    path = tmp_path / "cr2.toml"
    path.write_text('[scenario]\nduration_s = 1.0\n[sv]\nlane = 0\nposition_m = 100\n'
                    'speed_kmh = 80\noccupant = 0.5\n[vehicle]\n'
                    'preset = "commonroad_vehicle2"\nlength_m = 4.6\n')
    s = load_scenario(path)
    assert s.vehicle == dataclasses.replace(VEHICLE_PRESETS["commonroad_vehicle2"], length=4.6)
    assert with_overrides(s, seed=7).vehicle == s.vehicle
    assert scenario_to_dict(s)["vehicle"]["preset"] == "commonroad_vehicle2"


def test_an_unknown_preset_is_an_input_error(tmp_path) -> None:
    from cosim.errors import InputError
    from cosim.scenario import load_scenario

    path = tmp_path / "bad.toml"
    path.write_text('[scenario]\nduration_s = 1.0\n[sv]\nlane = 0\nposition_m = 100\n'
                    'speed_kmh = 80\noccupant = 0.5\n[vehicle]\npreset = "vehicle2"\n')
    with pytest.raises(InputError, match="vehicle.preset.*commonroad_vehicle2"):
        load_scenario(path)
