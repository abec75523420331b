"""The policy registry (cosim.driving.registry): a new policy plugs in with one
registration line and runs through real SUMO; a name is taken once; the scenario key
`[planner] policy`, its docs and `cosim compare`'s variants read the registry."""

from __future__ import annotations

import numpy as np
import pytest

from cosim.driving.base import DrivingContext, Manoeuvres, Messages, PolicyStatus
from cosim.driving.following import CarFollowing
from cosim.driving.gap.policy import GapPolicy
from cosim.driving.paper import PaperPolicy
from cosim.driving.registry import PLANNED, names, policy_class, register, unregister
from cosim.driving.sumo import SumoPolicy
from cosim.errors import InputError
from cosim.run.loop import simulate
from cosim.scenario import PLANNER_FIELDS, load_scenario, project_root, with_overrides
from cosim.traffic.world import Scene, SVState

CASE1 = project_root() / "scenarios" / "paper_case1_overtaking.toml"


class NeverChange:
    """A policy that never changes lanes: it follows its leader in its lane, always."""

    listens = False  # it never plans: the V2V channel need not run
    needs_planner = True  # our plant and controller fly its reference
    asks_for_gaps = False
    prediction = None

    def __init__(self, ctx: DrivingContext) -> None:
        self.following = CarFollowing(ctx, ctx.decision)
        self.wall = 0.0

    def status(self, sv: SVState) -> PolicyStatus:
        return PolicyStatus(target_lane=None, changing=False, manoeuvring=False,
                            leader_gap=self.following.leader_gap,
                            idm_accel=self.following.accel)

    def update(self, t: float, scene: Scene, messages: Messages):  # noqa: ANN201
        self.following.update(scene.sv, scene, allow_change=False)
        return self.following.reference(t, scene.sv)

    def summary(self, t: np.ndarray, y: np.ndarray) -> Manoeuvres:
        return Manoeuvres(lane_changes=[], starts=[], targets=[], ends=[], requests=0,
                          planner_calls=0, outcomes={"replan": 0, "abort": 0, "brake": 0},
                          first_start=None, plans=[])


@pytest.fixture
def never() -> object:
    yield register("never", NeverChange)  # the one registration line
    unregister("never")


def test_the_built_in_policies_are_registered_in_order() -> None:
    assert names() == ("paper", "sumo", "gap")
    assert tuple(PLANNED) == ("paper", "gap")  # sumo is chosen by the controller
    assert (policy_class("paper"), policy_class("gap"), policy_class("sumo")) == (
        PaperPolicy, GapPolicy, SumoPolicy)
    assert GapPolicy.name == "gap"


def test_a_name_is_taken_once() -> None:
    with pytest.raises(ValueError, match="registered already"):
        register("paper", NeverChange)
    assert policy_class("paper") is PaperPolicy
    with pytest.raises(TypeError, match="update"):
        register("broken", type("Broken", (), {"status": print, "summary": print}))
    assert "broken" not in names()
    with pytest.raises(InputError, match="one of 'paper', 'sumo', 'gap'"):
        policy_class("nope")


def test_a_registered_policy_is_a_scenario_key_value_and_a_compare_variant(never: object
                                                                            ) -> None:
    from cosim.commands.compare import drivers

    field = next(f for f in PLANNER_FIELDS if f.key == "policy")
    assert "never" in field.allowed()
    assert "mimo_never" in drivers("paper")
    unregister("never")
    assert "never" not in field.allowed()
    with pytest.raises(InputError, match="policy"):
        with_overrides(load_scenario(CASE1), policy="never")
    register("never", NeverChange)


def test_a_new_policy_runs_through_real_sumo(never: object) -> None:
    """Paper case 1 asks for a change to lane 1 at once: the new policy ignores it and
    keeps lane 0 behind its slow leader, in SUMO, without a collision."""
    sc = with_overrides(load_scenario(CASE1), policy="never", duration=3.0)
    assert sc.planner.policy == "never"
    r = simulate(sc)
    m = r.metrics
    assert r.plans == [] and m["lane_changes"] == 0 and m["plans"] == 0
    assert m["collisions"] == 0 and m["final_lane"] == sc.sv.lane
    y = r.trace["y_m"]
    assert np.max(np.abs(y - r.road.lane_center(sc.sv.lane))) < 0.05
    assert np.all(r.trace["changing"] == 0)
    # it followed: the car-following acceleration was recorded every step
    assert np.all(np.isfinite(r.trace["idm_accel_mps2"]))
