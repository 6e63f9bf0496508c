"""TI mmWave CLI profiles (.cfg) as this project's scenes.

The commands read, with the argument order of TI's mmWave SDK user guide ("Configuration (.cfg) File Format"):

  channelCfg  rxChannelEn txChannelEn cascading
  adcCfg      numADCBits (0: 12, 1: 14, 2: 16 bits) adcOutputFmt (0: real, 1: complex 1x, 2: complex 2x)
  profileCfg  profileId startFreq(GHz) idleTime(us) adcStartTime(us) rampEndTime(us) txOutPower txPhaseShifter
              freqSlopeConst(MHz/us) txStartTime(us) numAdcSamples digOutSampleRate(ksps) hpfCornerFreq1
              hpfCornerFreq2 rxGain(dB)
  chirpCfg    chirpStartIdx chirpEndIdx profileId startFreqVar(Hz) freqSlopeVar(kHz/us) idleTimeVar(us)
              adcStartTimeVar(us) txEnable (bit mask of the transmitters)
  frameCfg    chirpStartIdx chirpEndIdx numLoops numFrames framePeriodicity(ms) triggerSelect frameTriggerDelay(ms)

Lines starting with % are comments; every other command (sensorStart, cfarCfg, lvdsStreamCfg, ...) is listed
as not read. The scene:

  fs_hz = digOutSampleRate 1e3, slope = freqSlopeConst 1e12 Hz/s, t_sweep_s = rampEndTime,
  bandwidth_hz = slope rampEndTime, t_chirp_s = idleTime + rampEndTime, t_adc_start_s = adcStartTime,
  n_samples = numAdcSamples, n_chirps = (chirpEndIdx - chirpStartIdx + 1) numLoops, t_cycle_s =
  framePeriodicity, iq = adcOutputFmt > 0, adc_bits, fc_hz = startFreq + slope (adcStartTime + n_samples / 2 fs)
  (the centre of the band the ADC samples, where the phase a velocity turns per chirp is measured)

A chirp whose txEnable (masked by channelCfg's txChannelEn) is 0 transmits nothing: those chirps are the
capture's fixed activation pattern, the same in every cycle. A fixed pattern is not the secret per-cycle
sequence the paper asks for: an attacker who watches a few cycles learns which chirps are silent.

Transmitters. The chirps of a cycle (the frame's chirps, numLoops times) are cut into TDM loops: the shortest
n_slots such that every block of n_slots consecutive chirps fires the same transmitters in the same order, one
per chirp, or none (a silent loop). One transmitter throughout (or the same set firing together in every chirp,
as beamforming and BPM profiles do) is today's single-antenna scene: the receivers (popcount of rxChannelEn)
describe the capture, not the scene, and go in its comments; dca1000_source's rx picks one. Several transmitters
in turn make a MIMO scene:

  tx_positions_wl   the device's positions of the transmitters that fire (carav_stream/capture/ti_devices.py),
                    in TX order
  tdm_schedule      the loop's transmitters, as indices into tx_positions_wl, in chirpCfg order
  rx_positions_wl   the device's positions of the receivers rxChannelEn enables

so that the unambiguous velocity is lambda / (4 n_slots t_chirp): a transmitter repeats every n_slots chirps.
A loop that mixes silent and transmitting chirps, or single transmitters with several firing together, is
refused. The profile does not name its device: `device` chooses the layout and the LVDS lanes; without it the
awr1642 (TX1, TX2) is assumed, or the iwr6843 when channelCfg enables TX3, and the scene's comments say so.

Every problem is one line naming the file, line, command and field (TiCfgError).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from carav_stream.capture.ti_devices import DEFAULT_DEVICE, DEFAULT_DEVICE_3TX, DEVICES, Device
from carav_stream.core.units import C_MPS

FIELDS = {
    "channelCfg": ("rxChannelEn", "txChannelEn", "cascading"),
    "adcCfg": ("numADCBits", "adcOutputFmt"),
    "profileCfg": ("profileId", "startFreq", "idleTime", "adcStartTime", "rampEndTime", "txOutPower",
                   "txPhaseShifter", "freqSlopeConst", "txStartTime", "numAdcSamples", "digOutSampleRate",
                   "hpfCornerFreq1", "hpfCornerFreq2", "rxGain"),
    "chirpCfg": ("chirpStartIdx", "chirpEndIdx", "profileId", "startFreqVar", "freqSlopeVar", "idleTimeVar",
                 "adcStartTimeVar", "txEnable"),
    "frameCfg": ("chirpStartIdx", "chirpEndIdx", "numLoops", "numFrames", "framePeriodicity", "triggerSelect",
                 "frameTriggerDelay"),
}
INTEGER = {"rxChannelEn", "txChannelEn", "cascading", "numADCBits", "adcOutputFmt", "profileId", "numAdcSamples",
           "chirpStartIdx", "chirpEndIdx", "txEnable", "numLoops", "numFrames", "triggerSelect"}
ADC_BITS = {0: 12, 1: 14, 2: 16}


class TiCfgError(ValueError):
    """A profile that cannot be read or turned into a scene; the text names the file, line, command and field."""


@dataclass
class Command:
    name: str
    line: int
    values: dict[str, float | int]


@dataclass
class TiProfile:
    """The scene's keys (TOML-ready), the capture's facts and where each came from."""

    scene: dict[str, object]
    n_rx: int
    rx_channels: list[int]
    pattern: str                        # one digit per chirp of a cycle: 1 transmits, 0 silent
    source: str
    not_read: list[str] = field(default_factory=list)
    device: Device = DEVICES[DEFAULT_DEVICE]
    device_assumed: bool = True         # the profile does not name its device: `device` was not given
    schedule: tuple[int, ...] = (0,)    # the TDM loop's transmitters (0 = TX1), one per slot
    together: tuple[int, ...] = ()      # transmitters that fire together in every transmitting chirp (several)

    @property
    def balanced(self) -> bool:
        return self.pattern.count("1") * 2 == len(self.pattern)

    @property
    def mimo(self) -> bool:
        return len(set(self.schedule)) > 1

    def device_line(self) -> str:
        how = "assumed: the profile does not name its device, --device chooses" if self.device_assumed else "given"
        return f"device {self.device.name} ({self.device.family}; {how}): lanes = {self.device.lanes}"

    def velocity_line(self) -> str:
        """One line: the unambiguous velocity per transmitter repetition and the single chirp's it replaces."""
        s = self.scene
        wavelength, n = C_MPS / s["fc_hz"], len(self.schedule)
        one = wavelength / (4 * s["t_chirp_s"])
        return (f"TDM over {', '.join(f'TX{t + 1}' for t in self.schedule)} ({n} slots a loop): unambiguous velocity "
                f"+-{one / n:.4g} m/s = lambda / (4 x {n} x {s['t_chirp_s'] * 1e6:.4g} us), per transmitter "
                f"repetition, not the single chirp's +-{one:.4g} m/s")


