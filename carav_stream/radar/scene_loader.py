"""Scene files and presets: TOML in, a validated :class:`~carav_stream.radar.scene.Scene` out.

A scene file is flat TOML: radar keys at top level, then ``[[targets]]`` and ``[[attackers]]`` tables
(format and presets: docs/SCENES.md). ``load_scene("table1")`` loads a preset from ``presets/``,
``load_scene("my.toml", {"snr_db": 0})`` a file with overrides. Every key is declared once, like a block
parameter (:data:`SCENE_PARAMS`, :data:`TARGET_PARAMS`; an attacker's keys are its model's ``params``), and
checked by the same :class:`~carav_stream.core.params.Param`. Every problem found is reported at once in one
:class:`SceneError`, each located (``my.toml: targets[0].range_m: must be > 0, got -3``).
"""
from __future__ import annotations

import math
import re
import tomllib
from dataclasses import replace
from pathlib import Path
from typing import Any

from carav_stream.core.params import Param, suggest
from carav_stream.core.units import K_BOLTZMANN, KMH
from carav_stream.radar.attackers import AZIMUTH, AttackerError, make_attacker
from carav_stream.radar.scene import IF_SETTLE_SAMPLES, AttackerSpec, Scene, SceneError, Target, target_warnings

__all__ = ["ARRAY_LAYOUTS", "PRESET_DIR", "SCENE_PARAMS", "TARGET_PARAMS", "apply_overrides", "load_scene",
           "preset_names", "scene_from_dict"]

PRESET_DIR = Path(__file__).with_name("presets")
_ITEM_KEY = re.compile(r"(targets|attackers)\[(\d+)\]\.(\w+)")

# Antenna layouts along the azimuth axis, in wavelengths: (tx positions, rx positions, TDM schedule). A layout
# with n_tx / n_rx given is the uniform linear array (ula): receivers half a wavelength apart, transmitters
# n_rx half-wavelengths apart, so the virtual array is a filled uniform one of n_tx * n_rx elements.
ARRAY_LAYOUTS = {
    "ula": None,
    # TI AWR1642 BoosterPack: TX1 and TX2 two wavelengths apart, four receivers at half a wavelength: an
    # eight-element filled virtual array, chirps alternating TX1, TX2.
    "awr1642": ((0.0, 2.0), (0.0, 0.5, 1.0, 1.5), (0, 1)),
    # TI AWR1243 BoosterPack: TX1 and TX3 two wavelengths apart in azimuth, TX2 between them one wavelength in
    # (and half a wavelength up: elevation is not modelled, so its azimuth offset alone counts), four receivers;
    # chirps TX1, TX2, TX3: twelve virtual elements, four positions held twice.
    "awr1243": ((0.0, 1.0, 2.0), (0.0, 0.5, 1.0, 1.5), (0, 1, 2)),
}

