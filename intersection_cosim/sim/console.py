"""SUMO's console: libsumo writes its warnings to this process's standard error (file descriptor
2) besides its ``--error-log`` file; a run keeps them in the file and off the console."""

from __future__ import annotations

import contextlib
import os
import sys
from typing import Iterator


@contextlib.contextmanager
def stderr_silenced() -> Iterator[None]:
    """File descriptor 2 goes to the null device inside the block and is restored after it (also
    on an exception, which is therefore reported on the console as usual)."""
    sys.stderr.flush()
    saved = os.dup(2)
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 2)
        yield
    finally:
        sys.stderr.flush()
        os.dup2(saved, 2)
        os.close(saved)
        os.close(null)
