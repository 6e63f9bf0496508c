"""Monte Carlo of the CARAV detector: PF(eta), PM(eta) with Clopper-Pearson intervals, batched and seeded.

A *cycle source* draws cycles of a scene under an attack and returns their per-chirp RMS (all the detector uses):

    source.draw(n_cycles, attack, rarms, rng, method) -> (rms float64 (n_cycles, n_chirps), rho bool (same))
    source.draw_q(n_cycles, attack, rarms, rng, method) -> (q float64 (n_cycles,), by_d1 bool (n_cycles,))
    source.energy_exact(attack) -> bool       an exact sufficient-statistic path exists for this attack
    source.closed_form(attack) -> dict|None   parameters for stats.pf_pm_closed_form, or None
    source.n_rx (optional, default 1)         receivers: the detector on each chirp's RMS over all of them

method "samples" simulates every sample, "energy" draws the per-chirp energies from their exact laws, "auto" takes
"energy" where it is exact and falls back to "samples" otherwise. Q does not depend on eta, so one draw of Q per
cycle serves the whole eta grid: PF(eta) = #(Q0 >= eta) / n, PM(eta) = #(Qa < eta) / n.

Reproducibility: the seed feeds a SeedSequence; each (attack, RARMS) job and each batch inside it gets its own
child, so results depend on (seed, batch size) only, not on the number of worker threads.
"""
from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from carav_stream.detect.detector import PAPER_ETA, chirp_rms, detect_from_rms
from carav_stream.detect.stats import cfar_eta_closed_form, clopper_pearson, pf_pm_closed_form
from carav_stream.detect.thresholds import design_thresholds
from carav_stream.montecarlo import paper_model
from carav_stream.radar.activation import balanced_rows

__all__ = ["CycleSource", "PaperSource", "QDraw", "simulate_q", "curves_from_q", "sweep", "eta_grid"]

SAMPLES_PER_BATCH = 3_000_000
ENERGY_CYCLES_PER_BATCH = 20_000


class CycleSource(Protocol):
    name: str
    n_chirps: int
    n_samples: int
    iq: bool
    sigma_n: float

    def draw(self, n_cycles: int, attack: str, rarms: float, rng: np.random.Generator,
             method: str) -> tuple[np.ndarray, np.ndarray]: ...

    def draw_q(self, n_cycles: int, attack: str, rarms: float, rng: np.random.Generator,
               method: str) -> tuple[np.ndarray, np.ndarray]: ...

    def energy_exact(self, attack: str) -> bool: ...

    def closed_form(self, attack: str) -> dict | None: ...

    def describe(self) -> dict: ...


class PaperSource:
    """Cycle source for the paper's own model (`paper_model`): attacks none, random, smart; exact energy path for
    all three."""

    attacks = paper_model.ATTACKS

    def __init__(self, scene: paper_model.PaperScene):
        self.scene = scene
        self.name = scene.name
        self.n_chirps, self.n_samples, self.iq, self.sigma_n = scene.n_chirps, scene.n_samples, scene.iq, scene.sigma_n

    def energy_exact(self, attack: str) -> bool:
        return attack in paper_model.ATTACKS

    def closed_form(self, attack: str) -> dict | None:
        power = np.mean(np.abs(self.scene.echo) ** 2, axis=-1)
        if attack not in ("none", "random") or np.ptp(power) > 1e-9 * power.max():
            return None
        return {"n_chirps": self.n_chirps, "dof": self.scene.dof, "snr": self.scene.echo_snr}

    def draw(self, n_cycles, attack, rarms, rng, method):
        rho = balanced_rows(rng, n_cycles, self.n_chirps)
        if method == "energy":
            return paper_model.sample_rms(self.scene, rho, rng, attack, rarms), rho
        frames = paper_model.simulate_frames(self.scene, rho, rng, attack, rarms)
        return chirp_rms(frames), rho

    def draw_q(self, n_cycles, attack, rarms, rng, method):
        if method == "energy" and paper_model.exchangeable(self.scene, attack):
            return paper_model.sample_q_fast(self.scene, n_cycles, rng, attack, rarms)
        if method == "energy" and attack == "smart":
            return paper_model.sample_q_smart(self.scene, n_cycles, rng, rarms)
        rms, rho = self.draw(n_cycles, attack, rarms, rng, method)
        det = detect_from_rms(rms, rho, self.sigma_n, 1.0)
        return det.q, det.by_d1

    def describe(self) -> dict:
        return {"model": "paper", "name": self.name, "n_chirps": self.n_chirps, "n_samples": self.n_samples,
                "iq": self.iq, "sigma_n": self.sigma_n, "echo_snr_db": float(10 * np.log10(self.scene.echo_snr))}


