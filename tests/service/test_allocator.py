"""service.allocator: glibc malloc tuning keeps freed multi-megabyte blocks for reuse."""

from __future__ import annotations

import ctypes.util
import subprocess
import sys

import pytest

from service.allocator import tune_malloc

GLIBC = ctypes.util.find_library("c") is not None and sys.platform.startswith("linux")

# A worker's life in miniature: an answer's few multi-megabyte buffers (samples, their text, the
# body), all let go at the end, again and again; count the page faults.
PROBE = """
import resource, sys
import numpy as np
from service.allocator import tune_malloc
print(tune_malloc(int(sys.argv[1])), file=sys.stderr)
def answer():
    return [np.ones(n) for n in (150_000, 300_000, 500_000, 500_000)]  # 1.2 to 4 MB each

answer()  # the first one faults
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(20):
    buffers = answer()
    del buffers
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _faults(retain_bytes: int) -> int:
    out = subprocess.run(
        [sys.executable, "-c", PROBE, str(retain_bytes)],
        capture_output=True, text=True, check=True, timeout=60,
    )  # fmt: skip
    return int(out.stdout.strip())


def test_zero_leaves_glibc_alone():
    assert tune_malloc(0) is False


@pytest.mark.skipif(not GLIBC, reason="glibc only")
def test_freed_blocks_are_reused_without_page_faults():
    # By default glibc hands the 11 MB back to the OS after each answer (more than twice its
    # largest block sits free at the top of the heap), so every answer maps fresh pages: about
    # 2,700 faults each; tuned, the same memory is reused, already mapped.
    default, tuned = _faults(0), _faults(32 * 1024 * 1024)
    assert default > 20 * 1000
    assert tuned < 500
