"""Radar activation sequences (Algorithm 1, steps 1-2): every cycle exactly n_chirps/2 active chirps.

With TDM (a scene whose loop has n_slots > 1 chirp slots, one per transmitter of its schedule) the sequence is drawn
per loop: rho is constant within each loop of n_slots consecutive slots, and exactly n_loops/2 loops are active, so
an active loop fires the whole virtual array. ``next(n_cycles, n_chirps, n_slots)`` draws for loops what it draws
for chirps with a single transmitter (one key or LFSR bit each), so with n_slots = 1, where a loop is a chirp, the
rows are the single transmitter's.

Sources (``ActivationSource(kind, seed, taps)``):

``secure`` (default)
    Draws from the operating system's cryptographically secure generator (``os.urandom``, the same
    source as Python's ``secrets``): 64 random bits per chirp, and the n/2 chirps with the smallest
    keys are active. Every balanced pattern is equally likely (ties have probability < n^2 / 2^64).
    Not reproducible, by design: this is what the firmware should use.
``seeded``
    A numpy ``Generator(PCG64(seed))`` stream: uniformly random balanced rows, reproducible.
    **Simulation only**: anyone who learns the seed predicts every future cycle.
``lfsr``
    A maximal-length Fibonacci LFSR, s[n] = XOR of s[n - t] for t in ``taps`` (default (16, 15, 13, 4),
    period 2^16 - 1), balanced by Manchester coding: bit b_j of the stream drives the chirp pair
    (2j, 2j + 1) as (b_j, 1 - b_j). It exists to show why the paper warns against LFSRs: the bits are
    on the air, and :func:`berlekamp_massey` recovers the register from 2L of them.
"""
from __future__ import annotations

import os

import numpy as np

DEFAULT_TAPS = (16, 15, 13, 4)
KINDS = ("secure", "seeded", "lfsr")


