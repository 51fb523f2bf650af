"""intersection-cosim: SUMO co-simulation of game-theoretic conflict resolution for
autonomous vehicles at an unsignalized four-arm intersection (Hang et al.)."""

__version__ = "0.1.0"
