"""The simulator layer: the SUMO adapter (libsumo headless, TraCI for sumo-gui), the GUI view and the step scheduler."""
