"""A sweep on a Dask cluster (a LocalCluster of process workers on loopback) equals the local one."""

from __future__ import annotations

import pytest

from intersection_cosim.cli import main
from sweep_helpers import comparable, read_table, run_children, sweep_args

pytestmark = pytest.mark.slow


def test_dask_sweep_equals_local_sweep(reference_sweep, tmp_path):
    distributed = pytest.importorskip("distributed")
    import psutil

    before = {p.pid for p in psutil.Process().children(recursive=True)}
    out = tmp_path / "dask-sweep"
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        assert main(sweep_args(out, "--dask-scheduler", cluster.scheduler_address)) == 0
        workers = cluster.scheduler_info["workers"]
        assert len(workers) == 2
    assert (out / "sweep.csv").is_file()
    local, remote = read_table(reference_sweep), read_table(out)
    assert list(remote["status"]) == ["ok"] * len(local)
    import pandas as pd

    pd.testing.assert_frame_equal(comparable(remote), comparable(local))
    # Nothing left behind: no run process, no Dask worker (the resource tracker of multiprocessing
    # lives as long as this process and is not ours).
    assert run_children() == []
    left = [p for p in psutil.Process().children(recursive=True) if p.pid not in before]
    left = [p for p in left if "resource_tracker" not in " ".join(p.cmdline())]
    assert left == []