def _number(text: str, name: str, where: str) -> float | int:
    try:
        value = float(text)
    except ValueError:
        raise TiCfgError(f"{where}: {name}: expected a number, got {text!r}") from None
    if name in INTEGER:
        if value != int(value):
            raise TiCfgError(f"{where}: {name}: expected an integer, got {text!r}")
        return int(value)
    return value


def parse(text: str, source: str = "profile.cfg") -> tuple[dict[str, list[Command]], list[str]]:
    """The read commands by name, and the others as 'name (line n)'."""
    commands: dict[str, list[Command]] = {}
    others = []
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.split("%", 1)[0].strip()
        if not line:
            continue
        words = line.split()
        name, args = words[0], words[1:]
        if name not in FIELDS:
            others.append(f"{name} (line {number})")
            continue
        where = f"{source}:{number}: {name}"
        names = FIELDS[name]
        if len(args) < len(names):
            raise TiCfgError(f"{where}: expected {len(names)} fields ({' '.join(names)}), got {len(args)}: "
                             f"{names[len(args)]} is missing")
        values = {n: _number(a, n, where) for n, a in zip(names, args)}
        commands.setdefault(name, []).append(Command(name, number, values))
    return commands, others


def _one(commands: dict[str, list[Command]], name: str, source: str) -> Command:
    found = commands.get(name, [])
    if len(found) != 1:
        raise TiCfgError(f"{source}: {name}: expected exactly one, found {len(found)}"
                         + (f" (lines {', '.join(str(c.line) for c in found)})" if found else ""))
    return found[0]


def _bits(mask: int) -> list[int]:
    return [i for i in range(max(mask, 0).bit_length()) if mask >> i & 1]


