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
