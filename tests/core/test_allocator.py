"""core.allocator: freed megabytes are kept for reuse, and the user's own malloc settings win."""
import json
import os
import subprocess
import sys

import pytest

from carav_stream.core.allocator import MALLOC_ENV

PROBE = """
import ctypes, json, resource, sys
# 4 kB pages only: with transparent huge pages (numpy asks for them on large arrays) the number of faults
# depends on how many huge pages the kernel can find free at that moment, which another process changes
assert ctypes.CDLL(None).prctl(41, 1, 0, 0, 0) == 0   # PR_SET_THP_DISABLE
import numpy as np
from carav_stream.core.allocator import keep_freed_memory
if sys.argv[1] != "default":
    assert keep_freed_memory(json.loads(sys.argv[1]))
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
def test_a_large_temporary_allocated_again_is_reused_instead_of_faulted_in_again_unless_the_user_says_otherwise():
    untuned, tuned = _faults("default"), _faults("{}")
    users = _faults(json.dumps({"MALLOC_MMAP_THRESHOLD_": str(1 << 20)}))   # the user's 1 MB threshold wins
    # 5 x 64 MB in 4 kB pages is 81920 faults each time it is faulted in again; reused, almost none
    assert untuned > 40000 and tuned < untuned / 10 and users > untuned / 2, (untuned, tuned, users)


def test_a_scratch_buffer_is_reused_per_name_and_thread_grown_when_asked_for_more():
    import threading

    import numpy as np

    from carav_stream.core.allocator import scratch
    a = scratch("test-a", 100, np.float32)
    assert a.shape == (100,) and a.dtype == np.float32
    assert np.shares_memory(scratch("test-a", 50, np.float32), a)          # reused, a view of the same memory
    assert not np.shares_memory(scratch("test-b", 50, np.float32), a)      # another name, another buffer
    assert scratch("test-a", 50, np.float64).dtype == np.float64           # another dtype, a new buffer
    assert scratch("test-a", 1000, np.float64).shape == (1000,)            # grown
    other = []
    t = threading.Thread(target=lambda: other.append(scratch("test-a", 100, np.float64)))
    t.start()
    t.join()
    assert not np.shares_memory(other[0], scratch("test-a", 100, np.float64))   # each thread its own
