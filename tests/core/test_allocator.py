"""core.allocator: freed megabytes are kept for reuse, and the user's own malloc settings win."""
import os
import subprocess
import sys

import pytest

from carav_stream.core.allocator import MALLOC_ENV, keep_freed_memory

PROBE = """
import resource, sys
import numpy as np
from carav_stream.core.allocator import keep_freed_memory
if sys.argv[1] == "tuned":
    keep_freed_memory({})
a = np.ones(64 << 17); del a                     # 64 MB: beyond glibc's largest dynamic mmap threshold
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(5):
    b = np.ones(64 << 17); del b
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _faults(mode: str) -> int:
    env = {k: v for k, v in os.environ.items() if k not in MALLOC_ENV}
    done = subprocess.run([sys.executable, "-c", PROBE, mode], capture_output=True, text=True, env=env, check=True)
    return int(done.stdout)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_a_large_temporary_allocated_again_is_reused_instead_of_faulted_in_again():
    untuned, tuned = _faults("default"), _faults("tuned")
    assert untuned > 500 and tuned < 50, (untuned, tuned)


def test_settings_in_the_environment_are_left_to_the_user():
    applied = keep_freed_memory({"MALLOC_TRIM_THRESHOLD_": "0"})
    assert "MALLOC_TRIM_THRESHOLD_" not in applied
    assert set(applied) <= set(MALLOC_ENV)
