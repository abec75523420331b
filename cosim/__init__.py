"""cosim: an automated car changes lanes through real SUMO highway traffic.

Implements the planner and controller of Wang et al., "Longitudinal and lateral
control of autonomous vehicles in multi-vehicle driving environments", IET ITS
14(8) 2020, and goes beyond it where the paper stops.
"""

__version__ = "0.1.0"
