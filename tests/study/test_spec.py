"""Study files: the grid dimensions, where a value came from, and what is checked against
the base scenario before a study runs (cosim.study.spec)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cosim.errors import InputError
from cosim.scenario import OVERRIDES
from cosim.study.run_table import PARAMETERS, Driver
from cosim.study.spec import DRIVER, GRID, check_study, load_study

BASE = Path(__file__).resolve().parents[1] / "bad_inputs" / "base.toml"


def _study(tmp_path: Path, extra: str = "") -> Path:
    path = tmp_path / "s.toml"
    path.write_text(f'[study]\nscenario = "{BASE}"\ndensities_veh_per_km_lane = [0, 5]\n'
                    f"seeds = [1, 2]\n{extra}")
    return path


def test_the_drivers_are_the_scenario_controllers() -> None:
    assert tuple(Driver) == DRIVER.choices


def test_every_grid_parameter_of_a_study_is_a_grid_dimension() -> None:
    """A variant may not change what runs.csv labels a row with: the grid's dimensions are
    exactly batch's parameters (variant aside) plus the duration, each a scenario override."""
    overrides = {o for o, _, _ in GRID.values()}
    assert overrides == {"density", "seed", "occupant", "mu", "share", "fleet_driver",
                         "controller", "plant", "duration"}
    assert overrides <= set(OVERRIDES)
    named = {"driver" if o == "controller" else o for o in overrides}
    assert set(PARAMETERS) - {"variant"} <= named


def test_errors_name_the_study_key_then_the_flag(tmp_path: Path) -> None:
    study = load_study(_study(tmp_path, "duration_s = 200.0\n"))
    with pytest.raises(InputError) as info:
        check_study(study)
    assert (info.value.source, info.value.key) == (str(tmp_path / "s.toml"), "study.duration_s")
    assert "base scenario" in info.value.allowed and "scenario.duration_s" in info.value.allowed
    flagged = study.with_flags(duration=300.0)
    with pytest.raises(InputError) as info:
        check_study(flagged)
    assert (info.value.source, info.value.key) == ("command line", "--duration")


def test_a_valid_study_returns_its_base_scenario(tmp_path: Path) -> None:
    study = load_study(_study(tmp_path, '[study.variants]\nslow = { replanning = true }\n'))
    base = check_study(study)
    assert base.path == BASE and study.size == 2 * 2 * 1


@pytest.mark.parametrize("name", ["", ".", "..", "../x", "a/b"])
def test_a_name_flag_that_escapes_is_refused(tmp_path: Path, name: str) -> None:
    with pytest.raises(InputError) as info:
        load_study(_study(tmp_path)).with_flags(name=name)
    assert info.value.key == "--name"


@pytest.mark.parametrize("name", ["study_density.toml", "study_replanning.toml"])
def test_shipped_studies_pass_every_check(name: str) -> None:
    from cosim.scenario import project_root

    study = load_study(project_root() / "scenarios" / name)
    assert check_study(study).path == study.scenario
