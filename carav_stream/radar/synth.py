"""Synthesis of ADC frames, cycle-batched: transmit -> channel -> attacker -> ADC.

    R_k[m] = n_k[m] + rho(k) x_k[m] + a_k[m]            (paper, Section IV; quantised by the ADC)

Each stage is a pure function of its inputs and one ``numpy.random.Generator`` per stage, drawing in
cycle order, so running N cycles at once gives bit for bit what N one-cycle calls give (the
streaming pipeline runs the stages in separate processes, one cycle at a time):

    tx = transmit(scene, rho, cycle0, fidelity)              # what goes on the air
    rx = channel(scene, tx, rng_noise, cycle0)               # echoes + receiver noise (ADC input)
    rx, active = attacker.apply(rx, cycle0, rng_attack, observe(tx), fidelity=tx.fidelity)
    frames, clipped = adc(scene, rx)

``simulate_cycles`` is exactly that composition. Frames: float32 (I-only) or complex64 (I/Q), shape
(n_cycles, n_chirps, n_samples), or (n_cycles, n_rx, n_chirps, n_samples) for a scene with several receivers
(``Scene.frame_shape``), in sqrt(W) at the ADC (1 ohm), quantised. Echoes and attacks reach each receiver with the
far-field phase of its antenna (radar/arrays.py); each receiver has its own noise.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from carav_stream.radar.adc import adc_codes, from_codes, with_nonfinite
from carav_stream.radar.arrays import receiver_echoes
from carav_stream.radar.attackers import Observation
from carav_stream.radar.noise import gaussian
from carav_stream.radar.scene import Scene

FIDELITIES = ("auto", "beat", "waveform")
CHUNK_BYTES = 2 << 20
# The channel draws noise and adds echoes a few cycles at a time, about one core's L2 cache (1 MiB): table1
# (276 kB a cycle) goes 3 cycles at a time. Into output frames not in cache (the graph's shared-memory slots), a few
# cycles at a time cost less per cycle than one at a time, and more than a few gain little more; that holds with
# the nodes' allocator settings (core.allocator), without which the gathered echo rows of several cycles are a
# fresh mapping every time.
CHANNEL_CHUNK_BYTES = 1 << 20


@dataclass(frozen=True)
class Transmission:
    """What the victim put on the air for a batch of cycles.

    rho: bool (n_cycles, n_chirps), chirp k of cycle cycle0 + i was transmitted iff rho[i, k].
    fidelity: "beat" or "waveform" (resolved, never "auto").
    """

    rho: np.ndarray
    cycle0: int
    fidelity: str


@dataclass(frozen=True)
class Cycles:
    """Result of :func:`simulate_cycles` for cycles cycle0 .. cycle0 + n_cycles - 1.

    frames: float32 | complex64 ``scene.frame_shape(n_cycles)``, after the ADC.
    clean_echo: same dtype and shape, noise-free rho * x (ADC input, unquantised), or None.
    clipped: int64 (n_cycles,), samples per cycle at the ADC rails (I or Q), every receiver's.
    attack_active: bool (n_cycles,), the attacker emitted something in the cycle.
    codes: what the ADC delivered (:func:`adc_codes`): int16 codes, or the samples of an ideal ADC.
    nonfinite: int64 (n_cycles,), samples per cycle (every receiver's) that were NaN/Inf at the ADC input (such a
    cycle is invalid).
    """

    frames: np.ndarray
    clean_echo: np.ndarray | None
    clipped: np.ndarray
    attack_active: np.ndarray
    fidelity: str
    rho: np.ndarray
    cycle0: int
    codes: np.ndarray | None = None
    nonfinite: np.ndarray | None = None


def resolve_fidelity(fidelity: str, attacker=None) -> str:
    """``auto`` -> ``waveform`` if the attacker transmits its own waveform, else ``beat``."""
    if fidelity not in FIDELITIES:
        raise ValueError(f"fidelity: unknown {fidelity!r}, expected one of {', '.join(FIDELITIES)}")
    if fidelity != "auto":
        if fidelity == "beat" and attacker is not None and attacker.needs_waveform:
            raise ValueError(f"fidelity 'beat' cannot render attacker {attacker.kind!r}, which transmits its "
                             f"own waveform: use 'waveform' or 'auto'")
        return fidelity
    return "waveform" if attacker is not None and attacker.needs_waveform else "beat"


def transmit(scene: Scene, rho: np.ndarray, cycle0: int = 0, fidelity: str = "beat") -> Transmission:
    """Check the activation rows and put them on the air. ``fidelity`` must be resolved already."""
    rho = np.asarray(rho)
    if rho.dtype != np.bool_:
        raise TypeError(f"rho: expected a bool array, got dtype {rho.dtype}")
    if rho.ndim != 2 or rho.shape[1] != scene.n_chirps:
        raise ValueError(f"rho: expected shape (n_cycles, {scene.n_chirps}), got {rho.shape}")
    if fidelity not in ("beat", "waveform"):
        raise ValueError(f"transmit: fidelity must be 'beat' or 'waveform' (resolve 'auto' first), got {fidelity!r}")
    rho = rho.copy()
    rho.setflags(write=False)
    return Transmission(rho, int(cycle0), fidelity)


def observe(tx: Transmission) -> Observation:
    """The on-air emission an attacker can listen to (the same bits, but the attacker's only view)."""
    return Observation(tx.rho, tx.cycle0)


def draw_noise(scene: Scene, rng: np.random.Generator, n_cycles: int, *, out: np.ndarray | None = None) -> np.ndarray:
    """Receiver noise, i.i.d. N(0, sigma_n^2) per sample (circular complex for I/Q: sigma_n^2/2 per
    component), independent from receiver to receiver. float32 / complex64 ``scene.frame_shape(n_cycles)``, drawn
    in C order over (cycle, [receiver,] chirp, sample), written into ``out`` if given (a C-contiguous array of that
    shape and dtype). One block of the generator's stream per cycle (carav_stream.radar.noise), so batches equal
    one-cycle calls."""
    return gaussian(rng, scene.frame_shape(n_cycles), scene.sigma_n, scene.iq, out=out)


def swerling_gains(scene: Scene, rng: np.random.Generator) -> np.ndarray:
    """Amplitude factors sqrt(sigma / mean sigma) of every target for one cycle: float32 (n_targets,
    n_chirps). Swerling 1, 3: one draw per cycle (scan to scan); 2, 4: one per chirp; 1, 2: sigma
    exponential (chi^2, 2 dof); 3, 4: chi^2 with 4 dof; 0: constant. Targets are drawn in order."""
    n = scene.n_chirps
    gains = np.ones((len(scene.targets), n), dtype=np.float32)
    for i, t in enumerate(scene.targets):
        if t.swerling == 0:
            continue
        size = 1 if t.swerling in (1, 3) else n
        shape_k = 1.0 if t.swerling in (1, 2) else 2.0
        gains[i] = np.sqrt(rng.gamma(shape_k, 1.0 / shape_k, size=size))
    return gains


def _add_echo(scene: Scene, rx: np.ndarray, rho: np.ndarray, fidelity: str,
              gains: np.ndarray | None = None) -> None:
    """rx += sum_t g_t[k] (rho[k] main_t[k] + rho[k-1] tail_t[k]), in place, for one or more cycles; rx of
    ``scene.frame_shape``, the templates at every receiver (arrays.receiver_echoes)."""
    tpl = receiver_echoes(scene, fidelity)
    rho_prev = np.zeros_like(rho)
    rho_prev[:, 1:] = rho[:, :-1]      # the chirp before chirp 0 (previous cycle) is taken as silent
    if gains is None:
        # rx[i, k] += template[k] where on[i, k], all the chunk's cycles at once: gather the active chirps'
        # rows, add, scatter back (the same float32 additions as np.add(..., where=on), which costs more)
        for template, on in ((tpl.main_sum, rho), (tpl.tail_sum, rho_prev)):
            if template is None or not on.any():
                continue
            if on.all():
                rx += template
                continue
            cycle, k = np.nonzero(on)
            if rx.ndim == 3:
                part = rx[cycle, k]
                part += template[k]
                rx[cycle, k] = part
            else:                      # every receiver of an active chirp: (n_on, n_rx, n_samples)
                part = rx[cycle, :, k]
                part += template.transpose(1, 0, 2)[k]
                rx[cycle, :, k] = part
        return
    chirps = (rho.shape[0],) + (1,) * (rx.ndim - 3) + (rho.shape[1], 1)   # weights per chirp, over receivers
    for t in range(len(scene.targets)):
        g = gains[t]
        rx += (g * rho).reshape(chirps) * tpl.main[t]
        if tpl.tail is not None:
            g_prev = np.concatenate([np.zeros(1, np.float32), g[:-1]])
            rx += (g_prev * rho_prev).reshape(chirps) * tpl.tail[t]


def channel(scene: Scene, tx: Transmission, rng_noise: np.random.Generator, cycle0: int = 0, *,
            return_clean: bool = False, out: np.ndarray | None = None):
    """Echoes of the transmitted chirps plus receiver noise: the signal at the ADC input.

    Draws from ``rng_noise``, per cycle in order: the Swerling factors of fluctuating targets, then
    the noise. Returns rx (float32 | complex64, ``scene.frame_shape(n_cycles)``), or (rx, clean)
    with ``return_clean`` (clean = the noise-free echo part); ``out``: a C-contiguous array of rx's shape and
    dtype to compute rx into (returned). Works a few cycles at a time (noise, then echoes, while the chunk is
    still in cache).
    """
    if cycle0 != tx.cycle0:
        raise ValueError(f"channel: cycle0 {cycle0} does not match the transmission's cycle0 {tx.cycle0}")
    n_cycles = tx.rho.shape[0]
    dtype = np.complex64 if scene.iq else np.float32
    shape = scene.frame_shape(n_cycles)
    if out is not None and (out.dtype != dtype or out.shape != shape or not out.flags.c_contiguous):
        raise ValueError(f"channel: out must be a C-contiguous {np.dtype(dtype)} array of shape {shape}, got "
                         f"{out.dtype} {out.shape}")
    rx = np.empty(shape, dtype) if out is None else out
    clean = np.zeros_like(rx) if return_clean else None
    fluctuating = any(t.swerling for t in scene.targets)
    cycle_bytes = max(1, int(np.prod(shape[1:])) * np.dtype(dtype).itemsize)
    step = 1 if fluctuating else max(1, CHANNEL_CHUNK_BYTES // cycle_bytes)
    for a in range(0, n_cycles, step):
        b = min(a + step, n_cycles)
        if not fluctuating:
            draw_noise(scene, rng_noise, b - a, out=rx[a:b])
            _add_echo(scene, rx[a:b], tx.rho[a:b], tx.fidelity)
            if clean is not None:
                _add_echo(scene, clean[a:b], tx.rho[a:b], tx.fidelity)
            continue
        gains = swerling_gains(scene, rng_noise)
        draw_noise(scene, rng_noise, 1, out=rx[a:b])
        echo = np.zeros((1,) + rx.shape[1:], dtype)
        _add_echo(scene, echo, tx.rho[a:b], tx.fidelity, gains)
        rx[a] += echo[0]
        if clean is not None:
            clean[a] = echo[0]
    return (rx, clean) if return_clean else rx


def simulate_cycles(scene: Scene, rho: np.ndarray, rng_noise: np.random.Generator, *, attacker=None,
                    rng_attack: np.random.Generator | None = None, fidelity: str = "auto", cycle0: int = 0,
                    return_clean: bool = False) -> Cycles:
    """Simulate ADC frames for the activation rows ``rho`` (bool (n_cycles, n_chirps)).

    ``attacker``: an object from :func:`carav_stream.radar.attackers.make_attacker` (stateful: keep
    using the same one for consecutive batches) or None. ``rng_attack`` is required when the attacker
    draws random numbers. Equal, bit for bit, to running transmit/channel/apply/adc per cycle.
    """
    fid = resolve_fidelity(fidelity, attacker)
    rho = transmit(scene, rho, cycle0, fid).rho
    n_cycles = rho.shape[0]
    dtype = np.complex64 if scene.iq else np.float32
    frames = np.empty(scene.frame_shape(n_cycles), dtype)
    clean = np.empty_like(frames) if return_clean else None
    clipped = np.zeros(n_cycles, dtype=np.int64)
    nonfinite = np.zeros(n_cycles, dtype=np.int64)
    active = np.zeros(n_cycles, dtype=bool)
    codes = []
    # Stages run on chunks of about 2 MB: the same numbers (every stage draws cycle by cycle), but the
    # intermediate arrays stay in cache, which makes large batches as fast per cycle as small ones.
    step = max(1, CHUNK_BYTES // (int(np.prod(frames.shape[1:])) * np.dtype(dtype).itemsize))
    for i in range(0, n_cycles, step):
        j = min(i + step, n_cycles)
        tx = transmit(scene, rho[i:j], cycle0 + i, fid)
        out = channel(scene, tx, rng_noise, cycle0 + i, return_clean=return_clean)
        rx = out[0] if return_clean else out
        if return_clean:
            clean[i:j] = out[1]
        if attacker is not None:
            rx, active[i:j] = attacker.apply(rx, cycle0 + i, rng_attack, observe(tx), fidelity=fid)
        chunk, clipped[i:j], nonfinite[i:j] = adc_codes(scene, rx)
        codes.append(chunk)
        frames[i:j] = with_nonfinite(from_codes(scene, chunk), rx, nonfinite[i:j])
    codes = np.concatenate(codes) if codes else adc_codes(scene, frames)[0]
    return Cycles(frames, clean, clipped, active, fid, rho, cycle0, codes, nonfinite)


def echo_energy_per_chirp(scene: Scene, rho: np.ndarray, fidelity: str = "beat") -> np.ndarray:
    """Noise-free echo energy sum_(r, m) |rho(k) x_k,r[m]|^2 per chirp, over every receiver r, float64 (n_cycles,
    n_chirps), at the mean RCS (Swerling factors = 1). W * samples, ADC input, unquantised."""
    tpl = receiver_echoes(scene, fidelity)
    rho = np.asarray(rho, dtype=bool)

    def energy(x: np.ndarray) -> np.ndarray:    # (n_chirps,): summed over the samples and the receivers
        e = np.sum(np.abs(x.astype(np.complex128)) ** 2, axis=-1)
        return e.sum(axis=0) if e.ndim == 2 else e

    e_main = energy(tpl.main_sum)
    if tpl.tail_sum is None:
        return rho * e_main[None, :]
    # main and tail overlap little; sum the exact energy of each combination present
    rho_prev = np.zeros_like(rho)
    rho_prev[:, 1:] = rho[:, :-1]
    e_tail = energy(tpl.tail_sum)
    e_both = energy(tpl.main_sum.astype(np.complex128) + tpl.tail_sum)
    return np.where(rho & rho_prev, e_both, rho * e_main + rho_prev * e_tail)
