"""CARAV over a receiver array against weak attacks (`carav experiment receivers`; its command line in
carav_stream/cli/experiment/receivers.py).

The paper's signal model of the awr1642 preset (128 chirps of 256 I-only samples, the paper's 0 dB echo at the
preset's target), received by 1, 2, 4 and 8 receivers on a line at half-wavelength steps, each with its own
independent noise; C(eta) judges each chirp's RMS over all receivers, at the threshold designed for PF 1e-6 per cycle
with that many receivers (carav_stream/firmware/design.py: the one-receiver law with n_rx times the samples). One
attacker at broadside, its signal on every receiver with unit-modulus steering: `random` (closed form and Monte
Carlo) and `smart` (Monte Carlo), at the RARMS where one receiver misses most attacked cycles. Every sample is
simulated (carav_stream/montecarlo/array_source.py); one signal model, the paper's (what the radar chain's beat
fidelity gives with an ideal ADC). Measured: the share of attacked cycles C misses, with 95 % intervals; beside the
closed form, the law an attack independent on every receiver would have (the noise's), which one attacker does not.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from carav_stream.detect.stats import clopper_pearson, pf_pm_closed_form
from carav_stream.experiments.reporting import Tally
from carav_stream.firmware.design import pm_random, rms_threshold, scene_law
from carav_stream.montecarlo.array_source import ArraySource
from carav_stream.montecarlo.engine import simulate_q
from carav_stream.montecarlo.paper_model import paper_scene

__all__ = ["receivers", "PRESET", "RECEIVERS", "RARMS", "ATTACKS", "PF"]

PRESET = "awr1642"
RECEIVERS = (1, 2, 4, 8)
RARMS = (0.3, 0.4, 0.5)
ATTACKS = ("random", "smart")
PF = 1e-6


def receivers(trials: int, seed: int, rarms=RARMS, progress: Callable[[int, int], None] | None = None) -> dict:
    """{"scene": what was simulated, "rows": one per (receivers, RARMS): n_rx, rarms, eta (the PF design for that
    count), closed_form (PM of `random`: one attacker's steered signal), independent (PM were the attack independent
    on every receiver), and per attack of ATTACKS missed, rate and ci (95 %) over `trials` attacked cycles}; job j of
    the (receivers, RARMS, attack) grid draws from SeedSequence(seed).spawn(...)[j]; progress(cycles done, in all)."""
    scene = paper_scene(PRESET)
    jobs = [(n, float(r), a) for n in RECEIVERS for r in rarms for a in ATTACKS]
    tally = Tally(len(jobs) * trials, progress)
    rows: dict[tuple[int, float], dict] = {}
    for (n, r, attack), child in zip(jobs, np.random.SeedSequence(seed).spawn(len(jobs))):
        law = scene_law(scene, n)
        eta = rms_threshold(law, PF)
        if (n, r) not in rows:
            independent = pf_pm_closed_form(eta, n_chirps=law.n_chirps, dof=law.dof, snr=law.snr, rarms=r, n_rx=n)
            rows[n, r] = {"n_rx": n, "rarms": r, "eta": eta, "closed_form": float(pm_random(law, eta, r)),
                          "independent": float(independent["p_quiet"])}
        q = simulate_q(ArraySource(scene, n), attack, r, trials, child, progress=tally).q
        k = int(np.sum(q < eta))
        lo, hi = clopper_pearson(k, trials)
        rows[n, r][attack] = {"missed": k, "rate": k / trials, "ci": [float(lo), float(hi)]}
    return {"scene": {"preset": PRESET, "n_chirps": scene.n_chirps, "n_samples": scene.n_samples, "iq": scene.iq,
                      "echo_snr_db": float(10 * np.log10(scene.echo_snr)), "attacker_azimuth_deg": 0.0, "pf": PF},
            "trials": trials, "seed": seed, "rows": list(rows.values())}