def _device(name: str | None, tx_en: int, where: str) -> tuple[Device, bool]:
    """The device given (TiCfgError when channelCfg enables a transmitter it lacks), or the one assumed from the
    transmitters channelCfg enables."""
    if name is None:
        return DEVICES[DEFAULT_DEVICE_3TX if tx_en >> 2 & 1 else DEFAULT_DEVICE], True
    if name not in DEVICES:
        raise TiCfgError(f"device: {name!r} is not one of {', '.join(DEVICES)}")
    device = DEVICES[name]
    extra = [t for t in _bits(tx_en) if t >= len(device.tx_positions_wl)]
    if extra:
        raise TiCfgError(f"{where}: txChannelEn: {tx_en} enables TX{extra[0] + 1}; the {name} has "
                         f"{len(device.tx_positions_wl)} transmitters")
    return device, False


def _frame_chirps(commands: dict[str, list[Command]], frame: Command, source: str) -> list[Command]:
    """The chirpCfg of every chirp of the frame, chirpStartIdx..chirpEndIdx; each of one chirp shape."""
    chirp_of = {}
    for c in commands.get("chirpCfg", []):
        v = c.values
        for name in ("startFreqVar", "freqSlopeVar", "idleTimeVar", "adcStartTimeVar"):
            if v[name] != 0:
                raise TiCfgError(f"{source}:{c.line}: chirpCfg: {name}: {v[name]:g} varies the chirp; a scene has "
                                 "one chirp shape (expected 0)")
        for idx in range(v["chirpStartIdx"], v["chirpEndIdx"] + 1):
            chirp_of[idx] = c
    used = []
    for idx in range(frame.values["chirpStartIdx"], frame.values["chirpEndIdx"] + 1):
        if idx not in chirp_of:
            raise TiCfgError(f"{source}:{frame.line}: frameCfg: chirpStartIdx..chirpEndIdx: chirp {idx} has no "
                             "chirpCfg")
        used.append(chirp_of[idx])
    return used


def tdm_loop(masks: list[int]) -> tuple[tuple[int, ...], str] | None:
    """(the loop's transmitter masks, the cycle's pattern) of the chirps' transmitter masks: the shortest loop such
    that every block of that many consecutive chirps fires the loop's masks in order, or nothing; None if none does.
    One transmitter, or one set firing together, is a loop of one slot."""
    for n in range(1, len(masks) + 1):
        if len(masks) % n:
            continue
        blocks = [tuple(masks[i:i + n]) for i in range(0, len(masks), n)]
        firing = {b for b in blocks if any(b)}
        if len(firing) <= 1 and all(all(b) for b in firing):
            loop = firing.pop() if firing else (0,) * n
            return loop, "".join(("1" if any(b) else "0") * n for b in blocks)
    return None


def _transmitters(used: list[Command], frame: Command, tx_en: int,
                  source: str) -> tuple[tuple[int, ...], tuple[int, ...], str]:
    """(the TDM schedule as TX indices, the transmitters that fire together, the cycle's pattern)."""
    masks = [c.values["txEnable"] & tx_en for c in used] * frame.values["numLoops"]
    found = tdm_loop(masks)
    at = f"{source}:{frame.line}: frameCfg"
    order = ", ".join("TX" + "+TX".join(str(t + 1) for t in _bits(m)) if m else "-" for m in masks[:len(used)])
    if found is None:
        raise TiCfgError(f"{at}: the frame's chirps fire {order}: not TDM loops (a loop fires the same transmitters "
                         "in turn, one a chirp, or none: silent chirps inside a loop are not a scene's activation)")
    loop, pattern = found
    if len(set(loop)) > 1 and any(len(_bits(m)) > 1 for m in loop):
        raise TiCfgError(f"{at}: the frame's chirps fire {order}: several transmitters together in some chirps "
                         "and others alone (BPM or mixed beams), not one transmitter a chirp in turn (TDM)")
    if len(set(loop)) == 1:
        return (0,), tuple(_bits(loop[0])) if len(_bits(loop[0])) > 1 else (), pattern
    return tuple(_bits(m)[0] for m in loop), (), pattern