class ActivationSource:
    """Stateful generator of activation rows; ``next`` continues the stream where it stopped."""

    def __init__(self, kind: str = "secure", seed: int | None = None, taps: tuple[int, ...] | None = None):
        if kind not in KINDS:
            raise ValueError(f"activation source kind: unknown {kind!r}, expected one of {', '.join(KINDS)}")
        if kind == "seeded" and seed is None:
            raise ValueError("activation source 'seeded' needs seed=<int> (simulation only)")
        if kind == "secure" and seed is not None:
            raise ValueError("activation source 'secure' takes no seed (it reads os.urandom); "
                             "use kind='seeded' for a reproducible simulation")
        self.kind = kind
        self.seed = seed
        self.taps = tuple(int(t) for t in (taps or DEFAULT_TAPS))
        if kind == "lfsr":
            if min(self.taps) < 1:
                raise ValueError(f"lfsr taps must be >= 1, got {self.taps}")
            degree = max(self.taps)
            init = seed if seed is not None else 1
            state = [(init >> i) & 1 for i in range(degree)]
            if not any(state):
                raise ValueError(f"lfsr seed {seed} gives the all-zero state, which never leaves zero")
            self._lfsr_state = state  # the last `degree` output bits, oldest first
        if kind == "seeded":
            self._rng = np.random.Generator(np.random.PCG64(seed))

    def next(self, n_cycles: int, n_chirps: int, n_slots: int = 1) -> np.ndarray:
        """The next ``n_cycles`` activation rows: bool (n_cycles, n_chirps), n_chirps/2 True per row, constant within
        each TDM loop of ``n_slots`` chirps (module docstring)."""
        n_loops = _loops(n_chirps, n_slots)
        if n_cycles < 0:
            raise ValueError(f"n_cycles must be >= 0, got {n_cycles}")
        return per_loop(self._next(n_cycles, n_loops), n_slots)

    def _next(self, n_cycles: int, n: int) -> np.ndarray:
        """Balanced rows of n entries (chirps, or TDM loops): bool (n_cycles, n)."""
        if self.kind == "lfsr":
            bits = self.lfsr_bits(n_cycles * n // 2).reshape(n_cycles, n // 2)
            rho = np.empty((n_cycles, n), dtype=bool)
            rho[:, 0::2] = bits
            rho[:, 1::2] = ~bits
            return rho
        if self.kind == "secure":
            keys = np.frombuffer(os.urandom(8 * n_cycles * n), dtype=np.uint64)
            return lowest_half(keys.reshape(n_cycles, n))
        return balanced_rows(self._rng, n_cycles, n)

    def lfsr_bits(self, n_bits: int) -> np.ndarray:
        """The next ``n_bits`` output bits of the LFSR (bool)."""
        out = lfsr_continue(self._lfsr_state, self.taps, n_bits)
        self._lfsr_state = (self._lfsr_state + [int(b) for b in out])[-max(self.taps):]
        return out


def _loops(n_chirps: int, n_slots: int) -> int:
    """The loops of a cycle, checked: n_slots >= 1 divides n_chirps into an even number >= 2 of loops."""
    if n_slots < 1 or n_chirps % n_slots:
        raise ValueError(f"n_chirps {n_chirps} is not a whole number of TDM loops of {n_slots} slots")
    n_loops = n_chirps // n_slots
    if n_loops < 2 or n_loops % 2:
        what = "n_chirps" if n_slots == 1 else f"the TDM loops ({n_chirps} chirps / {n_slots} slots)"
        raise ValueError(f"{what} must be even and >= 2, got {n_loops}")
    return n_loops


def per_loop(rho_loops: np.ndarray, n_slots: int) -> np.ndarray:
    """Loop activation rows bool (n_cycles, n_loops) as chirp rows (n_cycles, n_loops * n_slots): each loop's entry
    repeated over its slots (the rows themselves for n_slots = 1)."""
    return rho_loops if n_slots == 1 else np.repeat(rho_loops, n_slots, axis=1)


def lowest_half(keys: np.ndarray) -> np.ndarray:
    """bool like keys (n_cycles, n_chirps): True at the n_chirps/2 smallest keys of every row, equal keys taken in
    index order (what a stable sort would pick).

    By selection, not sorting: each row's (n_chirps/2)-th smallest key (np.partition, linear time), every key below
    it, and as many keys equal to it as the half still lacks, first ones first: cheaper than a stable argsort
    (tests/radar/test_activation.py checks both pick alike)."""
    h = keys.shape[1] // 2
    if h == 0:
        return np.zeros(keys.shape, dtype=bool)
    kth = np.partition(keys, h - 1, axis=1)[:, h - 1: h]
    rho = keys < kth
    tied = keys == kth
    rho |= tied & (np.cumsum(tied, axis=1) <= (h - np.count_nonzero(rho, axis=1))[:, None])
    return rho


def balanced_rows(rng: np.random.Generator, n_cycles: int, n_chirps: int, n_slots: int = 1) -> np.ndarray:
    """Uniformly random balanced activation rows from a numpy generator, bool (n_cycles, n_chirps): the same law
    as the secure source, reproducible (simulation only); drawn per TDM loop of ``n_slots`` chirps (module
    docstring)."""
    n_loops = n_chirps if n_slots == 1 else _loops(n_chirps, n_slots)
    return per_loop(lowest_half(rng.random((n_cycles, n_loops))), n_slots)


def berlekamp_massey(bits) -> tuple[int, tuple[int, ...]]:
    """Shortest LFSR generating ``bits`` over GF(2).

    Returns ``(length, taps)`` such that s[n] = XOR of s[n - t] for t in taps, for every n >= length.
    With at least 2 * length observed bits the LFSR is unique. Same tap convention as
    ``ActivationSource(kind="lfsr", taps=...)``.
    """
    s = np.asarray(bits, dtype=np.uint8).ravel() & 1
    n = s.size
    c = np.zeros(n + 1, dtype=np.uint8)
    b = np.zeros(n + 1, dtype=np.uint8)
    c[0] = b[0] = 1
    length, m = 0, 1
    for i in range(n):
        # discrepancy d = s[i] + sum_{j=1..L} c[j] s[i-j]
        d = s[i] ^ (int(np.dot(c[1: length + 1], s[i - length: i][::-1])) & 1 if length else 0)
        if d == 0:
            m += 1
            continue
        if 2 * length <= i:
            t = c.copy()
            c[m:] ^= b[: n + 1 - m]
            length, b, m = i + 1 - length, t, 1
        else:
            c[m:] ^= b[: n + 1 - m]
            m += 1
    taps = tuple(int(j) for j in np.flatnonzero(c[1: length + 1]) + 1)
    return length, taps


def lfsr_continue(history, taps: tuple[int, ...], n_bits: int) -> np.ndarray:
    """Extend a bit history with the recurrence s[n] = XOR s[n - t] (predict the next ``n_bits``)."""
    h = [int(x) for x in np.asarray(history, dtype=np.uint8).ravel()]
    if taps and len(h) < max(taps):
        raise ValueError(f"need at least {max(taps)} bits of history for taps {taps}, got {len(h)}")
    out = np.empty(n_bits, dtype=bool)
    for i in range(n_bits):
        bit = 0
        for t in taps:
            bit ^= h[-t]
        h.append(bit)
        out[i] = bit
    return out
