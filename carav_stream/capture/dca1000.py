"""Raw ADC captures of TI's DCA1000 capture card, in every layout of TI's documented devices.

TI's DCA1000 and mmWave Studio raw-capture descriptions (the DCA1000EVM user guide, the raw ADC capture
application note SWRA581 and the reading scripts that come with them): the .bin file is a stream of
little-endian 16-bit words, chirp after chirp in capture order. Within a chirp the order depends on how many
LVDS lanes the radar uses:

  2 lanes (xWR16xx, xWR18xx, xWR68xx): receiver after receiver; within a receiver, its n_samples samples.
      real data:    one word per sample, in sample order
      complex data: every two samples n, n+1 of a receiver travel as four words I(n), I(n+1), Q(n), Q(n+1)
                    (lane 1 carries even samples, lane 2 odd ones, I before Q)
  4 lanes (xWR12xx, xWR14xx): one receiver per lane; sample after sample; within a sample, the lanes.
      real data:    a group of four words holds sample n of lanes 1..4
      complex data: a group of eight words holds I(n) of lanes 1..4, then Q(n) of lanes 1..4
      The capture always carries the four lanes, whatever receivers are enabled (TI's script: "the number of
      lanes is always 4 even if only 1 lane is used; unused lanes are populated with 0"): receivers 1..n_rx
      are lanes 1..n_rx, and the other lanes are read and dropped.

Encodings. Two's complement: a 12- or 14-bit ADC delivers its codes without sign extension (a code above
2^(b-1) - 1 is negative and 2^b is subtracted from it, as TI's scripts do). Offset binary (what some capture
tools write): the code plus 2^(b-1), i.e. the top bit of the b-bit code inverted; it is inverted back, then the
code is read as two's complement.

A cycle (a radar frame in TI's words) is `n_chirps` consecutive chirps, in the order the radar fired them (a TDM
MIMO profile's chirps alternate transmitters within the cycle: the scene's tdm_schedule says which fired each).
The blocks send the cycles shaped like this project's ADC frames (capture_receivers, receiver_frames): for a scene
with one receiver, one receiver's samples, int16 (cycles, n_chirps, n_samples) for real data, (cycles, n_chirps,
n_samples, 2) with I then Q for complex data; for a scene with several receivers (rx_positions_wl), that many of
the capture's, with a receiver axis: int16 (cycles, receivers, n_chirps, n_samples[, 2]).

Cost: decoding is a few numpy passes over the words (reshape, transpose, one copy); the sign and offset fixes of
12/14-bit or offset-binary codes add one int32 pass.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from carav_stream.core.params import Param

LANES = (2, 4)                                     # xWR16xx/18xx/68xx: 2 LVDS lanes; xWR12xx/14xx: 4
ENCODINGS = ("twos_complement", "offset_binary")

# What a DCA1000 capture's layout and activation take, the same for a file (dca1000_source) and the live stream
# (dca1000_udp_source): one declaration for both blocks.
CAPTURE_PARAMS = (
    Param("activation", str, "", "activation log of the capture ('' = use pattern)", file=True),
    Param("pattern", str, "", "fixed activation pattern of every cycle, n_chirps digits 0 | 1"),
    Param("n_rx", int, 4, "receivers enabled in the capture", low=1, high=4),
    Param("rx", int, 0, "receiver to process, for a scene with one receiver", low=0, high=3),
    Param("receivers", str, "", "receivers to send with a receiver axis: 'all' or a list such as '0,2' ('': all the "
                                "capture's for a scene with several receivers, else rx alone)"),
    Param("lanes", int, 2, "LVDS lanes: 2 (xWR16xx/18xx/68xx) or 4 (xWR12xx/14xx)", choices=(2, 4)),
    Param("encoding", str, "twos_complement", "how the words hold the codes", choices=ENCODINGS),
)


@dataclass(frozen=True)
class Layout:
    n_rx: int           # receivers enabled in the capture
    n_samples: int      # ADC samples per chirp and receiver
    n_chirps: int       # chirps per cycle (TI: per frame)
    complex: bool       # complex (I/Q) or real capture
    adc_bits: int = 16
    lanes: int = 2
    encoding: str = "twos_complement"

    def __post_init__(self) -> None:
        if not 1 <= self.n_rx <= 4 or self.n_samples < 1 or self.n_chirps < 1 or self.adc_bits not in (12, 14, 16):
            raise ValueError(f"DCA1000 layout: n_rx 1..4, n_samples >= 1, n_chirps >= 1, adc_bits 12 | 14 | 16; "
                             f"got {self}")
        if self.lanes not in LANES:
            raise ValueError(f"DCA1000 layout: lanes must be 2 (xWR16xx/18xx/68xx) or 4 (xWR12xx/14xx), "
                             f"got {self.lanes}")
        if self.encoding not in ENCODINGS:
            raise ValueError(f"DCA1000 layout: encoding must be one of {', '.join(ENCODINGS)}, got {self.encoding!r}")
        if self.lanes == 2 and self.complex and (self.n_samples * self.n_rx) % 2:
            raise ValueError(f"DCA1000 layout: complex samples travel in pairs over 2 lanes: n_samples x n_rx "
                             f"must be even, got {self.n_samples} x {self.n_rx}")

    @property
    def lanes_carried(self) -> int:
        """Receiver slots in each chirp of the file: n_rx over 2 lanes, always 4 over 4 lanes."""
        return 4 if self.lanes == 4 else self.n_rx

    @property
    def words_per_chirp(self) -> int:
        return self.lanes_carried * self.n_samples * (2 if self.complex else 1)

    @property
    def bytes_per_cycle(self) -> int:
        return 2 * self.words_per_chirp * self.n_chirps

    def describe(self) -> str:
        return (f"{self.n_chirps} chirps x {self.n_rx} receivers x {self.n_samples} "
                f"{'complex' if self.complex else 'real'} {self.adc_bits}-bit samples, {self.lanes} lanes, "
                f"{self.encoding.replace('_', ' ')}")


def capture_layout(scene, n_rx: int, lanes: int, encoding: str) -> Layout:
    """The Layout of a scene's capture with the CAPTURE_PARAMS values. Codes wider than 14 bits are read as 16."""
    return Layout(n_rx, scene.n_samples, scene.n_chirps, scene.iq,
                  scene.adc_bits if scene.adc_bits in (12, 14) else 16, lanes, encoding)