def profile_from_cfg(text: str, source: str = "profile.cfg", device: str | None = None) -> TiProfile:
    """The scene of a TI mmWave CLI profile (see the module docstring); TiCfgError naming the line and field.
    `device` (a key of DEVICES) gives the antenna layout and lanes; None assumes one (module docstring)."""
    commands, others = parse(text, source)
    channel, adc, frame = (_one(commands, n, source) for n in ("channelCfg", "adcCfg", "frameCfg"))
    at = {n: f"{source}:{c.line}: {n}" for n, c in (("channelCfg", channel), ("adcCfg", adc), ("frameCfg", frame))}
    rx_en, tx_en = channel.values["rxChannelEn"], channel.values["txChannelEn"]
    if not 0 < rx_en < 16:
        raise TiCfgError(f"{at['channelCfg']}: rxChannelEn: expected a mask of receivers 1..15, got {rx_en}")
    radar, assumed = _device(device, tx_en, at["channelCfg"])
    if adc.values["numADCBits"] not in ADC_BITS:
        raise TiCfgError(f"{at['adcCfg']}: numADCBits: expected 0 (12 bits), 1 (14) or 2 (16), got "
                         f"{adc.values['numADCBits']}")
    if adc.values["adcOutputFmt"] not in (0, 1, 2):
        raise TiCfgError(f"{at['adcCfg']}: adcOutputFmt: expected 0 (real), 1 or 2 (complex), got "
                         f"{adc.values['adcOutputFmt']}")
    f = frame.values
    if f["chirpEndIdx"] < f["chirpStartIdx"] or f["numLoops"] < 1 or f["framePeriodicity"] <= 0:
        raise TiCfgError(f"{at['frameCfg']}: expected chirpEndIdx >= chirpStartIdx, numLoops >= 1 and "
                         f"framePeriodicity > 0, got {f['chirpStartIdx']}, {f['chirpEndIdx']}, {f['numLoops']}, "
                         f"{f['framePeriodicity']}")
    used = _frame_chirps(commands, frame, source)
    scene = _chirp_scene(commands, used, frame, adc, source)
    schedule, together, pattern = _transmitters(used, frame, tx_en, source)
    rx = _bits(rx_en)
    profile = TiProfile(scene, len(rx), rx, pattern, source, others, radar, assumed, schedule, together)
    silent = pattern.count("0")
    activation = (f"{silent} of {len(pattern)} chirps silent (txEnable = 0), a fixed pattern, not the paper's secret "
                  "per-cycle sequence" if silent else "every chirp transmits (no activation pattern)")
    scene["description"] = f"TI profile {Path(source).name}: " + activation
    if profile.mimo:
        fired = sorted(set(schedule))
        if fired[-1] >= len(radar.tx_positions_wl):
            raise TiCfgError(f"{source}:{frame.line}: frameCfg: the frame's chirps fire TX{fired[-1] + 1}; the "
                             f"{radar.name} (assumed) has {len(radar.tx_positions_wl)} transmitters, and no device "
                             "read here has more")
        scene["description"] = (f"TI profile {Path(source).name}, {radar.name}: TDM over "
                                f"{', '.join(f'TX{t + 1}' for t in schedule)} x {len(rx)} RX; {activation}")
        scene["tx_positions_wl"] = [radar.tx_positions_wl[t] for t in fired]
        scene["tdm_schedule"] = [fired.index(t) for t in schedule]
        scene["rx_positions_wl"] = [radar.rx_positions_wl[r] for r in rx]
    return profile


def _chirp_scene(commands: dict[str, list[Command]], used: list[Command], frame: Command, adc: Command,
                 source: str) -> dict[str, object]:
    """The scene's chirp, sampling and cycle keys from the frame's one profileCfg (description left empty)."""
    ids = {c.values["profileId"] for c in used}
    if len(ids) != 1:
        raise TiCfgError(f"{source}:{frame.line}: frameCfg: the frame's chirps use profiles {sorted(ids)}; a scene "
                         "has one chirp shape (expected one profile)")
    pid = ids.pop()
    profiles = {c.values["profileId"]: c for c in commands.get("profileCfg", [])}
    if pid not in profiles:
        raise TiCfgError(f"{source}:{used[0].line}: chirpCfg: profileId: {pid} has no profileCfg")
    p, line = profiles[pid].values, profiles[pid].line
    where = f"{source}:{line}: profileCfg"
    for name in ("idleTime", "rampEndTime", "freqSlopeConst", "digOutSampleRate", "numAdcSamples", "startFreq"):
        if p[name] <= 0:
            raise TiCfgError(f"{where}: {name}: must be > 0, got {p[name]:g}")
    fs_hz = p["digOutSampleRate"] * 1e3
    slope = p["freqSlopeConst"] * 1e12
    adc_start_s, ramp_s = p["adcStartTime"] * 1e-6, p["rampEndTime"] * 1e-6
    window_s = p["numAdcSamples"] / fs_hz
    if adc_start_s + window_s > ramp_s * (1 + 1e-9):
        raise TiCfgError(f"{where}: numAdcSamples: {p['numAdcSamples']} samples at {p['digOutSampleRate']:g} ksps "
                         f"from adcStartTime {p['adcStartTime']:g} us end at {(adc_start_s + window_s) * 1e6:.4g} "
                         f"us, after rampEndTime {p['rampEndTime']:g} us")
    return {
        "name": Path(source).stem, "description": "",
        "fc_hz": p["startFreq"] * 1e9 + slope * (adc_start_s + window_s / 2),
        "bandwidth_hz": slope * ramp_s, "t_sweep_s": ramp_s, "t_chirp_s": (p["idleTime"] + p["rampEndTime"]) * 1e-6,
        "t_cycle_s": frame.values["framePeriodicity"] * 1e-3, "t_adc_start_s": adc_start_s, "fs_hz": fs_hz,
        "n_chirps": len(used) * frame.values["numLoops"], "n_samples": p["numAdcSamples"],
        "iq": adc.values["adcOutputFmt"] > 0, "adc_bits": ADC_BITS[adc.values["numADCBits"]], "rx_gain_db": p["rxGain"],
    }


