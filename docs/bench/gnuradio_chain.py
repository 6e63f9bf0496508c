#!/usr/bin/env python3
"""Throughput of a GNU Radio 3.10 + gr-radar FMCW chain on carav-stream's table1 scene (cycles/s).

What it measures: wall-clock cycles/s of ``tb.run()`` for a ``gr.top_block`` limited by ``blocks.head`` to
N measurement cycles (N x 64 chirps x 1100 samples), median of ``--repeats`` runs after a short warm-up run,
plus the process CPU time (getrusage RUSAGE_SELF, user + sys, all of GNU Radio's threads) per cycle and the
1-minute load average before and after each run. One JSON line on stdout.

The flowgraph (one thread per block, GNU Radio's default scheduler and buffers):

    radar.signal_generator_fmcw_c (150 MHz complex baseband, 1100-sample up-chirps sweeping 150 MHz)
      -> head -> radar.static_target_simulator_cc (one point target: 43 m, 1.11 m/s closing, RCS 100 m^2,
         77 GHz; no self-coupling)
      -> add_cc <- head <- analog.noise_source_c (Gaussian, set for carav's table1 per-sample SNR, +2.2 dB)
      -> multiply_conjugate_cc (dechirp: tx * conj(rx)) -> stream_to_tagged_stream (1100)
      -> radar.ts_fft_cc (1100-point FFT per chirp) -> radar.find_max_peak_c (strongest bin per chirp)
      -> message_debug "store" (the per-chirp peak frequencies; converted to range after the run, untimed,
         only to check that the chain sees the target at 43 m).

Relative to carav-stream's table1 pipeline (graphs/demo.toml, `carav bench pipeline`) it does LESS work:
- no RMS detectors (D0/D1), no random activation sequence (every chirp is transmitted), no Q/C(eta) verdict
  and no gate: GNU Radio and gr-radar have no such blocks; no attacker either;
- no 2-D range-Doppler processing: per-chirp FFT and max-peak only, versus carav's `ml` estimator over the
  64 x 1100 cycle (range and velocity per cycle). gr-radar's estimator_fmcw needs CW + up + down chirps (a
  triangle waveform) and so cannot be used on carav's sawtooth; the target simulator restarts the Doppler
  phase on every chirp (no slow-time Doppler), so a 2-D FFT on its output would be meaningless anyway;
- no ADC model (carav: I-only, 12-bit int16 codes); GNU Radio here is complex float32 throughout (twice
  carav's sample count per cycle: I and Q);
- the echo is a circular delay within each chirp (gr-radar's FFT-domain delay), not carav's echo model;
- one process, in-process circular stream buffers; carav moves frames between 8 processes over ZeroMQ.

Run (system python3 with Debian's gnuradio and gr-radar packages, not the project's .venv):

    apt-get install -y gnuradio gr-radar
    /usr/bin/python3 docs/bench/gnuradio_chain.py [--cycles N] [--seconds 6] [--repeats 3] [--tx-table]

--tx-table replaces radar.signal_generator_fmcw_c (a std::exp per sample) by a vector_source_c replaying
one precomputed chirp with its length tag: the same samples' role, a cheaper source.

Not imported by the package or the tests.
"""
import argparse
import cmath
import json
import math
import resource
import statistics
import time

import pmt
from gnuradio import analog, blocks, gr, radar

C = 299_792_458.0
FS, N_SAMP, N_CHIRPS, BW, FC = 150_000_000, 1100, 64, 150e6, 77e9
RANGE_M, V_CLOSING, RCS = 43.0, (100 - 96) / 3.6, 100.0   # gr-radar: positive velocity = closing
SNR_DB = 2.2027                                           # carav table1 per-sample SNR (radar equation)
KEY = "packet_len"


