"""The ground floor: physical constants, the one parameter system every other floor declares with, and how a
process keeps its memory (allocator settings, per-thread scratch buffers)."""