def scene_toml(profile: TiProfile, sigma_n: float | None = None) -> str:
    """The scene as TOML the scene loader accepts, with the capture's facts and the profile's sources as comments."""
    s = dict(profile.scene)
    s["adc_full_scale"] = 1.0
    if sigma_n is not None:
        s["sigma_n"] = sigma_n
    silent = profile.pattern.count("0")
    lines = [f"# Scene of the TI mmWave CLI profile {profile.source} (carav scenes --from-ti-cfg).",
             f"# Capture: n_rx = {profile.n_rx} (rxChannelEn: {_receivers(profile.rx_channels)}); "
             f"{profile.device_line()}.", *_antenna_lines(profile),
             "# adc_full_scale = 1: one code is 1 / 2^(adc_bits - 1); " + (
                 "sigma_n is the noise RMS given in codes." if sigma_n is not None else
                 "sigma_n comes from the radar equation, not from this radar: measure the noise RMS in codes with "
                 "`carav capture inspect` and set sigma_n = codes / 2^(adc_bits - 1).")]
    if silent:
        lines += [f"# Activation pattern (txEnable = 0 chirps silent), the same in every cycle: {profile.pattern}",
                  "# A fixed pattern is not the secret per-cycle sequence the paper asks for: an attacker who watches "
                  "a few cycles learns it.", "# Give it to dca1000_source or dca1000_udp_source as `pattern`."
                  + ("" if profile.balanced else f" The detector needs half the chirps active; this pattern has "
                                                 f"{len(profile.pattern) - silent} of {len(profile.pattern)}.")]
    if profile.not_read:
        lines.append(f"# Not read (no scene field): {', '.join(profile.not_read)}")
    for key, value in s.items():
        lines.append(f"{key} = {_toml(value)}")
    return "\n".join(lines) + "\n"


def _receivers(channels: list[int]) -> str:
    return ", ".join(f"RX{r + 1}" for r in channels)


def _antenna_lines(profile: TiProfile) -> list[str]:
    """Comments on the antennas: the TDM array and its velocity, or how the single transmitter's scene is read."""
    d = profile.device
    if profile.mimo:
        s = profile.scene
        virtual = [s["tx_positions_wl"][j] + r for j in s["tdm_schedule"] for r in s["rx_positions_wl"]]
        return [f"# TDM MIMO: transmitters at {', '.join(f'{x:g}' for x in s['tx_positions_wl'])} wavelengths "
                f"(the {d.name}'s layout), receivers {_receivers(profile.rx_channels)} at "
                f"{', '.join(f'{x:g}' for x in s['rx_positions_wl'])}: {len(virtual)} virtual elements at "
                f"{', '.join(f'{x:g}' for x in virtual)} wavelengths (slot-major).",
                f"# {profile.velocity_line()}."]
    lines = []
    if profile.together:
        lines.append(f"# TX{'+TX'.join(str(t + 1) for t in profile.together)} fire together in every transmitting "
                     "chirp (beamforming or BPM; bpmCfg is not read): one transmitter for the scene, no virtual array.")
    if profile.n_rx > 1:
        positions = ", ".join(repr(d.rx_positions_wl[r]) for r in profile.rx_channels)
        lines.append(f"# One transmitter: the scene has one receiver (dca1000_source's rx picks it); "
                     f"rx_positions_wl = [{positions}] (the {d.name}'s {_receivers(profile.rx_channels)}) makes it "
                     "a receiver array.")
    return lines


def _toml(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return repr(value)
    if isinstance(value, float):   # 12 significant digits: the microsecond arithmetic's last bits say nothing
        return repr(float(f"{value:.12g}"))
    return json.dumps(value)
