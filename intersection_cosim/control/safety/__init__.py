"""The safety layers under every decision of a controller that commands vehicles.

* :mod:`~intersection_cosim.control.safety.onboard`: each commanded vehicle's own longitudinal
  guard against the vehicle ahead of it, whatever that vehicle is (applied by the simulator adapter
  every SUMO step).
* :mod:`~intersection_cosim.control.safety.filter`: the junction guard of the game controllers, its
  named rules in :mod:`~intersection_cosim.control.safety.rules`.
"""