# Defaults are MATLAB phased/FMCWExample hardware (Tables I and II defer to it for RF parameters).
# None: not set; the loader derives the value (see each meaning).
SCENE_PARAMS = (
    Param("name", str, None, "scene name (default: the file name)", optional=True),
    Param("description", str, "", "one line for listings"),
    Param("fc_hz", float, doc="carrier (operating) frequency", unit="Hz", low=0.0, strict=True),
    Param("bandwidth_hz", float, doc="swept bandwidth", unit="Hz", low=0.0, strict=True),
    Param("t_sweep_s", float, doc="sweep duration", unit="s", low=0.0, strict=True),
    Param("t_chirp_s", float, None, "chirp repetition interval (default t_sweep_s)", unit="s", low=0.0,
          strict=True, optional=True),
    Param("t_cycle_s", float, None, "measurement cycle T_m (default n_chirps * t_chirp_s)", unit="s", low=0.0,
          strict=True, optional=True),
    Param("t_adc_start_s", float, None, f"ADC start after the chirp start (default {IF_SETTLE_SAMPLES} / fs_hz: once "
          "the IF filter has settled after the ramp's reset; 0 samples from the reset)", unit="s", low=0.0,
          optional=True),
    Param("fs_hz", float, doc="ADC sample rate", unit="Hz", low=0.0, strict=True),
    Param("n_chirps", int, doc="chirps per cycle N_r, even (half are active)", low=2),
    Param("n_samples", int, None, "samples per chirp N_s (default round((t_sweep_s - t_adc_start_s) fs_hz))",
          low=1, optional=True),
    Param("iq", bool, False, "complex I/Q samples (false: the in-phase branch only)"),
    Param("adc_bits", int, 12, "ADC resolution; 0 = an ideal ADC", low=0, high=24),
    Param("adc_full_scale", float, None, "ADC full scale (default: adc_headroom_db above noise + echoes)",
          unit="sqrt(W)", low=0.0, strict=True, optional=True),
    Param("adc_headroom_db", float, 30.0, "full scale above the RMS of noise and echoes", unit="dB"),
    Param("tx_power_w", float, 3.16e-3, "transmit power", unit="W", low=0.0, strict=True),
    Param("tx_gain_db", float, 36.0, "transmit antenna gain", unit="dB"),
    Param("rx_gain_db", float, 42.0, "receive antenna and chain gain", unit="dB"),
    Param("noise_figure_db", float, 4.5, "receiver noise figure", unit="dB"),
    Param("temperature_k", float, 290.0, "receiver temperature", unit="K", low=0.0, strict=True),
    Param("sigma_n", float, None, "noise RMS per sample (default: from snr_db or the radar equation)",
          unit="sqrt(W)", low=0.0, strict=True, optional=True),
    Param("snr_db", float, None, "per-sample SNR of the first target; sets sigma_n", unit="dB", optional=True),
    Param("radar_speed_mps", float, 0.0, "radar ground speed along boresight", unit="m/s"),
    Param("radar_speed_kmh", float, None, "radar ground speed, instead of radar_speed_mps", unit="km/h",
          optional=True),
    Param("waveform_oversample", int, 4, "waveform fidelity: grid points per ADC sample", low=1),
    Param("if_filter", bool, True, "beat fidelity: an ideal anti-alias (IF) filter removes beats outside the band "
                                   "(false: they fold, as in MATLAB's FMCWExample; waveform fidelity always filters)"),
    Param("array", str, "ula", "antenna layout: a uniform linear array of n_tx x n_rx at half a wavelength, or a "
                               "radar's own (docs/SCENES.md, 'Receiver arrays')", choices=tuple(ARRAY_LAYOUTS)),
    Param("n_rx", int, None, "receivers of the uniform linear array (default 1)", low=1, high=64, optional=True),
    Param("n_tx", int, None, "transmitters of the uniform linear array, fired in turn (TDM; default 1)", low=1,
          high=16, optional=True),
    Param("rx_positions_wl", list, None, "receiver positions along the array, instead of the layout's",
          unit="wavelengths", optional=True),
    Param("tx_positions_wl", list, None, "transmitter positions along the array, instead of the layout's",
          unit="wavelengths", optional=True),
    Param("tdm_schedule", list, None, "one TDM loop: the transmitter (index into the positions) firing in each "
                                      "chirp slot (default each transmitter once, in order)", optional=True),
    Param("targets", list, [], "[[targets]] tables"),
    Param("attackers", list, [], "[[attackers]] tables: kind and the model's parameters"),
)
TARGET_PARAMS = (
    Param("name", str, None, "label", optional=True),
    Param("range_m", float, doc="range at the start of every cycle", unit="m", low=0.0, strict=True),
    Param("velocity_mps", float, 0.0, "ground speed along boresight, + = away", unit="m/s"),
    Param("velocity_kmh", float, None, "ground speed, instead of velocity_mps", unit="km/h", optional=True),
    Param("rcs_m2", float, 1.0, "mean radar cross section", unit="m^2", low=0.0, strict=True),
    Param("swerling", int, 0, "RCS fluctuation model (0 = constant)", choices=(0, 1, 2, 3, 4)),
    Param("azimuth_deg", float, 0.0, "azimuth from boresight, + towards larger array positions", unit="deg",
          low=-90.0, high=90.0),
)
ATTACKER_AZIMUTH = AZIMUTH

_RADAR = {p.name: p for p in SCENE_PARAMS}
_TARGET = {p.name: p for p in TARGET_PARAMS}
_REQUIRED = [p.name for p in SCENE_PARAMS if p.required]


def preset_names() -> list[str]:
    return sorted(p.stem for p in PRESET_DIR.glob("*.toml"))


def load_scene(name_or_path: str, overrides: dict | None = None) -> Scene:
    """Load a preset by name (``table1``, ``table1_following``, ``awr1642``, ``awr1642_literal``) or a TOML file.

    ``overrides`` replaces top-level keys after loading (``{"n_chirps": 32, "iq": True, "snr_db": 0}``);
    ``None`` values remove a key. Raises :class:`SceneError` listing every problem.
    """
    path = Path(name_or_path)
    if not path.suffix and (PRESET_DIR / f"{name_or_path}.toml").exists():
        path = PRESET_DIR / f"{name_or_path}.toml"
    if not path.is_file():
        raise SceneError([f"{name_or_path}: no such scene file or preset "
                          f"(presets: {', '.join(preset_names())})"])
    try:
        d = tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SceneError([f"{path.name}: not valid TOML: {exc}"]) from None
    if overrides:
        d = apply_overrides(d, overrides)
    return scene_from_dict(d, path.name)


