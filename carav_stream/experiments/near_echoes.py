"""The table1 car near the radar, attack-free: what its echo does to every detector (`carav experiment near-echoes`;
its command line in carav_stream/cli/experiment/near_echoes.py).

The car (100 m^2, 96 km/h, radar at 100 km/h) at 5, 7 and 10 m, at beat and waveform fidelity, sampled two ways:
from the ramp's reset (t_adc_start_s = 0, 1100 samples, as MATLAB's example does) and as the table1 preset samples
(16 samples in, 1080 samples, once the IF filter has settled). Each cell simulates --trials attack-free cycles
(seeded) and counts the cycles on which each detector alarms:

  C(eta)      the RMS detector at the eta designed for PF 1e-6 per cycle (`carav design`: D0 and D1, noise alone)
  C(1.5)      the paper's threshold
  spectral, integrated, coherent, spill
              the opt-in tests at their PF 1e-6 designs (carav_stream/montecarlo/detectors.py)
  CUSUM       the CUSUM of the silent power at h for an in-control run of 1e6 cycles: the cycle of its first alarm
              in the run, or "-" for none.

The opt-in tests and the CUSUM are calibrated to the noise the ADC delivers (carav_stream/radar/adc.py,
output_noise_rms): the full scale sits 30 dB above the loud near echo, so the 12-bit ADC's quantisation adds 18 % to
the noise power at 5 m (5 % at 7 m). Against sigma_n alone the integrated and coherent tests alarm on a cycle in a few
hundred at 5 m, and the CUSUM, which sums the excess over cycles, within a few cycles. C's designed eta counts it.

with 95 % Clopper-Pearson intervals. PF 1e-6 lies within the interval of k alarms in n cycles only for k = 0 (for
n up to 2.5e5). Beside them, the leak's exact rate (carav_stream/firmware/leak.py): the false-alarm rate per cycle
of C at the designed eta that the echo's leak into the silent slots implies (at the fidelity where it
is larger, the same for both rows of a scene), and whether `carav validate`, `design` and `scenes` warn.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from carav_stream.detect.detector import PAPER_ETA, chirp_rms, detect
from carav_stream.detect.opt_in import cusum_silent_power, cusum_threshold, silent_power_z
from carav_stream.experiments.reporting import Tally
from carav_stream.firmware.blind_zone import opt_in_alarms
from carav_stream.firmware.design import rms_threshold, scene_law
from carav_stream.firmware.leak import scene_leaks
from carav_stream.montecarlo.detectors import OPT_IN
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles

__all__ = ["near_echoes", "cell", "ALARMS", "RANGES_M", "STARTS", "FIDELITIES", "PF"]

RANGES_M = (5.0, 7.0, 10.0)
STARTS = {"from the reset": {"t_adc_start_s": 0.0, "n_samples": 1100}, "preset": {}}
FIDELITIES = ("beat", "waveform")
PF = 1e-6
CHUNK = 100          # cycles simulated at once (100 x 64 x 1100 float32: 28 MB)
ALARMS = ("C(eta)", "C(1.5)", *OPT_IN)   # the detectors whose alarms a cell counts


def cell(start: str, range_m: float, fidelity: str, n: int, seed: int,
         tick: Callable[[int], None] | None = None) -> dict:
    """Alarms of every detector on n attack-free cycles of the table1 car at range_m, sampled as `start` says."""
    scene = load_scene("table1", {"targets[0].range_m": range_m, **STARTS[start]})
    law = scene_law(scene)
    eta = rms_threshold(law, PF)
    leak = scene_leaks(scene, eta, pf_design=PF)[0]
    rng = np.random.default_rng([seed, int(range_m * 10), len(start), len(fidelity)])
    counts = dict.fromkeys(ALARMS, 0)
    z = []
    for done in range(0, n, CHUNK):
        rho = balanced_rows(rng, min(CHUNK, n - done), scene.n_chirps)
        x = simulate_cycles(scene, rho, rng, fidelity=fidelity).frames
        q = detect(x, rho, scene.sigma_n).q
        counts["C(eta)"] += int(np.sum(q >= eta))
        counts["C(1.5)"] += int(np.sum(q >= PAPER_ETA))
        for name, alarm in opt_in_alarms(x, rho, scene, law, OPT_IN).items():
            counts[name] += int(np.sum(alarm))
        z.append(silent_power_z(chirp_rms(x), rho, law.sigma_eff, law.dof))
        if tick is not None:
            tick(len(rho))
    _, cusum = cusum_silent_power(np.concatenate(z), h=cusum_threshold(1 / PF))
    first = int(np.argmax(cusum)) if cusum.any() else None
    return {"start": start, "range_m": range_m, "fidelity": fidelity, "trials": n, "n_samples": scene.n_samples,
            "t_adc_start_s": scene.t_adc_start_s, "eta": eta, "alarms": counts, "cusum_first_alarm": first,
            "leak_fraction": leak.fraction, "leak_pf": leak.pf, "warned": leak.exceeds}


def near_echoes(n: int, seed: int, partial: Callable[[dict], None] | None = None,
                progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """cell() of every sampling of STARTS, range of RANGES_M and fidelity of FIDELITIES, n cycles each; partial(cell)
    as each is done, progress(cycles done, cycles in all) as they are judged."""
    tally = Tally(len(STARTS) * len(RANGES_M) * len(FIDELITIES) * n, progress)
    rows = []
    for start in STARTS:
        for r in RANGES_M:
            for fid in FIDELITIES:
                c = cell(start, r, fid, n, seed, tally)
                if partial is not None:
                    partial(c)
                rows.append(c)
    return rows
