"""Our post-encroachment time of a conflicting pair, on constructed trajectories of known PET."""

import math

import numpy as np
import pandas as pd

from intersection_cosim.results.metrics import crossing_time, post_encroachment_time


def _traj(t0, s0, v, t_end=10.0, dt=0.1):
    """A vehicle at constant speed v [m/s] with its front at s0 [m] at t0 [s]."""
    t = np.round(np.arange(t0, t_end + 1e-9, dt), 6)
    return pd.DataFrame({"s": s0 + v * (t - t0)}, index=pd.Index(t, name="time"))


def test_crossing_time_interpolates_between_steps():
    t = np.array([0.0, 0.1, 0.2])
    s = np.array([0.0, 1.0, 3.0])
    assert math.isclose(crossing_time(t, s, 2.0), 0.15)
    assert math.isnan(crossing_time(t, s, 5.0))  # never reached
    assert math.isnan(crossing_time(t, s, -1.0))  # already past at the first step: moment unknown


def test_pet_runs_from_first_rear_out_to_second_front_in():
    # a: zone (10, 20) m at 10 m/s from s = 0 at t = 0 -> rear out at 2.0 s.
    # b: zone (5, 15) m at 5 m/s from s = -15 m at t = 0 -> front in at 4.0 s. PET 2.0 s.
    a, b = _traj(0.0, 0.0, 10.0), _traj(0.0, -15.0, 5.0)
    assert math.isclose(post_encroachment_time(a, b, (10.0, 20.0), (5.0, 15.0)), 2.0, abs_tol=1e-9)
    # the same pair seen from b's side
    assert math.isclose(post_encroachment_time(b, a, (5.0, 15.0), (10.0, 20.0)), 2.0, abs_tol=1e-9)


def test_pet_grows_with_the_second_vehicles_delay_and_is_zero_when_both_occupy_the_zone():
    a = _traj(0.0, 0.0, 10.0)
    pets = [post_encroachment_time(a, _traj(0.0, -s0, 5.0), (10.0, 20.0), (5.0, 15.0)) for s0 in (5.0, 10.0, 20.0)]
    # b's front in at 2.0, 3.0, 5.0 s against a's rear out at 2.0 s
    assert np.allclose(pets, [0.0, 1.0, 3.0], atol=1e-9)
    both_inside = post_encroachment_time(a, _traj(0.0, 6.0, 5.0), (10.0, 20.0), (5.0, 15.0))
    assert both_inside == 0.0


def test_pet_is_unknown_when_a_vehicle_never_enters():
    a, b = _traj(0.0, 0.0, 10.0), _traj(0.0, -100.0, 5.0, t_end=3.0)
    assert math.isnan(post_encroachment_time(a, b, (10.0, 20.0), (5.0, 15.0)))
