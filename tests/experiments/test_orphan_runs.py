"""A run's own process ends when the sweep or stress search that started it is killed hard."""

from __future__ import annotations

import os
import subprocess
import sys
import time

CHILD = ("import os, time; from intersection_cosim.experiments.executors import PARENT_ENV, _exit_when_orphaned; "
         "_exit_when_orphaned(int(os.environ.get(PARENT_ENV, os.getppid())), poll=0.05); time.sleep(30)")
# starts the run as execute_job does (its pid in the environment) and dies at once, as under kill -9
PARENT = ("import os, subprocess, sys; from intersection_cosim.experiments.executors import PARENT_ENV; "
          "p = subprocess.Popen([sys.executable, '-c', sys.argv[1]], stdout=subprocess.DEVNULL, "
          "stderr=subprocess.DEVNULL, env={**os.environ, PARENT_ENV: str(os.getpid())}); "
          "print(p.pid, flush=True); os._exit(0)")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as f:  # a zombie waits for init to reap it: gone all the same
        return f.read().split(")")[-1].split()[0] != "Z"


def test_a_run_left_behind_by_its_killed_parent_ends_within_a_second():
    out = subprocess.run([sys.executable, "-c", PARENT, CHILD], capture_output=True, text=True, timeout=60)
    child = int(out.stdout.split()[0])
    deadline = time.monotonic() + 5.0
    while _alive(child) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _alive(child)


def test_a_run_whose_parent_lives_goes_on():
    child = subprocess.Popen([sys.executable, "-c", CHILD])
    try:
        time.sleep(1.0)
        assert child.poll() is None
    finally:
        child.kill()
        child.wait()