def apply_overrides(d: dict, overrides: dict) -> dict:
    """Return a copy of ``d`` with keys replaced. Keys are top-level names or located items
    (``"targets[0].range_m"``, ``"attackers[1].rarms"``). Setting ``snr_db`` or ``sigma_n`` drops the
    other (an override always decides the noise level); a ``None`` value removes the key."""
    out = dict(d)
    for key, value in overrides.items():
        m = _ITEM_KEY.fullmatch(key)
        if m:
            table, index, name = m.group(1), int(m.group(2)), m.group(3)
            items = [dict(x) if isinstance(x, dict) else x for x in out.get(table, [])]
            if index >= len(items) or not isinstance(items[index], dict):
                raise SceneError([f"override {key}: the scene has {len(items)} {table}"])
            if value is None:
                items[index].pop(name, None)
            else:
                items[index][name] = value
            out[table] = items
            continue
        if key in ("snr_db", "sigma_n"):
            out.pop("sigma_n" if key == "snr_db" else "snr_db", None)
        if key in ("radar_speed_mps", "radar_speed_kmh"):
            out.pop("radar_speed_kmh" if key == "radar_speed_mps" else "radar_speed_mps", None)
        if value is None:
            out.pop(key, None)
        else:
            out[key] = value
    return out


class _Problems:
    """Located problems of one scene source."""

    def __init__(self, source: str) -> None:
        self.source, self.items = source, []

    def fail(self, where: str, msg: str) -> None:
        self.items.append(f"{self.source}: {where}: {msg}")

    def checked(self, declared: dict[str, Param], table: dict, prefix: str = "") -> dict[str, Any]:
        """The table's values that pass their declaration (converted); a problem for every other key."""
        good = {}
        for key, value in table.items():
            p = declared.get(key)
            if p is None:
                self.fail(prefix + key, f"unknown key{suggest(key, declared)}")
                continue
            value, problem = p.check(value)
            if problem:
                self.fail(prefix + key, problem)
            else:
                good[key] = value
        return good


