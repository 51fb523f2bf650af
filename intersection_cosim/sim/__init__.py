"""The simulator layer: the libsumo adapter (the only libsumo import) and the step scheduler."""
