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
sequence the paper asks for: an attacker who watches a few cycles learns which chirps are silent. The receivers
(popcount of rxChannelEn) describe the capture, not the scene, and go in its comments.

Every problem is one line naming the file, line, command and field (TiCfgError).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

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

    @property
    def balanced(self) -> bool:
        return self.pattern.count("1") * 2 == len(self.pattern)


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


def profile_from_cfg(text: str, source: str = "profile.cfg") -> TiProfile:
    """The scene of a TI mmWave CLI profile (see the module docstring); TiCfgError naming the line and field."""
    commands, others = parse(text, source)
    channel, adc, frame = (_one(commands, n, source) for n in ("channelCfg", "adcCfg", "frameCfg"))
    at = {n: f"{source}:{c.line}: {n}" for n, c in (("channelCfg", channel), ("adcCfg", adc), ("frameCfg", frame))}
    rx_en, tx_en = channel.values["rxChannelEn"], channel.values["txChannelEn"]
    if not 0 < rx_en < 16:
        raise TiCfgError(f"{at['channelCfg']}: rxChannelEn: expected a mask of receivers 1..15, got {rx_en}")
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
    chirp_of = {}
    for c in commands.get("chirpCfg", []):
        v = c.values
        for name in ("startFreqVar", "freqSlopeVar", "idleTimeVar", "adcStartTimeVar"):
            if v[name] != 0:
                raise TiCfgError(f"{source}:{c.line}: chirpCfg: {name}: {v[name]:g} varies the chirp; a scene has "
                                 "one chirp shape (expected 0)")
        for idx in range(v["chirpStartIdx"], v["chirpEndIdx"] + 1):
            chirp_of[idx] = c
    profiles = {c.values["profileId"]: c for c in commands.get("profileCfg", [])}
    used = []
    for idx in range(f["chirpStartIdx"], f["chirpEndIdx"] + 1):
        if idx not in chirp_of:
            raise TiCfgError(f"{at['frameCfg']}: chirpStartIdx..chirpEndIdx: chirp {idx} has no chirpCfg")
        used.append(chirp_of[idx])
    ids = {c.values["profileId"] for c in used}
    if len(ids) != 1:
        raise TiCfgError(f"{at['frameCfg']}: the frame's chirps use profiles {sorted(ids)}; a scene has one chirp "
                         "shape (expected one profile)")
    pid = ids.pop()
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
    pattern = "".join("1" if c.values["txEnable"] & tx_en else "0" for c in used) * f["numLoops"]
    scene = {
        "name": Path(source).stem, "description": "",
        "fc_hz": p["startFreq"] * 1e9 + slope * (adc_start_s + window_s / 2),
        "bandwidth_hz": slope * ramp_s, "t_sweep_s": ramp_s, "t_chirp_s": (p["idleTime"] + p["rampEndTime"]) * 1e-6,
        "t_cycle_s": f["framePeriodicity"] * 1e-3, "t_adc_start_s": adc_start_s, "fs_hz": fs_hz,
        "n_chirps": len(pattern), "n_samples": p["numAdcSamples"], "iq": adc.values["adcOutputFmt"] > 0,
        "adc_bits": ADC_BITS[adc.values["numADCBits"]], "rx_gain_db": p["rxGain"],
    }
    silent = pattern.count("0")
    scene["description"] = (f"TI profile {Path(source).name}: " + (
        f"{silent} of {len(pattern)} chirps silent (txEnable = 0), a fixed pattern, not the paper's secret "
        "per-cycle sequence" if silent else "every chirp transmits (no activation pattern)"))
    rx = [i for i in range(4) if rx_en >> i & 1]
    return TiProfile(scene, len(rx), rx, pattern, source, others)


def scene_toml(profile: TiProfile, sigma_n: float | None = None) -> str:
    """The scene as TOML the scene loader accepts, with the capture's facts and the profile's sources as comments."""
    s = dict(profile.scene)
    s["adc_full_scale"] = 1.0
    if sigma_n is not None:
        s["sigma_n"] = sigma_n
    silent = profile.pattern.count("0")
    lines = [f"# Scene of the TI mmWave CLI profile {profile.source} (carav scenes --from-ti-cfg).",
             f"# Capture: n_rx = {profile.n_rx} (rxChannelEn: RX{', RX'.join(str(i + 1) for i in profile.rx_channels)}"
             "); lanes = 2 for xWR16xx/18xx/68xx, 4 for xWR12xx/14xx (the profile does not name the device).",
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


def _toml(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return repr(value)
    if isinstance(value, float):   # 12 significant digits: the microsecond arithmetic's last bits say nothing
        return repr(float(f"{value:.12g}"))
    return json.dumps(value)