def scene_from_dict(d: dict, source: str) -> Scene:
    """Validate a scene dictionary (the parsed TOML) and build the :class:`Scene`.

    ``source`` names the origin in messages (a file name). Raises :class:`SceneError` with all problems.
    """
    if not isinstance(d, dict):
        raise SceneError([f"{source}: a scene must be a table, got {type(d).__name__}"])
    p = _Problems(source)
    v = p.checked(_RADAR, d)
    for k in _REQUIRED:
        if k not in d:
            p.fail(k, "missing (required)")
    for k, param in _RADAR.items():
        if param.default is not None:
            v.setdefault(k, param.default)
    v["name"] = v.get("name") or Path(source).stem
    n_chirps = v.get("n_chirps")
    if isinstance(n_chirps, int) and n_chirps % 2:
        p.fail("n_chirps", f"must be an even number >= 2 (half the chirps are active), got {n_chirps}")
    if "radar_speed_kmh" in d and "radar_speed_mps" in d:
        p.fail("radar_speed_kmh", "give radar_speed_mps or radar_speed_kmh, not both")
    if v.get("radar_speed_kmh") is not None:
        v["radar_speed_mps"] = v["radar_speed_kmh"] * KMH
    if "sigma_n" in d and "snr_db" in d:
        p.fail("snr_db", "give sigma_n or snr_db, not both")
    targets = tuple(_target(p, i, t) for i, t in enumerate(_tables(p, d, "targets")))
    raw_attackers = _tables(p, d, "attackers")
    array = _array(p, v)
    if p.items:
        raise SceneError(p.items)
    tx_pos, rx_pos, schedule = array
    if n_chirps % len(schedule) or (n_chirps // len(schedule)) % 2:
        p.fail("n_chirps", f"{n_chirps} chirps must make an even number of TDM loops of {len(schedule)} slots "
                           "(the activation is balanced over loops)")

    t_chirp = v.get("t_chirp_s") or v["t_sweep_s"]
    default_start = v.get("t_adc_start_s") is None
    if default_start:
        v["t_adc_start_s"] = IF_SETTLE_SAMPLES / v["fs_hz"]
    n_samples = v.get("n_samples") or round((v["t_sweep_s"] - v["t_adc_start_s"]) * v["fs_hz"])
    t_cycle = v.get("t_cycle_s") or n_chirps * t_chirp
    if t_chirp < v["t_sweep_s"]:
        p.fail("t_chirp_s", f"the chirp period must be >= t_sweep_s = {v['t_sweep_s']:.6g} s, got {t_chirp:.6g}")
    if t_cycle < n_chirps * t_chirp * (1 - 1e-12):
        p.fail("t_cycle_s", f"must be >= n_chirps * t_chirp_s = {n_chirps * t_chirp:.6g} s, got {t_cycle:.6g}")
    if n_samples < 1:
        p.fail("n_samples", f"the sweep after t_adc_start_s holds no sample at fs_hz ({n_samples})")
    t_window = v["t_adc_start_s"] + n_samples / v["fs_hz"]
    if t_window > t_chirp + 1.0 / v["fs_hz"]:
        start = (f"t_adc_start_s = {v['t_adc_start_s']:.6g} s (not given: the default, {IF_SETTLE_SAMPLES} samples "
                 "in, once the IF filter has settled after the ramp's reset; t_adc_start_s = 0 samples from the "
                 "reset)" if default_start else "t_adc_start_s")
        p.fail("n_samples", f"{n_samples} samples at {v['fs_hz']:.6g} Hz from {start} end at "
                            f"{t_window:.6g} s, after the chirp period {t_chirp:.6g} s")
    if v.get("snr_db") is not None and not targets:
        p.fail("snr_db", "sets the noise from the first target's SNR, but the scene has no targets")
    if p.items:
        raise SceneError(p.items)

    base = Scene(
        name=v["name"], fc_hz=v["fc_hz"], bandwidth_hz=v["bandwidth_hz"], t_sweep_s=v["t_sweep_s"],
        t_chirp_s=t_chirp, t_cycle_s=t_cycle, t_adc_start_s=v["t_adc_start_s"], fs_hz=v["fs_hz"],
        n_chirps=n_chirps, n_samples=n_samples, iq=v["iq"], adc_bits=v["adc_bits"], adc_full_scale=1.0,
        tx_power_w=v["tx_power_w"], tx_gain_db=v["tx_gain_db"], rx_gain_db=v["rx_gain_db"],
        noise_figure_db=v["noise_figure_db"], temperature_k=v["temperature_k"], sigma_n=1.0,
        radar_speed_mps=v["radar_speed_mps"], targets=targets, waveform_oversample=v["waveform_oversample"],
        if_filter=v["if_filter"], description=v["description"], source=source, adc_start_default=default_start,
        tx_positions_wl=tx_pos, rx_positions_wl=rx_pos, tdm_schedule=schedule)
    sigma_n = _sigma_n(base, v)
    if not (math.isfinite(sigma_n) and sigma_n > 0):   # snr_db = +-1e300 passes the type check, say
        p.fail("snr_db" if v.get("snr_db") is not None else "sigma_n",
               f"gives a noise RMS of {sigma_n:g}; it must be finite and > 0")
        raise SceneError(p.items)
    full_scale = v.get("adc_full_scale")
    if full_scale is None:
        total_w = sigma_n ** 2 + sum(base.echo_power_w(t) for t in targets)
        full_scale = math.sqrt(total_w) * 10 ** (v["adc_headroom_db"] / 20)
    scene = replace(base, sigma_n=sigma_n, adc_full_scale=full_scale)

    specs = [spec for i, a in enumerate(raw_attackers) if (spec := _attacker_spec(p, i, a, scene)) is not None]
    if p.items:
        raise SceneError(p.items)
    scene = replace(scene, attackers=tuple(specs))
    return replace(scene, warnings=tuple(target_warnings(scene) + _attacker_warnings(scene)))


def _array(p: _Problems, v: dict) -> tuple[tuple[float, ...], tuple[float, ...], tuple[int, ...]]:
    """(tx positions, rx positions, TDM schedule) from the layout, n_tx/n_rx and explicit positions."""
    layout = ARRAY_LAYOUTS.get(v.get("array", "ula"))
    if layout is not None:
        for key in ("n_rx", "n_tx"):
            if v.get(key) is not None:
                p.fail(key, f"the {v['array']} layout fixes its antennas; give {key} with array = \"ula\"")
        tx, rx, schedule = layout
    else:
        n_rx, n_tx = v.get("n_rx") or 1, v.get("n_tx") or 1
        rx = tuple(0.5 * r for r in range(n_rx))
        tx = tuple(0.5 * n_rx * t for t in range(n_tx))
        schedule = tuple(range(n_tx))
    tx = _positions(p, "tx_positions_wl", v.get("tx_positions_wl"), tx)
    rx = _positions(p, "rx_positions_wl", v.get("rx_positions_wl"), rx)
    given = v.get("tdm_schedule")
    if given is not None:
        if not given or not all(isinstance(j, int) and not isinstance(j, bool) and 0 <= j < len(tx) for j in given):
            p.fail("tdm_schedule", f"must list transmitter indices 0..{len(tx) - 1}, got {given!r}")
        else:
            schedule = tuple(given)
    elif v.get("tx_positions_wl") is not None:
        schedule = tuple(range(len(tx)))
    return tx, rx, schedule


def _positions(p: _Problems, key: str, given: list | None, default: tuple[float, ...]) -> tuple[float, ...]:
    if given is None:
        return default
    ok = (given and len(given) <= 64 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                               and math.isfinite(x) and abs(x) <= 1e4 for x in given))
    if not ok:
        p.fail(key, f"must list 1 to 64 finite positions in wavelengths, got {given!r}")
        return default
    return tuple(float(x) for x in given)


