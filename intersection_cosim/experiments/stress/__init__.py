"""``intersection-cosim stress``: seeded and adversarial search of a scenario's variants for
collisions, locks and near misses, each failure written as a scenario file that replays it."""
