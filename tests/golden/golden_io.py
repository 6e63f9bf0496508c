"""The project's golden-vector files (one .npz per block, written by the make_<block>.py generators here), in the
format of carav_stream.testing.golden (described there)."""
from __future__ import annotations

from pathlib import Path

from carav_stream.testing.golden import flatten, load_vectors, save_vectors

__all__ = ["HERE", "save", "load", "flatten"]

HERE = Path(__file__).resolve().parent
save = save_vectors
load = load_vectors