@dataclass(frozen=True)
class QDraw:
    """Q of n_trials cycles: q float64 (n,), by_d1 bool (n,) (the max came from an active chirp), method used."""

    q: np.ndarray
    by_d1: np.ndarray
    method: str


def resolve_method(source: CycleSource, attack: str, method: str) -> str:
    if method not in ("auto", "energy", "samples"):
        raise ValueError(f"method: unknown {method!r}, expected auto, energy or samples")
    if method == "auto":
        return "energy" if source.energy_exact(attack) else "samples"
    if method == "energy" and not source.energy_exact(attack):
        raise ValueError(f"method: no exact energy path for attack {attack!r} on {source.name}; use samples")
    return method


def batch_plan(source: CycleSource, attack: str, n_trials: int, *, method: str = "auto",
               detector: str = "carav") -> tuple[str, list[int]]:
    """(method used, cycles per batch): how a point's n_trials cycles are cut into seeded batches. Batch b of job j
    draws from SeedSequence(seed, spawn_key=(j, b)), so whoever runs it (a thread here, a Dask worker in
    `carav study`) draws the same numbers."""
    if n_trials < 1:
        raise ValueError(f"n_trials: must be >= 1, got {n_trials}")
    if detector != "carav":
        if not hasattr(source, "draw_stat"):
            raise ValueError(f"detector: {detector!r} needs every sample; the {source.name} source gives RMS "
                             "levels only (use the radar model)")
        if method == "energy":
            raise ValueError(f"method: detector {detector!r} needs every sample; use samples or auto")
        used = "samples"
    else:
        used = resolve_method(source, attack, method)
    per = (ENERGY_CYCLES_PER_BATCH if used == "energy"
           else max(1, SAMPLES_PER_BATCH // (source.n_chirps * source.n_samples * getattr(source, "n_rx", 1))))
    return used, [min(per, n_trials - i) for i in range(0, n_trials, per)]


def batches_independent(source: CycleSource, used: str) -> bool:
    """Whether a point's batches may run apart, in any order: the sufficient-statistic (energy) path keeps no state
    between batches; a source marked sequential (stateful attackers, an activation stream) needs them in order."""
    return used == "energy" or not getattr(source, "sequential", False)


def draw_batch(source: CycleSource, attack: str, rarms: float, size: int, seed: np.random.SeedSequence, used: str,
               detector: str = "carav") -> tuple[np.ndarray, np.ndarray]:
    """Q (or an opt-in detector's statistic) and by_d1 of one batch."""
    rng = np.random.default_rng(seed)
    if detector != "carav":
        q = source.draw_stat(size, attack, rarms, rng, detector)
        return q, np.zeros(q.shape, bool)
    return source.draw_q(size, attack, rarms, rng, used)


def simulate_q(source: CycleSource, attack: str, rarms: float, n_trials: int, seed_seq: np.random.SeedSequence,
               *, method: str = "auto", workers: int = 2, progress: Callable[[int], None] | None = None,
               detector: str = "carav") -> QDraw:
    """Draw Q for n_trials cycles (eta = 1 is passed to the detector: Q itself does not depend on eta); for an
    opt-in detector (carav_stream.montecarlo.detectors) its statistic instead, on full samples."""
    used, sizes = batch_plan(source, attack, n_trials, method=method, detector=detector)
    children = seed_seq.spawn(len(sizes))

    def one(args):
        size, child = args
        out = draw_batch(source, attack, rarms, size, child, used, detector)
        if progress is not None:
            progress(size)
        return out

    if hasattr(source, "begin_job"):
        source.begin_job(attack, rarms)
    if getattr(source, "sequential", False):
        workers = 1                       # stateful attackers must see their cycles in order
    if workers > 1 and len(sizes) > 1:
        with ThreadPoolExecutor(workers) as pool:
            parts = list(pool.map(one, zip(sizes, children)))
    else:
        parts = [one(a) for a in zip(sizes, children)]
    return QDraw(np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]), used)


