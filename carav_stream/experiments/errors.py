"""The experiments' own error: a setting an experiment refuses, or a command a document quotes that failed. Its
message is one line naming the setting or the command; the command line chooses the exit code."""
from __future__ import annotations

__all__ = ["ExperimentError"]


class ExperimentError(Exception):
    """An experiment refused its settings, or a quoted command did not run to its end; the message says which."""