def _sigma_n(scene: Scene, v: dict) -> float:
    if v.get("sigma_n") is not None:
        return float(v["sigma_n"])
    if v.get("snr_db") is not None:
        power = scene.echo_power_w(scene.targets[0])
        if not power > 0:
            return 0.0
        log10_ratio = math.log10(power) - v["snr_db"] / 10   # in logs: no overflow for any snr_db
        return 10 ** (log10_ratio / 2) if log10_ratio < 600 else math.inf
    noise_w = (K_BOLTZMANN * scene.temperature_k * scene.fs_hz * 10 ** (scene.noise_figure_db / 10)
               * 10 ** (scene.rx_gain_db / 10))
    return math.sqrt(noise_w if scene.iq else noise_w / 2.0)


def _tables(p: _Problems, d: dict, key: str) -> list:
    value = d.get(key, [])
    if not isinstance(value, list) or not all(isinstance(x, dict) for x in value):
        p.fail(key, f"must be a list of tables ([[{key}]]), got {value!r}")
        return []
    return value


def _target(p: _Problems, i: int, t: dict) -> Target | None:
    where = f"targets[{i}]"
    v = p.checked(_TARGET, t, f"{where}.")
    if "range_m" not in t:
        p.fail(f"{where}.range_m", "missing (required)")
    if "velocity_mps" in t and "velocity_kmh" in t:
        p.fail(f"{where}.velocity_kmh", "give velocity_mps or velocity_kmh, not both")
    if len(v) != len(t) or "range_m" not in v:
        return None
    velocity = v["velocity_kmh"] * KMH if v.get("velocity_kmh") is not None else v.get("velocity_mps", 0.0)
    return Target(range_m=v["range_m"], velocity_mps=velocity, rcs_m2=v.get("rcs_m2", 1.0),
                  swerling=v.get("swerling", 0), azimuth_deg=v.get("azimuth_deg", 0.0))


def _attacker_spec(p: _Problems, i: int, a: dict, scene: Scene) -> AttackerSpec | None:
    where = f"attackers[{i}]"
    kind = a.get("kind")
    params = {k: val for k, val in a.items() if k not in ("kind", "azimuth_deg")}
    azimuth, problem = ATTACKER_AZIMUTH.check(a.get("azimuth_deg", 0.0))
    if problem:
        p.fail(f"{where}.azimuth_deg", problem)
    if not isinstance(kind, str):
        p.fail(f"{where}.kind", f"missing or not a string, got {kind!r}")
        return None
    try:
        make_attacker(kind, scene, **params)
    except AttackerError as exc:
        for name, msg in exc.problems:
            p.fail(f"{where}.{name}" if name else where, msg)
        return None
    frozen = {k: tuple(val) if isinstance(val, list) else val for k, val in params.items()}
    return AttackerSpec(kind, tuple(sorted(frozen.items())), azimuth_deg=0.0 if problem else azimuth)


def _attacker_warnings(scene: Scene) -> list[str]:
    """Each attacker's own doubts, and ADC saturation by its expected peak."""
    out = []
    src = scene.source or scene.name
    for i, spec in enumerate(scene.attackers):
        attacker = make_attacker(spec.kind, scene, **spec.kwargs())
        out.extend(f"{src}: attackers[{i}]: {w}" for w in attacker.physics_warnings())
        peak = attacker.peak_amplitude()
        if scene.adc_bits and peak > scene.adc_full_scale:
            out.append(f"{src}: attackers[{i}]: expected peak {peak:.3g} exceeds the ADC full scale "
                       f"{scene.adc_full_scale:.3g} ({peak / scene.adc_full_scale:.1f}x): the ADC "
                       f"will clip (counted per cycle in 'clipped')")
    return out