def eta_grid(spec: str) -> np.ndarray:
    """Parse START:STOP:STEP (inclusive of STOP within half a step) into a float64 grid."""
    try:
        start, stop, step = (float(v) for v in spec.split(":"))
    except ValueError:
        raise ValueError(f"eta: expected START:STOP:STEP, got {spec!r}") from None
    if not (step > 0 and stop >= start and start > 0):
        raise ValueError(f"eta: need 0 < START <= STOP and STEP > 0, got {spec!r}")
    n = int(np.floor((stop - start) / step + 0.5)) + 1
    return start + step * np.arange(n)


def curves_from_q(q0: np.ndarray, qa: np.ndarray | None, eta: np.ndarray, confidence: float = 0.95) -> dict:
    """PF from attack-free Q0 and PM from attacked Qa on the eta grid, with Clopper-Pearson intervals."""
    eta = np.asarray(eta, dtype=np.float64)
    out = {}
    s0 = np.sort(q0)
    k_fa = s0.size - np.searchsorted(s0, eta, side="left")          # #(Q0 >= eta): alarm is C >= 1
    lo, hi = clopper_pearson(k_fa, s0.size, confidence)
    out.update(pf=k_fa / s0.size, pf_ci=np.stack([lo, hi], -1), pf_trials=int(s0.size))
    if qa is not None:
        sa = np.sort(qa)
        k_miss = np.searchsorted(sa, eta, side="left")                   # #(Qa < eta)
        lo, hi = clopper_pearson(k_miss, sa.size, confidence)
        out.update(pm=k_miss / sa.size, pm_ci=np.stack([lo, hi], -1), trials=int(sa.size))
    return out


def _as_lists(a: np.ndarray) -> list:
    return np.asarray(a, dtype=float).tolist()


def sweep(source: CycleSource, *, attacks, rarms, n_trials: int, eta, seed: int | None = None,
          method: str = "auto", target_pf: float = 0.01, design_rarms: float = 3.0, workers: int = 2,
          progress: Callable[[int, int], None] | None = None, detector: str = "carav") -> dict:
    """PF and PM curves for every (attack, RARMS), thresholds per curve and for the design set, JSON-ready.

    PF comes from n_trials attack-free cycles shared by all curves. The top-level `thresholds` are designed against
    the worst PM (pointwise max) over the curves with RARMS >= design_rarms (the paper's "harmful" attacks; all
    curves when none qualifies). `detector` scores C(eta) ("carav") or an opt-in detector, whose statistic is in
    units of its PF = 1e-6 threshold (carav_stream.montecarlo.detectors).
    """
    eta = np.asarray(eta, dtype=np.float64)
    attacks = list(attacks)
    rarms = [float(r) for r in rarms]
    jobs = sweep_jobs(attacks, rarms)
    children = np.random.SeedSequence(seed).spawn(len(jobs))
    total = n_trials * len(jobs)
    done = [0]

    def tick(n):
        done[0] += n
        if progress is not None:
            progress(done[0], total)

    draws = {}
    for (attack, r), child in zip(jobs, children):
        draws[(attack, r)] = simulate_q(source, attack, r, n_trials, child, method=method, workers=workers,
                                        progress=tick, detector=detector)
    return assemble(source, draws, pairs=jobs[1:], n_trials=n_trials, eta=eta, seed=seed, target_pf=target_pf,
                    design_rarms=design_rarms, detector=detector)


