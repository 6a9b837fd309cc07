"""glibc's allocator, tuned for a worker that builds multi-megabyte answers again and again.

By default glibc returns freed memory to the OS as soon as 128 kB (growing to a few MB) sit free at
the top of the heap, and serves every block above its ``mmap`` threshold from fresh pages. A
worker that encodes a 4 MB answer, frees it and encodes the next then pays a page fault per 4 kB
page every time: on the VM this service was measured on, that doubled the time of a 10,000-point
spline (planning 1.7 -> 0.6 ms, columns encoding 6.6 -> 3.4 ms, in-process medians).

``tune_malloc(retain_bytes)`` keeps up to ``retain_bytes`` free at the top of the heap for reuse
(``M_TRIM_THRESHOLD``), serves blocks below half of it from the heap (``M_MMAP_THRESHOLD``, at most
glibc's 32 MiB), and uses at most ``ARENAS`` allocation arenas (``M_ARENA_MAX``), so a worker's
threads cannot each keep their own ``retain_bytes``: the retained memory of a worker stays about
``ARENAS x retain_bytes``. Larger blocks (a streamed answer's chunks are far below it) still come
from ``mmap`` and go back at once. Without glibc (musl, macOS) it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util

M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
M_ARENA_MAX = -8
MMAP_THRESHOLD_MAX = 32 * 1024 * 1024
"""glibc's ceiling for ``M_MMAP_THRESHOLD`` on 64-bit systems in [bytes]."""
ARENAS = 2
"""Allocation arenas per process: the route threads mostly hold the GIL, so they rarely contend."""


def tune_malloc(retain_bytes: int) -> bool:
    """Tune glibc's ``malloc`` for this process; ``retain_bytes`` <= 0 leaves glibc's defaults.

    Returns True when glibc took every setting (False: not glibc, or a value refused)."""
    if retain_bytes <= 0:
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    settings = (
        (M_ARENA_MAX, ARENAS),
        (M_TRIM_THRESHOLD, min(retain_bytes, 2**31 - 1)),
        (M_MMAP_THRESHOLD, min(retain_bytes // 2, MMAP_THRESHOLD_MAX)),
    )
    return all(mallopt(option, value) == 1 for option, value in settings)
