"""Shared test settings: hypothesis runs derandomized in CI, with small example counts everywhere; the test
processes keep freed memory for reuse as carav's commands and nodes do (core.allocator)."""
import os

from hypothesis import HealthCheck, settings

from carav_stream.core.allocator import keep_freed_memory

keep_freed_memory()

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("ci" if os.environ.get("CI") else "dev")


def pytest_collection_modifyitems(items):
    """Longest first: the document checks (each re-runs a quoted command, up to a minute or more), then the tests
    that start processes, then the other tests marked slow, then the rest, each group in its own order. Under
    pytest-xdist the list is then dealt round-robin into one contiguous share per worker: `--dist worksteal` hands
    each worker a contiguous share of the collection and an idle worker steals from the end of a busy one's queue,
    so every worker starts on long tests, what is stolen late is short, and the workers end together."""
    def group(item) -> tuple[bool, bool, bool]:
        slow = item.get_closest_marker("slow") is not None
        return (not (slow and item.nodeid.startswith("tests/cli/test_reproduce.py")),
                item.get_closest_marker("integration") is None, not slow)
    items.sort(key=group)
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if workers > 1:
        items[:] = [item for share in range(workers) for item in items[share::workers]]
