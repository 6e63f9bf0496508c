"""The private activation log: the activation sequence of every recorded cycle, in its own file beside a recording.

The sequence rho is the firmware's secret (Algorithm 1): whoever knows it can tell silent from active chirps and
defeat the detector, so it never goes into the sample file or the recording's metadata. The log is written with
mode 0600 (its owner alone may read it) and is needed only to judge the recording again (replay) or to run the
detector on a real radar's capture whose firmware silenced chirps by a known sequence.

    # carav activation log v2: private firmware state; do not share it with the recording
    # n_chirps 64
    0 0110100111010001...        one line per cycle: its index, then rho(0) .. rho(N_r - 1) as 0 and 1
    # sha256 9f86d0...           the SHA-256 of every byte before this line

Lines starting with # are comments; cycles are in recording order (not necessarily consecutive).
The last line of a v2 log (what carav writes) is its checksum: a log whose rows were edited, cut short or extended,
or whose checksum line is missing, is refused when read, naming the file, so a judged replay never runs silently
on another sequence than the one recorded. The checksum guards against accidental or careless change; it is no
signature (whoever may write the file may also rewrite its checksum: the 0600 mode keeps other users out).
A log without the v2 header (v1, or one written by hand or by a capture's firmware) has no checksum to check.
A log that its group or others may read, write or run is refused when read: whoever could read it may have read it,
and a detector judging with a known sequence proves nothing (`chmod 600 FILE` if it was never exposed).
"""
from __future__ import annotations

import hashlib
import os
import stat
from collections.abc import Sequence
from pathlib import Path

import numpy as np

MAGIC = "# carav activation log v2"
SUFFIX = ".activation"
CHECKSUM = "# sha256 "


class ActivationLogError(ValueError):
    """A log that cannot be read, or does not fit its recording; the text names the file and line."""


def write_log(path: str | Path, cycles: Sequence[int], rho: np.ndarray) -> None:
    """Write the log (mode 0600, replacing any file there): rho bool (len(cycles), n_chirps)."""
    rho = np.asarray(rho, dtype=bool)
    if rho.ndim != 2 or rho.shape[0] != len(cycles):
        raise ValueError(f"activation log {path}: {len(cycles)} cycles but rho of shape {rho.shape}")
    digits = np.where(rho, ord("1"), ord("0")).astype(np.uint8)
    lines = [f"{MAGIC}: private firmware state; do not share it with the recording", f"# n_chirps {rho.shape[1]}"]
    lines += [f"{c} {row.tobytes().decode()}" for c, row in zip(cycles, digits)]
    body = "\n".join(lines) + "\n"
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    os.fchmod(fd, 0o600)   # an existing file keeps its mode through O_CREAT: make it private too
    with os.fdopen(fd, "w") as fh:
        fh.write(f"{body}{CHECKSUM}{hashlib.sha256(body.encode()).hexdigest()}\n")


def _checked_body(path: Path, text: str, required: bool) -> str:
    """The log's text without its checksum line, after checking it (v2); v1 and hand-written logs as they are,
    unless `required` (a recording written with a checksummed log)."""
    if not text.startswith(MAGIC):
        if required:
            raise ActivationLogError(f"{path}: activation log is not the checksummed log its recording was written "
                                     f"with (its first line should be '{MAGIC}...')")
        return text
    body, _, last = text.rstrip("\n").rpartition("\n")
    if not last.startswith(CHECKSUM):
        raise ActivationLogError(f"{path}: activation log has no checksum line (its last line should be "
                                 f"'{CHECKSUM}<hex>'): it was cut short or edited")
    body += "\n"
    if hashlib.sha256(body.encode()).hexdigest() != last[len(CHECKSUM):].strip():
        raise ActivationLogError(f"{path}: activation log does not match its checksum: a row was changed, added or "
                                 "removed after it was written")
    return body


def read_log(path: str | Path, n_chirps: int, require_checksum: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(cycles int64 (n,), rho bool (n, n_chirps)) from a log; ActivationLogError naming the file and line.
    require_checksum  refuse a log without its checksum line (what carav's recordings are written with)."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            mode = os.fstat(fh.fileno()).st_mode
            if mode & 0o077:
                raise ActivationLogError(f"{path}: activation log has mode {stat.S_IMODE(mode):04o}: its group or "
                                         "others have access to it, and the sequence is secret (chmod 600 it if it "
                                         "was never exposed)")
            text = fh.read().decode()
    except FileNotFoundError:
        raise ActivationLogError(f"{path}: activation log not found (it goes beside the recording, "
                                 f"named like it with {SUFFIX})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ActivationLogError(f"{path}: activation log cannot be read: {exc}") from None
    cycles, rows = [], []
    for number, line in enumerate(_checked_body(path, text, require_checksum).splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        words = line.split()
        if len(words) != 2 or not words[0].isdigit() or len(words[1]) != n_chirps or set(words[1]) - {"0", "1"}:
            raise ActivationLogError(f"{path}:{number}: expected '<cycle> <{n_chirps} digits 0 or 1>', got "
                                     f"{line[:60]!r}")
        cycles.append(int(words[0]))
        rows.append(np.frombuffer(words[1].encode(), dtype=np.uint8) == ord("1"))
    if not rows:
        return np.zeros(0, dtype=np.int64), np.zeros((0, n_chirps), dtype=bool)
    return np.array(cycles, dtype=np.int64), np.stack(rows)


def log_path(base: str | Path) -> Path:
    """The log beside the recording `base` (its name without the .sigmf-meta / .sigmf-data suffix)."""
    return Path(f"{base}{SUFFIX}")


def pattern_rho(pattern: str, n_chirps: int) -> np.ndarray:
    """bool (n_chirps,) from a string of n_chirps digits 0 | 1; ValueError naming the parameter."""
    if len(pattern) != n_chirps or set(pattern) - {"0", "1"}:
        raise ValueError(f"pattern: expected {n_chirps} digits 0 or 1 (the scene's n_chirps), got {pattern[:40]!r}"
                         f" ({len(pattern)} characters)")
    return np.frombuffer(pattern.encode(), np.uint8) == ord("1")


def capture_activation(log: str, pattern: str, n_chirps: int) -> tuple[np.ndarray | None, np.ndarray | None,
                                                                       np.ndarray | None]:
    """A capture's activation from exactly one of an activation log or a fixed pattern (CAPTURE_PARAMS): (the
    pattern's row, None, None) or (None, the log's cycles, its rows). ValueError naming the parameter otherwise."""
    if bool(log) == bool(pattern):
        raise ValueError("activation, pattern: give exactly one (an activation log, or the fixed pattern of "
                         "the radar's profile)")
    if pattern:
        return pattern_rho(pattern, n_chirps), None, None
    try:
        cycles, rho = read_log(log, n_chirps)
    except ActivationLogError as exc:
        raise ValueError(f"activation: {exc}") from None
    return None, cycles, rho
