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
    that start processes, then the rest, each group in its own order. The workers of `dev.py test` then end
    together instead of one running a long check alone at the end."""
    def group(item) -> int:
        if item.nodeid.startswith("tests/cli/test_reproduce.py"):
            return 0
        return 1 if item.get_closest_marker("integration") else 2
    items.sort(key=group)
