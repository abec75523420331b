"""Scenario files: SI conversion, defaults, path resolution, overrides, export,
and the declarative field mechanism the study files reuse."""

from __future__ import annotations

import json
import shutil
import tomllib
from pathlib import Path
from typing import Any

import pytest

from cosim.errors import InputError
from cosim.params import ControllerGains, PlannerConfig, RoadParams, VehicleParams
from cosim.scenario import (
    OVERRIDES,
    Scenario,
    load_scenario,
    project_root,
    scenario_from_dict,
    scenario_to_dict,
    with_overrides,
)
from cosim.validation import REQUIRED, Field, validate_table

BASE = Path(__file__).resolve().parent / "bad_inputs" / "base.toml"
MINIMAL = """
[scenario]
duration_s = 5.0
[sv]
lane = 0
position_m = 200.0
speed_kmh = 80.0
"""


def _doc() -> dict[str, Any]:
    return tomllib.loads(BASE.read_text())


def _write(folder: Path, text: str, name: str = "s.toml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


def test_units_are_converted_to_si() -> None:
    s = load_scenario(BASE)
    assert s.sv.speed == pytest.approx(100.0 / 3.6, rel=1e-15)
    assert s.tvs[0].speed == pytest.approx(95.0 / 3.6, rel=1e-15)
    assert s.tvs[0].gap == 40.0 and s.tvs[1].gap == -30.0
    assert s.sv.lane_changes[0].at == 1.0 and s.sv.lane_changes[0].target_lane == 2
    lc = s.tvs[0].lane_change
    assert lc is not None and (lc.start, lc.target_lane, lc.tau) == (2.0, 0, 4.0)
    assert lc.target_speed is None and lc.broadcast == "reference"
    assert s.road.speed_bands[1] == pytest.approx((25.0, 110.0 / 3.6))
    assert s.n_steps == 200


def test_defaults_come_from_the_parameter_dataclasses(tmp_path: Path) -> None:
    s = load_scenario(_write(tmp_path, MINIMAL, "minimal_case.toml"))
    assert s.name == "minimal_case"  # the file's stem
    assert s.vehicle == VehicleParams()
    assert s.gains == ControllerGains()
    assert s.planner == PlannerConfig()
    assert s.road == RoadParams()
    assert (s.step, s.substeps, s.seed) == (0.05, 10, 0)
    assert s.tvs == () and s.sv.lane_changes == ()
    assert (s.sv.plant, s.sv.controller, s.sv.decision) == ("twotrack", "mimo", False)
    assert s.sv.desired_speed is None
    assert s.traffic.density == 0.0 and s.v2v.loss == 0.0
    assert s.network == project_root() / "networks" / "highway.net.xml"


def test_overrides_of_table1_and_gains(tmp_path: Path) -> None:
    text = MINIMAL + "[vehicle]\nmass_kg = 1500\n[controller]\nky0 = 12.0\n"
    s = load_scenario(_write(tmp_path, text))
    assert s.vehicle.mass == 1500.0 and isinstance(s.vehicle.mass, float)
    assert s.vehicle.lf == VehicleParams().lf
    assert s.gains.ky0 == 12.0


def test_network_relative_to_the_scenario_file_first(tmp_path: Path) -> None:
    shutil.copy(project_root() / "networks" / "highway.net.xml", tmp_path / "highway.net.xml")
    s = load_scenario(_write(tmp_path, MINIMAL + '[road]\nnetwork = "highway.net.xml"\n'))
    assert s.network == tmp_path / "highway.net.xml"
    # Not beside the file: the project root.
    s = load_scenario(
        _write(tmp_path, MINIMAL + '[road]\nnetwork = "networks/highway.net.xml"\n', "b.toml")
    )
    assert s.network == project_root() / "networks" / "highway.net.xml"


def test_a_changed_network_file_is_read_again(tmp_path: Path) -> None:
    net = tmp_path / "highway.net.xml"
    shutil.copy(project_root() / "networks" / "highway.net.xml", net)
    path = _write(tmp_path, MINIMAL + '[road]\nnetwork = "highway.net.xml"\n')
    load_scenario(path)
    net.write_text("<routes/>\n")
    with pytest.raises(InputError, match="root <net>"):
        load_scenario(path)


def test_decision_scenarios_may_start_outside_the_band(tmp_path: Path) -> None:
    text = MINIMAL.replace("speed_kmh = 80.0", "speed_kmh = 50.0")
    with pytest.raises(InputError, match="sv.speed_kmh"):
        load_scenario(_write(tmp_path, text))
    s = load_scenario(_write(tmp_path, text.replace("lane = 0", "lane = 0\ndecision = true")))
    assert s.sv.decision and s.sv.speed == pytest.approx(50 / 3.6)
    # never above the lane's SUMO limit (90 km/h in lane 0): SUMO would not insert it
    fast = MINIMAL.replace("speed_kmh = 80.0", "speed_kmh = 100.0")
    with pytest.raises(InputError, match="lane 0's speed limit in the network, 90 km/h"):
        load_scenario(_write(tmp_path, fast.replace("lane = 0", "lane = 0\ndecision = true")))


def test_tv_changing_lanes_at_t0_may_sit_beside_the_sv(tmp_path: Path) -> None:
    """Case 5.3: TV1 in the target lane 0 m apart is fine; in the SV's own lane it is not."""
    tv = (
        '[[tv]]\nid = "tv1"\nlane = {lane}\ngap_m = 0.0\nspeed_kmh = 108.0\n'
        "[tv.lane_change]\nstart_s = {start}\ntarget_lane = 1\ntau_s = 4.0\n"
    )
    sv = MINIMAL.replace("lane = 0", "lane = 1").replace("80.0", "105.0")
    ok = load_scenario(_write(tmp_path, sv + tv.format(lane=2, start=0.0)))
    assert ok.tvs[0].lane == 2
    under_way = load_scenario(_write(tmp_path, sv + tv.format(lane=2, start=-1.5)))
    assert under_way.tvs[0].lane_change.start == -1.5  # type: ignore[union-attr]
    with pytest.raises(InputError, match=r"tv\[0\]\.gap_m"):
        load_scenario(
            _write(
                tmp_path,
                sv + tv.format(lane=1, start=0.0).replace("target_lane = 1", "target_lane = 2"),
            )
        )


def test_traffic_lane_changes_are_continuous_unless_sublane(tmp_path: Path) -> None:
    assert load_scenario(_write(tmp_path, MINIMAL)).traffic.lanechange_duration == 3.0
    s = load_scenario(_write(tmp_path, MINIMAL + "[traffic]\nsublane = true\n"))
    assert s.traffic.sublane and s.traffic.lanechange_duration == 0.0


def test_duration_multiple_of_step_tolerates_rounding(tmp_path: Path) -> None:
    text = MINIMAL.replace("duration_s = 5.0", "duration_s = 0.3\nstep_s = 0.1")
    s = load_scenario(_write(tmp_path, text))  # 0.3 / 0.1 = 2.9999999999999996
    assert s.n_steps == 3


def test_with_overrides_revalidates_and_keeps_the_original() -> None:
    s = load_scenario(BASE)
    t = with_overrides(
        s,
        density=20,
        mu=0.8,
        seed=7,
        occupant=0.2,
        controller="siso",
        plant="bicycle",
        duration=20.0,
        sv_speed=105 / 3.6,
    )
    assert t.traffic.density == 20.0 and t.road.mu == 0.8 and t.seed == 7
    assert t.sv.occupant == 0.2 and t.sv.controller == "siso" and t.sv.plant == "bicycle"
    assert t.duration == 20.0 and t.sv.speed == pytest.approx(105 / 3.6)
    assert (s.traffic.density, s.road.mu, s.seed, s.duration) == (0.0, 0.6, 1, 10.0)
    assert with_overrides(s, **{"vehicle.mass_kg": 1500}).vehicle.mass == 1500.0
    bold = with_overrides(s, occupant=0.9)
    assert with_overrides(bold, occupant=None).sv.occupant == 0.5  # None: back to the default


@pytest.mark.parametrize(
    ("changes", "key"),
    [
        ({"mu": 2.0}, "road.mu"),
        ({"density": -1}, "traffic.density_veh_per_km_lane"),
        ({"duration": 10.01}, "scenario.duration_s"),
        ({"controller": "human"}, "sv.controller"),
        ({"seed": True}, "scenario.seed"),
        ({"dencity": 5}, "dencity"),
        ({"sv.sped_kmh": 100}, "sv.sped_kmh"),
    ],
)
def test_with_overrides_rejects_like_a_file(changes: dict[str, Any], key: str) -> None:
    s = load_scenario(BASE)
    with pytest.raises(InputError) as info:
        with_overrides(s, **changes)
    assert info.value.key == key
    assert "(overrides)" in str(info.value)


def test_unknown_override_name_gets_a_suggestion() -> None:
    with pytest.raises(InputError, match="did you mean 'density'"):
        with_overrides(load_scenario(BASE), dencity=5)
    assert {"density", "seed", "occupant", "mu", "controller", "plant", "duration"} <= set(
        OVERRIDES
    )


def test_scenario_to_dict_is_json_and_round_trips(tmp_path: Path) -> None:
    s = load_scenario(BASE)
    d = scenario_to_dict(s)
    text = json.dumps(d, allow_nan=False)
    assert d["sv"]["speed_kmh"] == 100.0 and d["road"]["lane_speeds_kmh"][0] == [60.0, 90.0]
    assert d["tv"][0]["lane_change"]["tau_s"] == 4.0 and "lane_change" not in d["tv"][1]
    back = scenario_from_dict(json.loads(text), path=s.path)
    assert back == s
    assert hash(back) == hash(s)


def test_scenario_pickles_for_worker_processes() -> None:
    import pickle

    s = load_scenario(BASE)
    back = pickle.loads(pickle.dumps(s))
    assert back == s and back.document == s.document
    assert with_overrides(back, seed=9).seed == 9  # the document travels with it


def test_scenario_is_frozen() -> None:
    s = load_scenario(BASE)
    with pytest.raises(AttributeError):
        s.duration = 3.0  # type: ignore[misc]
    assert isinstance(s, Scenario)


# ------------------------------------------------------------------ the field mechanism

SPECS = (
    Field("count", int, lo=1, hi=10, default=REQUIRED),
    Field(
        "speed_kmh",
        float,
        name="speed",
        unit="km/h",
        lo=0,
        hi=200,
        lo_open=True,
        default=50 / 3.6,
        si_divisor=3.6,
    ),
    Field("mode", str, choices=("fast", "slow"), default="fast"),
    Field("verbose", bool, default=False),
)


def test_validate_table_fills_defaults_and_converts() -> None:
    out = validate_table("study.toml", "grid", {"count": 3, "speed_kmh": 72}, SPECS)
    assert out == {"count": 3, "speed": 20.0, "mode": "fast", "verbose": False}


@pytest.mark.parametrize(
    ("raw", "key", "fragment"),
    [
        ({}, "grid.count", "required: an integer in [1, 10]"),
        ({"count": 0}, "grid.count", "[1, 10]"),
        ({"count": 2.0}, "grid.count", "an integer"),
        ({"count": True}, "grid.count", "an integer"),
        ({"count": 1, "speed_kmh": 0}, "grid.speed_kmh", "(0, 200] km/h"),
        ({"count": 1, "speed_kmh": float("nan")}, "grid.speed_kmh", "finite"),
        ({"count": 1, "mode": "fsat"}, "grid.mode", "did you mean 'fast'"),
        ({"count": 1, "verbose": 1}, "grid.verbose", "true or false"),
        ({"count": 1, "speed": 3}, "grid.speed", "did you mean 'speed_kmh'"),
        ([1, 2], "grid", "a table"),
    ],
)
def test_validate_table_errors(raw: Any, key: str, fragment: str) -> None:
    with pytest.raises(InputError) as info:
        validate_table("study.toml", "grid", raw, SPECS)
    assert info.value.key == key
    message = str(info.value)
    assert message.startswith("study.toml: ") and fragment in message
    assert "\n" not in message


def test_schema_table_lists_every_key() -> None:
    from cosim.scenario import TABLES, schema_markdown

    text = schema_markdown()
    for name, specs in TABLES.items():
        for f in specs:
            assert f"`{name}.{f.key}`" in text
    assert "| `road.mu` | road friction coefficient | a finite number in [0.1, 1.2] | `0.6` " \
           "(override `mu`) |" in text
    assert "| `sv.decision` | change lanes by the traffic rule (leader slower, faster lane " \
           "free) | true or false | `false` (override `decision`) |" in text


def test_every_shipped_scenario_and_study_is_valid() -> None:
    from cosim.study.spec import load_study

    files = sorted((project_root() / "scenarios").glob("*.toml"))
    assert files, "no scenarios shipped"
    for path in files:
        if "study" in tomllib.loads(path.read_text()):
            assert load_study(path).size > 0
            continue
        s = load_scenario(path)
        assert s.path == path and s.n_steps > 0


def test_docs_list_every_scenario_key_as_the_code_validates_it() -> None:
    """docs/scenario_keys.md is the generated key reference; it must match the code."""
    from cosim.scenario import project_root, schema_markdown

    text = (project_root() / "docs" / "scenario_keys.md").read_text(encoding="utf-8")
    assert text.endswith(schema_markdown())


def test_route_and_sv_edge_on_the_one_edge_network(tmp_path: Path) -> None:
    """`[road] route` and `[sv] edge` may name the one edge; the scenario is the same one
    (its route kept as written, exported and read back), and absent they stay absent."""
    plain = load_scenario(_write(tmp_path, MINIMAL, "plain.toml"))
    assert plain.route is None and plain.sv.edge is None
    assert "route" not in scenario_to_dict(plain)["road"]
    text = MINIMAL.replace("[sv]\n", "[road]\nroute = [\"highway\"]\n[sv]\nedge = \"highway\"\n")
    s = load_scenario(_write(tmp_path, text, "routed.toml"))
    assert s.route == ("highway",) and s.sv.edge == "highway"
    d = scenario_to_dict(s)
    assert d["road"]["route"] == ["highway"] and d["sv"]["edge"] == "highway"
    assert scenario_from_dict(json.loads(json.dumps(d)), path=s.path) == s
    assert (s.sv.position, s.network) == (plain.sv.position, plain.network)


def test_lane_changes_may_say_a_direction_instead_of_a_lane() -> None:
    """`direction = "left" | "right"`: the lane next to the one the SV is in by then (the
    same scenario as with target lanes); both or neither is refused in one line."""
    doc = _doc()
    doc["sv"]["lane"] = 1
    doc["sv"]["lane_changes"] = [{"at_s": 1.0, "direction": "left"},
                                 {"at_s": 5.0, "direction": "right"},
                                 {"at_s": 8.0, "direction": "right"}]
    sc = scenario_from_dict(doc, path=BASE)
    assert [c.target_lane for c in sc.sv.lane_changes] == [2, 1, 0]
    assert all(c.direction is None for c in sc.sv.lane_changes)
    written = _doc()
    written["sv"]["lane"] = 1
    written["sv"]["lane_changes"] = [{"at_s": 1.0, "target_lane": 2},
                                     {"at_s": 5.0, "target_lane": 1},
                                     {"at_s": 8.0, "target_lane": 0}]
    assert scenario_from_dict(written, path=BASE).sv == sc.sv
    doc["sv"]["lane_changes"] = [{"at_s": 1.0, "direction": "left", "target_lane": 2}]
    with pytest.raises(InputError, match=r"lane_changes\[0\] = 2: either target_lane or"):
        scenario_from_dict(doc, path=BASE)
    doc["sv"]["lane_changes"] = [{"at_s": 1.0}]
    with pytest.raises(InputError, match=r"lane_changes\[0\].*either target_lane or"):
        scenario_from_dict(doc, path=BASE)
    doc["sv"]["lane_changes"] = [{"at_s": 1.0, "direction": "right"},
                                 {"at_s": 4.0, "direction": "right"}]
    with pytest.raises(InputError, match=r"\[1\].direction = 'right': a side with a lane"):
        scenario_from_dict(doc, path=BASE)


def test_fleet_is_off_by_default_and_checked_like_every_key() -> None:
    """[fleet]: no automated vehicle unless asked for; share in [0, 1]; vtypes name the
    user's own demand; the fleet is driven by our planner and controller, not SUMO."""
    s = load_scenario(BASE)
    assert not s.fleet.enabled and s.fleet.share == 0.0 and s.fleet.vtypes == ()
    assert with_overrides(s, **{"fleet.share": 0.2}).fleet.share == 0.2
    for changes, key, fragment in [
        ({"fleet.share": 1.5}, "fleet.share", "[0, 1]"),
        ({"fleet.vtypes": "av"}, "fleet.vtypes", "a list of at most 64"),
        ({"fleet.vtypes": ["av", "av"]}, "fleet.vtypes", "distinct"),
        ({"fleet.vtypes": ["av"]}, "fleet.vtypes", "own demand"),
        ({"fleet.share": 0.2, "controller": "sumo"}, "sv.controller", "with a [fleet]"),
    ]:
        with pytest.raises(InputError) as info:
            with_overrides(s, **changes)
        assert info.value.key == key and fragment in str(info.value), (changes, info.value)
        assert "\n" not in str(info.value)


def test_random_traffic_must_fit_where_the_routes_lanes_run_through() -> None:
    """From the on-ramp the lanes that run through begin beside the acceleration lane
    (s = 404 m): random traffic over more than they cover is refused before SUMO starts,
    naming the stretch (the run itself refused it without the file's name)."""
    root = Path(__file__).resolve().parents[1]
    doc = tomllib.loads((root / "scenarios" / "ramp_merge.toml").read_text())
    doc["road"]["route"] = ["ramp", "acc", "main1"]
    doc["sv"].update(edge="ramp", lane=0, position_m=100.0)
    doc["scenario"]["duration_s"] = 10.0
    doc["traffic"]["length_m"] = 1100.0
    with pytest.raises(InputError) as err:
        scenario_from_dict(doc, root / "scenarios" / "ramp_merge.toml", source="sc.toml")
    text = str(err.value)
    assert text.startswith("sc.toml: traffic.length_m = 1100.0: at most the 994 m of the route")
    assert "(s = 404 to 1399 m)" in text and "\n" not in text
    doc["traffic"]["length_m"] = 990.0
    assert scenario_from_dict(doc, root / "scenarios" / "ramp_merge.toml").traffic.length == 990.0
