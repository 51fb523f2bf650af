"""Vehicle bodies (models/bodies.py): the place beside a body, as a lane change would take it."""

import numpy as np

from intersection_cosim.models.bodies import beside_occupied

L, W = 4.5, 1.8  # [m] body length and width
LANE = 3.2  # [m] lane width: the sideways shift of a lane change


def _beside(xs, speeds, who, shift, margin=1.0, dt=0.1, ys=None):
    """Every vehicle heading east (heading 0) on y = ``ys`` (default 0 for the first, LANE for the rest)."""
    n = len(xs)
    ys = [0.0] + [LANE] * (n - 1) if ys is None else ys
    return beside_occupied(np.array(xs, float), np.array(ys, float), np.zeros(n), np.full(n, L), np.full(n, W),
                           np.array(speeds, float), np.array(who), np.array(shift, float), margin, dt)


def test_a_body_beside_takes_the_place_and_one_well_ahead_does_not():
    # the other's rear 0.5 m ahead of our front (inside the 1 m margin), then 3 m ahead
    assert _beside([0.0, 5.0], [0.0, 0.0], [0], [LANE]).tolist() == [True]
    assert _beside([0.0, 7.5], [0.0, 0.0], [0], [LANE]).tolist() == [False]
    # the same place to the right is empty (the other is on the left)
    assert _beside([0.0, 0.0], [0.0, 0.0], [0], [-LANE]).tolist() == [False]


def test_a_follower_that_reaches_the_place_within_the_step_takes_it():
    # the other's front 1.5 m behind our rear: free at rest, taken if it drives 10 m/s (1 m in 0.1 s)
    follower = -L - 1.5
    assert _beside([0.0, follower], [0.0, 0.0], [0], [LANE]).tolist() == [False]
    assert _beside([0.0, follower], [0.0, 10.0], [0], [LANE], margin=0.6).tolist() == [True]
    assert _beside([0.0, follower], [0.0, 10.0], [0], [LANE], margin=0.4).tolist() == [False]


def test_its_own_body_does_not_take_the_place_and_each_place_is_answered_alone():
    # two candidates: the first has a body beside it, the second (far away) does not
    taken = _beside([0.0, 1.0, 100.0], [0.0, 0.0, 0.0], [0, 2], [LANE, LANE], ys=[0.0, LANE, 0.0])
    assert taken.tolist() == [True, False]
    assert _beside([0.0], [0.0], [0], [0.0]).tolist() == [False]  # alone: nothing takes it


def test_the_compiled_check_agrees_with_the_separating_axes_of_every_pair():
    """Random scenes: the answer is the same as body_corners + bodies_overlap over all pairs."""
    from intersection_cosim.models.bodies import bodies_overlap, body_corners
    rng = np.random.default_rng(7)
    agree = checked = taken = 0
    for _ in range(40):
        n = 25
        x, y = rng.uniform(0, 120, n), rng.uniform(0, 30, n)
        heading, speed = rng.uniform(-np.pi, np.pi, n), rng.uniform(0, 12, n)
        length, width = rng.uniform(3.5, 12, n), rng.uniform(1.6, 2.5, n)
        who, shift = np.arange(0, n, 2), rng.choice([-3.2, 3.2], len(range(0, n, 2)))
        got = beside_occupied(x, y, heading, length, width, speed, who, shift, 0.8, 0.1)
        sweep = speed * 0.1
        for k, i in enumerate(who):
            d = np.array([np.cos(heading[i]), np.sin(heading[i])])
            front = np.array([x[i], y[i]]) + (sweep[i] + 0.8) * d + shift[k] * np.array([-d[1], d[0]])
            place = body_corners(front[:1], front[1:], heading[i:i + 1], [length[i] + sweep[i] + 1.6], width[i:i + 1])
            others = [j for j in range(n) if j != i]
            bodies = body_corners(x[others] + sweep[others] * np.cos(heading[others]),
                                  y[others] + sweep[others] * np.sin(heading[others]), heading[others],
                                  length[others] + sweep[others], width[others])
            expect = bool(bodies_overlap(place, bodies).any())
            agree += expect == bool(got[k])
            checked += 1
            taken += expect
    assert agree == checked and checked == 40 * 13
    assert 0.2 * checked < taken < 0.8 * checked  # both answers are exercised
