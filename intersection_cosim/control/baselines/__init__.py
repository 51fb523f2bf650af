"""Baseline controllers to compare the game against: SUMO's own driver model and right of way
(``sumo_baseline``) and first-come-first-served reservations (``fcfs`` with ``reservations``)."""