def sweep_jobs(attacks, rarms) -> list[tuple[str, float]]:
    """The jobs of a sweep in seed order: no attack first (PF), then every (attack, RARMS); job j draws from
    SeedSequence(seed).spawn(...)[j]."""
    return [("none", 0.0)] + [(a, float(r)) for a in attacks for r in rarms]


def assemble(source: CycleSource, draws: dict, *, pairs, n_trials: int, eta, seed: int | None,
             target_pf: float = 0.01, design_rarms: float = 3.0, detector: str = "carav") -> dict:
    """The JSON result of a sweep from its draws {(attack, RARMS): QDraw} (see `sweep`); `pairs` the attacked
    (attack, RARMS) points in order (draws also holds ("none", 0.0), the attack-free cycles)."""
    eta = np.asarray(eta, dtype=np.float64)
    q0 = draws[("none", 0.0)]
    curves = []
    for attack, r in pairs:
        qa = draws[(attack, r)]
        c = curves_from_q(q0.q, qa.q, eta)
        entry = {"detector": detector, "attack": attack, "rarms": r, "trials": n_trials, "method": qa.method,
                 "eta": _as_lists(eta), "pf": _as_lists(c["pf"]), "pm": _as_lists(c["pm"]),
                 "pf_ci": _as_lists(c["pf_ci"]), "pm_ci": _as_lists(c["pm_ci"]),
                 "miss_by_d1_share": float(np.mean(qa.by_d1)),
                 "q_quantiles": {p: float(np.quantile(qa.q, p / 100)) for p in (1, 50, 99)}}
        entry["thresholds"] = design_thresholds(eta, c["pf"], c["pm"], target_pf=target_pf,
                                                pf_ci=c["pf_ci"], pm_ci=c["pm_ci"])
        cf = source.closed_form(attack if attack in ("none", "random") else "none")
        if cf is not None and attack in ("none", "random") and detector == "carav":
            entry["closed_form"] = {
                "pf": _as_lists(pf_pm_closed_form(eta, **cf)["p_alarm"]),
                "pm": _as_lists(pf_pm_closed_form(eta, **cf, rarms=r)["p_quiet"]),
                "note": "D0 part exact, D1 part approximate (stats.pf_pm_closed_form)"}
        curves.append(entry)
    design = [c for c in curves if c["rarms"] >= design_rarms] or curves
    pf = np.asarray(design[0]["pf"])
    pf_ci = np.asarray(design[0]["pf_ci"])
    pm_all = np.array([c["pm"] for c in design])
    worst = np.argmax(pm_all, axis=0)
    pm = pm_all[worst, np.arange(eta.size)]
    pm_ci = np.array([c["pm_ci"] for c in design])[worst, np.arange(eta.size)]
    result = {
        "scene": source.describe(), "detector": detector, "seed": seed, "trials": n_trials, "eta": _as_lists(eta),
        "pf_method": q0.method, "curves": curves,
        "thresholds": design_thresholds(eta, pf, pm, target_pf=target_pf, pf_ci=pf_ci, pm_ci=pm_ci),
        "design": {"rarms_min": design_rarms, "curves": [[c["attack"], c["rarms"]] for c in design],
                   "pm": "pointwise worst case over the design curves", "cfar_target_pf": target_pf},
        "false_alarm_by_d1_share": float(np.mean(q0.by_d1)),
    }
    cf = source.closed_form("none") if detector == "carav" else None
    if cf is not None:
        pf_cf = pf_pm_closed_form(eta, **cf)
        result["closed_form"] = {
            "pf": _as_lists(pf_cf["p_alarm"]), "pf_d0_exact": _as_lists(pf_cf["p_alarm_d0"]),
            "pf_at_eta_1_5": float(pf_pm_closed_form(PAPER_ETA, **cf)["p_alarm"]),
            "cfar_eta_pf_1e-6": cfar_eta_closed_form(1e-6, n_chirps=cf["n_chirps"], dof=cf["dof"],
                                                     n_rx=cf.get("n_rx", 1)),
            "note": "Gaussian noise; D0 part exact, D1 part approximate"}
    return result
