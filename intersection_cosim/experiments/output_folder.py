"""A run's output folder: written into a temporary folder beside it and renamed into place when
the run has finished, so a crashed or interrupted run leaves no half-written results."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from intersection_cosim.errors import InputError
from intersection_cosim.results.layout import RUN_MARKER


def prepare_output(out: Path, force: bool = False) -> Path:
    """Check that ``out`` can be written and return the temporary folder to write into.

    ``out`` must be new, an empty folder or, with ``force``, a previous run's folder (replaced
    when the new run has finished); anything else is refused.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("--out", "out", str(out), "is a file, not a folder")
    if (out / RUN_MARKER).is_file():
        if not force:
            raise InputError("--out", "out", str(out), f"holds a finished run ({RUN_MARKER}); use --force to "
                             "replace it, or another --out")
    elif out.is_dir() and any(out.iterdir()):
        raise InputError("--out", "out", str(out), "exists and is not a previous run's folder; not overwriting it")
    parent = out.parent if str(out.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=parent))
    except OSError as exc:
        raise InputError("--out", "out", str(out), f"cannot be written ({exc.strerror})") from None
    umask = os.umask(0)
    os.umask(umask)
    tmp.chmod(0o777 & ~umask)  # mkdtemp makes it private; a run folder is an ordinary folder
    return tmp


def finish_output(tmp: Path, out: Path) -> None:
    """Atomically put the finished run in place (replacing a previous run's folder)."""
    if out.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
        os.replace(out, old / "run")
        os.replace(tmp, out)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(tmp, out)
