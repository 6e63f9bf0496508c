"""Helpers shared by the benchmark blocks and the raw pyzmq baseline: figures and opt-in cProfile.

CARAV_BENCH_PROFILE=DIR makes every benchmark block profile its own node process (from start() to finish(),
i.e. the runtime's receive/decode/process/encode/send loop around it) and write DIR/<role>-<pid>.prof.
"""
from __future__ import annotations

import os
from typing import Any

import numpy as np

PROFILE_ENV = "CARAV_BENCH_PROFILE"


def profile_start(role: str) -> Any:
    folder = os.environ.get(PROFILE_ENV)
    if not folder:
        return None
    import cProfile
    prof = cProfile.Profile()
    prof.enable()
    return (prof, os.path.join(folder, f"{role}-{os.getpid()}.prof"))


def profile_stop(handle: Any) -> None:
    if handle is not None:
        prof, path = handle
        prof.disable()
        prof.dump_stats(path)


def cpu_s() -> tuple[float, float, int, int]:
    """(user s, system s, minor page faults, voluntary context switches) of this process so far, all threads
    (ZeroMQ's I/O thread and pyzmq's zero-copy garbage collector thread included)."""
    import resource
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime, r.ru_stime, r.ru_minflt, r.ru_nvcsw


def cpu_figures(start: tuple[float, float, int, int], n_frames: int) -> dict:
    """CPU use since `start` (from cpu_s()), in total and per frame (ms, counts)."""
    user, system, minflt, nvcsw = (b - a for a, b in zip(start, cpu_s()))
    per = 1.0 / max(n_frames, 1)
    return {"cpu_user_s": user, "cpu_sys_s": system, "cpu_ms_per_frame": (user + system) * per * 1e3,
            "cpu_user_ms_per_frame": user * per * 1e3, "cpu_sys_ms_per_frame": system * per * 1e3,
            "page_faults_per_frame": minflt * per, "voluntary_switches_per_frame": nvcsw * per}


def figures(t_recv: list[float], latency_s: list[float], warmup: int, nbytes: int, in_order: bool) -> dict:
    """Rate and latency figures (plain types) from receive times (s, monotonic) and latencies (s).

    The first `warmup` frames (pipeline fill) are left out: rate = (n - 1 - k0) / (t[n-1] - t[k0]).
    """
    n = len(t_recv)
    k0 = min(warmup, max(n - 2, 0))
    span = t_recv[-1] - t_recv[k0] if n >= 2 else 0.0
    lat = np.asarray(latency_s[k0:], dtype=np.float64)
    nan = float("nan")
    return {"frames": n, "bytes_per_frame": int(nbytes), "in_order": bool(in_order),
            "frames_per_s": float((n - 1 - k0) / span) if span > 0 else 0.0,
            "latency_median_s": float(np.median(lat)) if lat.size else nan,
            "latency_p99_s": float(np.percentile(lat, 99)) if lat.size else nan,
            "latency_max_s": float(lat.max()) if lat.size else nan}