def capture_receivers(scene, n_rx: int, rx: int, receivers: str) -> int | tuple[int, ...]:
    """Which of the capture's n_rx receivers the blocks send (CAPTURE_PARAMS): an index for a scene with one receiver
    (frames without a receiver axis), a tuple of scene.n_rx indices for a scene with several. ValueError in one line,
    naming the parameter, when they contradict the scene or the capture."""
    text = receivers.strip()
    if text and rx:
        raise ValueError(f"rx, receivers: give one of them, got rx = {rx} and receivers = {receivers!r}")
    if text == "all" or not text and scene.n_rx > 1:
        chosen = tuple(range(n_rx))
    elif text:
        try:
            chosen = tuple(int(r) for r in text.split(","))
        except ValueError:
            raise ValueError(f"receivers: expected 'all' or receivers such as '0,2', got {receivers!r}") from None
        if len(set(chosen)) < len(chosen) or not all(0 <= r < n_rx for r in chosen):
            raise ValueError(f"receivers: {receivers!r}: expected distinct receivers 0..{n_rx - 1} of the capture's "
                             f"n_rx = {n_rx}")
    else:
        if rx >= n_rx:
            raise ValueError(f"rx: receiver {rx} is not among the capture's n_rx = {n_rx}")
        return rx
    if scene.n_rx == 1:
        if len(chosen) == 1:
            return chosen[0]
        raise ValueError(f"receivers: {receivers!r} sends {len(chosen)} receivers, but the scene {scene.name} has one "
                         "(no rx_positions_wl): give it its receivers' positions, or send one receiver with rx")
    if len(chosen) != scene.n_rx:
        raise ValueError(f"n_rx, receivers: the capture's receivers {list(chosen)} (n_rx = {n_rx}) contradict the "
                         f"scene {scene.name}'s {scene.n_rx} receivers (rx_positions_wl)")
    return chosen


def receiver_frames(codes: np.ndarray, chosen: int | tuple[int, ...]) -> np.ndarray:
    """Decoded codes (cycles, n_chirps, n_rx, n_samples[, 2]) -> the frames capture_receivers chose: int16 (cycles,
    n_chirps, n_samples[, 2]) for one receiver, (cycles, len(chosen), n_chirps, n_samples[, 2]) for several."""
    if isinstance(chosen, int):
        return np.ascontiguousarray(codes[:, :, chosen])
    return np.ascontiguousarray(np.moveaxis(codes, 2, 1)[:, list(chosen)])


