"""The safety layers under every decision of a controller that commands vehicles.

* :mod:`~intersection_cosim.control.safety.onboard`: each commanded vehicle's own longitudinal
  guard against the vehicle ahead of it, whatever that vehicle is (applied by the simulator adapter
  every SUMO step).
* :mod:`~intersection_cosim.control.safety.filter`: the junction guard of the game controllers,
  on their accelerations, from the tracked vehicles and their plans.
"""

from intersection_cosim.control.safety.filter import (SafetyFilter, braking_plan, krauss_safe_speed, occupancy,
                                                      occupancy_times, reach_times, stopping_acceleration)

__all__ = ["SafetyFilter", "braking_plan", "krauss_safe_speed", "occupancy", "occupancy_times", "reach_times",
           "stopping_acceleration"]
