"""Tests of cosim.compiled: numba compiles the hot functions without
changing their arithmetic, compiled callers call compiled callees, and numba is
imported only when a compiled function is first called."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np

from cosim import compiled
from cosim.control.warm import warm_up
from cosim.params import VehicleParams
from cosim.vehicle import bicycle, twotrack
from cosim.vehicle.plant import PlantStart

VEHICLE = VehicleParams()


def test_compiled_derivatives_equal_the_interpreted_functions() -> None:
    warm_up()
    plant = twotrack.TwoTrackPlant(VEHICLE, 0.6, PlantStart(vx=25.0))
    rng = np.random.default_rng(3)
    for _ in range(50):
        n = plant.state.size
        s = plant.state + rng.normal(0.0, 0.05, n) * np.abs(plant.state + 1.0)
        inputs = np.array([math.cos(0.02), math.sin(0.02), *rng.normal(0.0, 300.0, 4)])
        out_c, out_p = np.empty(n), np.empty(n)
        forces_c, forces_p = np.zeros(14), np.zeros(14)
        twotrack.twotrack_derivative(s, plant._const, inputs, forces_c, out_c)
        twotrack.twotrack_derivative.py_func(s, plant._const, inputs, forces_p, out_p)
        np.testing.assert_allclose(out_c, out_p, rtol=1e-13, atol=1e-12)
        np.testing.assert_allclose(forces_c, forces_p, rtol=1e-13, atol=1e-12)
    bike = bicycle.BicyclePlant(VEHICLE, PlantStart(vx=25.0, vy=0.3, yaw_rate=0.05))
    bike.set_inputs(0.01, (100.0, -50.0, 200.0, 20.0))
    out_c, out_p = np.empty(6), np.empty(6)
    bicycle.bicycle_derivative(bike.state, bike._const, bike._inputs, out_c)
    bicycle.bicycle_derivative.py_func(bike.state, bike._const, bike._inputs, out_p)
    np.testing.assert_allclose(out_c, out_p, rtol=1e-13, atol=1e-12)


def test_compiled_callers_see_compiled_callees() -> None:
    warm_up()
    # numba compiled the caller against the compiled callee (it looks callees up in the
    # caller's globals: the copy compiled.py gives it), and no module name was rebound
    assert twotrack.twotrack_step.signatures
    assert isinstance(twotrack.twotrack_step, compiled._Deferred)
    assert twotrack.twotrack_derivative.signatures  # compiled as the step's callee
    assert twotrack.twotrack_step.compiled.py_func.__globals__["twotrack_derivative"] is (
        twotrack.twotrack_derivative.compiled)


def test_importing_the_closed_loop_does_not_import_numba() -> None:
    code = ("import sys, cosim.control.closed_loop, cosim.run.loop; "
            "sys.exit(1 if 'numba' in sys.modules else 0)")
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0


def test_the_compiled_modules_declare_every_compiled_function() -> None:
    """The cache's folder is named by the sources of the functions declared so far:
    `load_compiled_modules` must reach every file with one, or a warm cache reads cold."""
    from pathlib import Path

    package = Path(compiled.__file__).parent
    with_njit = {str(p) for p in package.rglob("*.py") if "\n@njit" in p.read_text()}
    code = ("import inspect; from cosim import compiled; compiled.load_compiled_modules(); "
            "print('\\n'.join(sorted({inspect.getsourcefile(d.py_func) "
            "for d in compiled._PENDING})))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert set(done.stdout.split()) == with_njit
