"""scripts/plot_av_share.py: which run folders it reads and what it prints per share."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "plot_av_share.py"


def _run(folder: Path, controller: str, travel_time: float, drivers: list[str]) -> None:
    folder.mkdir(parents=True)
    (folder / "summary.json").write_text(json.dumps({"controller": controller, "counts": {"collisions": 0},
                                                     "metrics": {"mean_travel_time": travel_time}}))
    (folder / "vehicles.csv").write_text("vehicle,driver\n" + "".join(f"v{n},{d}\n" for n, d in enumerate(drivers)))


def test_it_reads_run_and_compare_folders_and_averages_the_seeds(tmp_path):
    """A `run --out` folder named av0.5 and two compare folders av_share_0.50 (seeds 1, 2) are one
    point at share 0.5 (mean 21 s of 20, 21 and 22 s); a game run with no share in its name is
    skipped, a baseline's is drawn whatever its name."""
    _run(tmp_path / "medium_av0.5-nash-s1", "nash", 20.0, ["av", "human"])
    _run(tmp_path / "cmp" / "nash-seed1-av_share_0.50", "nash", 21.0, ["av", "av", "human", "human"])
    _run(tmp_path / "cmp" / "nash-seed2-av_share_0.50", "nash", 22.0, ["av", "human"])
    _run(tmp_path / "cmp" / "nash-seed1-av_share_1.00", "nash", 18.0, ["av"])
    _run(tmp_path / "nash-seed3", "nash", 99.0, ["av"])
    _run(tmp_path / "sumo-priority-seed1", "sumo-priority", 25.0, ["av"])
    folders = [str(p) for p in (tmp_path / "medium_av0.5-nash-s1", tmp_path / "nash-seed3", tmp_path / "sumo-priority-seed1",
                                *sorted((tmp_path / "cmp").iterdir()))]
    out = tmp_path / "fig.png"
    done = subprocess.run([sys.executable, str(SCRIPT), *folders, "--out", str(out)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "nash av_share 0.5 (realised 0.50): 21.00 +- 0.82 s, 3 runs" in done.stdout
    assert "nash av_share 1 (realised 1.00): 18.00" in done.stdout
    assert "skipped" in done.stderr and "nash-seed3" in done.stderr
    assert "sumo-priority: 25.00 +- 0.00 s over 1 runs" in done.stdout  # a baseline needs no share
    assert out.stat().st_size > 10_000
