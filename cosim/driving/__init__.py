"""When and how the SV changes lanes: the lane-change policies behind one interface
(base: `LaneChangePolicy`, the `DrivingContext` each is built from, its ports to the
world) and one registry (registry: name -> class, duplicates refused).

- layout: the road as lanes (membership, centres, gaps along a lane, speed bands)
- view: the SV and the traffic as the decision functions take them (SVView, TrafficView)
- plans: the plans.csv rows a policy writes, their triggers, the planner calls timed
- rule: the paper's trigger (decision rule) and IDM car following
- following: car following in the SV's lane and the lane-keeping reference
- lane_end: the SV on a lane that ends (one API: `SVLaneEnds`), the stop before the end
- manoeuvre: plan / fly / re-check (a component policies use)
- recheck: what replaces a plan under way that now collides: replan / abort / brake
- paper: the paper's SV ("paper")
- gap/: the gap-seeking policy ("gap"): geometry, decision, policy
- sumo: the SUMO-driven SV's policy ("sumo", controller "sumo")

Importing this package registers the built-in policies, in this order.
"""

from cosim.driving import paper, sumo  # noqa: F401  (they register themselves)
from cosim.driving.gap import policy  # noqa: F401