def check_loops(rho: np.ndarray, n_slots: int, where: str) -> None:
    """ValueError naming `where` (the pattern: one row, or the activation log: a row per cycle, in capture order)
    when a row of rho (rows, n_chirps) mixes active and silent chirps within one of the scene's TDM loops."""
    if n_slots == 1 or rho.size == 0:
        return
    loops = rho.reshape(rho.shape[0], -1, n_slots)
    mixed = np.argwhere(loops.any(axis=2) != loops.all(axis=2))
    if mixed.size:
        row, loop = (int(v) for v in mixed[0])
        cycle = f"cycle {row}, " if rho.shape[0] > 1 else ""
        raise ValueError(f"{where}: {cycle}chirps {loop * n_slots}..{loop * n_slots + n_slots - 1} mix active and "
                         f"silent chirps; the scene's TDM loops of {n_slots} slots are active or silent as a whole")


def signed_codes(words: np.ndarray, adc_bits: int, encoding: str) -> np.ndarray:
    """The ADC's codes as int16 from the file's words (int16, any shape): offset binary's top bit inverted back,
    a 12- or 14-bit code's sign extended."""
    if adc_bits == 16 and encoding == "twos_complement":
        return words
    wide = words.astype(np.int32) & (2 ** adc_bits - 1)
    if encoding == "offset_binary":
        wide ^= 2 ** (adc_bits - 1)
    wide[wide > 2 ** (adc_bits - 1) - 1] -= 2 ** adc_bits
    return wide.astype(np.int16)


def decode(words: np.ndarray, layout: Layout) -> np.ndarray:
    """int16 words of whole cycles -> int16 (cycles, n_chirps, n_rx, n_samples[, 2]) (I, Q on the last axis)."""
    words = np.asarray(words)
    if words.dtype != np.dtype("<i2") or words.ndim != 1 or words.size % (layout.words_per_chirp * layout.n_chirps):
        raise ValueError(f"DCA1000 words: expected little-endian int16 of whole cycles "
                         f"({layout.words_per_chirp * layout.n_chirps} words each), got {words.dtype} {words.shape}")
    words = signed_codes(words, layout.adc_bits, layout.encoding)
    chirps = words.size // layout.words_per_chirp
    n_s, n_rx = layout.n_samples, layout.n_rx
    if layout.lanes == 4 and not layout.complex:     # (sample, lane) -> (lane, sample)
        out = words.reshape(chirps, n_s, 4).transpose(0, 2, 1)[:, :n_rx]
    elif layout.lanes == 4:                          # (sample, I|Q, lane) -> (lane, sample, I|Q)
        out = words.reshape(chirps, n_s, 2, 4).transpose(0, 3, 1, 2)[:, :n_rx]
    elif not layout.complex:
        out = words.reshape(chirps, n_rx, n_s)
    else:   # groups of four words I(n), I(n+1), Q(n), Q(n+1) -> (sample, I|Q)
        quads = words.reshape(chirps, n_rx * n_s // 2, 2, 2)   # (pair, I|Q, n|n+1)
        out = quads.transpose(0, 1, 3, 2).reshape(chirps, n_rx, n_s, 2)
    return np.ascontiguousarray(out.reshape(chirps // layout.n_chirps, layout.n_chirps, *out.shape[1:]))


def complete_cycles(path: str | Path, layout: Layout) -> tuple[int, int]:
    """(whole cycles in the capture, bytes left after them: a truncated capture leaves some)."""
    size = Path(path).stat().st_size
    return size // layout.bytes_per_cycle, size % layout.bytes_per_cycle


def read_cycles(path: str | Path, layout: Layout, first: int, count: int,
                rx: int | tuple[int, ...] | None) -> np.ndarray:
    """Cycles [first, first + count) of the capture: receiver_frames(codes, rx), or with rx None every receiver as
    decoded, int16 (count, n_chirps, n_rx, n_samples[, 2])."""
    words = np.fromfile(path, dtype="<i2", count=count * layout.bytes_per_cycle // 2,
                        offset=first * layout.bytes_per_cycle)
    codes = decode(words, layout)
    return codes if rx is None else receiver_frames(codes, rx)
