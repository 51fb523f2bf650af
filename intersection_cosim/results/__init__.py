"""What a run and a sweep leave on disk, and the metrics computed from it.

The layer below both ``experiments`` (which writes run and sweep folders) and ``report`` (which
only reads them): file names and columns (``layout``), reading SUMO's XML outputs
(``sumo_outputs``), per-vehicle and per-pair metrics (``metrics``) and a sweep folder's spec and
table (``sweep_folder``). Nothing here runs a simulation or imports ``experiments`` or ``report``.
"""