def build(cycles, seed=1, tx_table=False):
    """The flowgraph for `cycles` measurement cycles; returns (top_block, message store)."""
    n = cycles * N_CHIRPS * N_SAMP
    tb = gr.top_block("carav_table1_gr_radar")
    tx = radar.signal_generator_fmcw_c(FS, N_SAMP, 0, 0, -BW / 2, BW, 1.0, KEY)
    if tx_table:   # the same chirp, computed once and replayed (the generator calls exp() per sample)
        half_slope = math.pi * BW * FS / N_SAMP                # phase pi * S * t^2, -BW/2 .. +BW/2
        chirp = [cmath.exp(1j * half_slope * ((k - N_SAMP / 2) / FS) ** 2) for k in range(N_SAMP)]
        length = gr.tag_utils.python_to_tag((0, pmt.intern(KEY), pmt.from_long(N_SAMP), pmt.intern("tx")))
        tx = blocks.vector_source_c(chirp, True, 1, [length])
    tx_head = blocks.head(gr.sizeof_gr_complex, n)
    target = radar.static_target_simulator_cc([RANGE_M], [V_CLOSING], [RCS], [0.0], [0.0], FS, FC,
                                              -100.0, True, False, KEY)
    # gr-radar's echo amplitude (sqrt of the radar equation, tx amplitude 1); noise RMS for carav's SNR
    echo = C / FC * math.sqrt(RCS) / RANGE_M ** 2 / (4 * math.pi) ** 1.5
    noise = analog.noise_source_c(analog.GR_GAUSSIAN, echo / 10 ** (SNR_DB / 20), seed)
    noise_head = blocks.head(gr.sizeof_gr_complex, n)
    add = blocks.add_cc()
    mix = blocks.multiply_conjugate_cc()
    mix.set_tag_propagation_policy(gr.TPP_DONT)             # both inputs carry length tags: re-tag below
    tag = blocks.stream_to_tagged_stream(gr.sizeof_gr_complex, 1, N_SAMP, KEY)
    fft = radar.ts_fft_cc(N_SAMP, KEY)
    peak = radar.find_max_peak_c(FS, -300.0, 0, [0.0, 0.0], False, KEY)
    store = blocks.message_debug()
    tb.connect(tx, tx_head, target, (add, 0))
    tb.connect(noise, noise_head, (add, 1))
    tb.connect(tx_head, (mix, 0))
    tb.connect(add, (mix, 1))
    tb.connect(mix, tag, fft, peak)
    tb.msg_connect((peak, "Msg out"), (store, "store"))
    return tb, store


def loadavg():
    with open("/proc/loadavg") as f:
        return float(f.read().split()[0])


def cpu_s():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def timed(cycles, tx_table=False):
    tb, store = build(cycles, tx_table=tx_table)
    load0, c0, t0 = loadavg(), cpu_s(), time.perf_counter()
    tb.run()
    wall, cpu = time.perf_counter() - t0, cpu_s() - c0
    # untimed check: message count and the median per-chirp range over the last cycle
    n_msgs = store.num_messages()
    last = [store.get_message(i) for i in range(max(0, n_msgs - N_CHIRPS), n_msgs)]
    freqs = [pmt.f32vector_elements(pmt.nth(1, pmt.nth(1, m))) for m in last]
    ranges = [f[0] * C * (N_SAMP / FS) / (2 * BW) for f in freqs if len(f)]
    return {"cycles": cycles, "seconds": wall, "cycles_per_s": cycles / wall,
            "cpu_us_per_cycle": cpu / cycles * 1e6, "load1_before": load0, "load1_after": loadavg(),
            "peak_messages": n_msgs, "expected_messages": cycles * N_CHIRPS,
            "median_range_m_last_cycle": statistics.median(ranges) if ranges else None}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=0, help="cycles per run (0: from the warm-up rate)")
    ap.add_argument("--seconds", type=float, default=6.0, help="target run length when --cycles is 0")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--warmup", type=int, default=30, help="cycles of the warm-up run")
    ap.add_argument("--tx-table", action="store_true",
                    help="replay a precomputed chirp (vector_source_c) instead of radar.signal_generator_fmcw_c")
    a = ap.parse_args()
    warm = timed(a.warmup, a.tx_table)
    cycles = a.cycles or max(a.warmup, math.ceil(warm["cycles_per_s"] * a.seconds))
    runs = [timed(cycles, a.tx_table) for _ in range(a.repeats)]
    ok = all(r["peak_messages"] == r["expected_messages"] for r in runs)
    print(json.dumps({
        "bench": "gnuradio_gr_radar_fmcw_table1", "gnuradio": gr.version(),
        "tx": "vector_source_c table" if a.tx_table else "radar.signal_generator_fmcw_c",
        "utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "cycles_per_run": cycles,
        "cycles_per_s": statistics.median(r["cycles_per_s"] for r in runs),
        "cpu_us_per_cycle": statistics.median(r["cpu_us_per_cycle"] for r in runs),
        "all_chirps_processed": ok, "warmup": warm, "runs": runs}))


if __name__ == "__main__":
    main()
