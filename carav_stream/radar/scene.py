"""Scenes: the radar, its targets and its attackers, loaded from TOML and validated.

A scene file is flat TOML: radar keys at top level, then ``[[targets]]`` and ``[[attackers]]`` tables
(format and presets: docs/SCENES.md). ``load_scene("table1")`` loads a preset from ``presets/``,
``load_scene("my.toml", {"snr_db": 0})`` a file with overrides. Every problem found is reported at once
in one :class:`SceneError`, each located (``my.toml: targets[0].range_m: must be > 0, got -3``).
Physics that is legal but probably not what the user meant (a beat beyond the ADC's Nyquist rate, a
Doppler beyond the unambiguous velocity, an attacker that saturates the ADC) goes to ``Scene.warnings``.

Conventions
    * Target ``velocity_mps`` is the target's ground speed along the radar's boresight, positive in
      the radar's direction of travel (away from the radar); the radar moves at ``radar_speed_mps``.
      The range rate is ``velocity_mps - radar_speed_mps`` (Table I: 96 - 100 km/h, closing).
    * Geometry is frozen per cycle: every cycle starts from the scene's ranges (stationary statistics,
      as in the paper's Monte Carlo runs); motion within a cycle is modelled (Doppler, migration).
    * Samples are in sqrt(W) at the receiver output (1 ohm), after the receive gain.
    * ``sigma_n`` is the per-sample noise RMS at the ADC input, E|n|^2 = sigma_n^2, for I-only and I/Q
      alike. An I-only receiver is the I branch of the I/Q one: it sees half the echo power and half
      the noise power, so the per-sample SNR is the same in both modes.
    * Noise level, first match wins: ``sigma_n`` (explicit), ``snr_db`` (per-sample SNR of the first
      target), else the radar equation: k T fs F G_rx (noise bandwidth = sample rate).
"""
from __future__ import annotations

import difflib
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

C_MPS = 299_792_458.0
K_BOLTZMANN = 1.380649e-23
PRESET_DIR = Path(__file__).with_name("presets")
KMH = 1.0 / 3.6
_ITEM_KEY = re.compile(r"(targets|attackers)\[(\d+)\]\.(\w+)")


class SceneError(ValueError):
    """All problems of a scene, one located message per line (``problems`` holds them)."""

    def __init__(self, problems: list[str]):
        self.problems = list(problems)
        super().__init__("invalid scene:\n  " + "\n  ".join(self.problems))


@dataclass(frozen=True)
class Target:
    """A point target. ``velocity_mps`` is its ground speed along boresight (+ = away)."""

    range_m: float
    velocity_mps: float = 0.0
    rcs_m2: float = 1.0
    swerling: int = 0


@dataclass(frozen=True)
class AttackerSpec:
    """An attacker as written in a scene: its kind and its parameters (name, value) pairs."""

    kind: str
    params: tuple[tuple[str, Any], ...] = ()

    def kwargs(self) -> dict[str, Any]:
        return dict(self.params)


@dataclass(frozen=True)
class Scene:
    """A validated scene. Frozen and hashable, so derived arrays can be cached per scene."""

    name: str
    fc_hz: float
    bandwidth_hz: float
    t_sweep_s: float
    t_chirp_s: float
    t_cycle_s: float
    t_adc_start_s: float
    fs_hz: float
    n_chirps: int
    n_samples: int
    iq: bool
    adc_bits: int
    adc_full_scale: float
    tx_power_w: float
    tx_gain_db: float
    rx_gain_db: float
    noise_figure_db: float
    temperature_k: float
    sigma_n: float
    radar_speed_mps: float
    targets: tuple[Target, ...] = ()
    attackers: tuple[AttackerSpec, ...] = ()
    waveform_oversample: int = 4
    warnings: tuple[str, ...] = ()
    description: str = ""
    source: str = field(default="", compare=False)

    @property
    def slope_hz_per_s(self) -> float:
        return self.bandwidth_hz / self.t_sweep_s

    @property
    def wavelength_m(self) -> float:
        return C_MPS / self.fc_hz

    @property
    def range_resolution_m(self) -> float:
        """c / (2 B_sampled), B_sampled the bandwidth swept during the sampling window."""
        return C_MPS / (2.0 * self.slope_hz_per_s * self.n_samples / self.fs_hz)

    @property
    def max_beat_hz(self) -> float:
        """Highest representable beat: fs for complex (I/Q) sampling, fs/2 for real (I-only)."""
        return self.fs_hz if self.iq else self.fs_hz / 2.0

    @property
    def max_range_m(self) -> float:
        """Range whose beat reaches ``max_beat_hz`` (Doppler ignored)."""
        return self.max_beat_hz * C_MPS / (2.0 * self.slope_hz_per_s)

    @property
    def max_velocity_mps(self) -> float:
        """Unambiguous |range rate|: lambda / (4 t_chirp)."""
        return self.wavelength_m / (4.0 * self.t_chirp_s)

    @property
    def cycles_per_s(self) -> float:
        return 1.0 / self.t_cycle_s

    def range_rate_mps(self, target: Target) -> float:
        return target.velocity_mps - self.radar_speed_mps

    def beat_hz(self, target: Target) -> float:
        """Beat of ``target`` at chirp 0: S tau - f_D (MATLAB dechirp convention, f_D > 0 closing)."""
        tau_s = 2.0 * target.range_m / C_MPS
        return self.slope_hz_per_s * tau_s + 2.0 * self.range_rate_mps(target) / self.wavelength_m

    def echo_power_w(self, target: Target) -> float:
        """Mean per-sample echo power at the ADC input (radar equation, two-way free space).

        Pt Gt Grx sigma lambda^2 / ((4 pi)^3 R^4), halved for I-only (the I branch sees half).
        """
        p_w = (self.tx_power_w * 10 ** (self.tx_gain_db / 10) * 10 ** (self.rx_gain_db / 10)
               * target.rcs_m2 * self.wavelength_m ** 2 / ((4 * math.pi) ** 3 * target.range_m ** 4))
        return p_w if self.iq else p_w / 2.0

    def snr_db(self, target_index: int = 0) -> float:
        """Per-sample SNR of a target, in dB (same for I-only and I/Q)."""
        return 10 * math.log10(self.echo_power_w(self.targets[target_index]) / self.sigma_n ** 2)


# ---------------------------------------------------------------------------------------------
# Loading

_RADAR_KEYS = {
    "name": str, "description": str, "fc_hz": float, "bandwidth_hz": float, "t_sweep_s": float,
    "t_chirp_s": float, "t_cycle_s": float, "t_adc_start_s": float, "fs_hz": float, "n_chirps": int,
    "n_samples": int, "iq": bool, "adc_bits": int, "adc_full_scale": float, "adc_headroom_db": float,
    "tx_power_w": float, "tx_gain_db": float, "rx_gain_db": float, "noise_figure_db": float,
    "temperature_k": float, "sigma_n": float, "snr_db": float, "radar_speed_mps": float,
    "radar_speed_kmh": float, "waveform_oversample": int, "targets": list, "attackers": list,
}
# MATLAB phased/FMCWExample hardware (Tables I and II defer to it for RF parameters).
_DEFAULTS = {
    "description": "", "t_adc_start_s": 0.0, "iq": False, "adc_bits": 12, "adc_headroom_db": 30.0,
    "tx_power_w": 3.16e-3, "tx_gain_db": 36.0, "rx_gain_db": 42.0, "noise_figure_db": 4.5,
    "temperature_k": 290.0, "radar_speed_mps": 0.0, "waveform_oversample": 4,
}
_REQUIRED = ("fc_hz", "bandwidth_hz", "t_sweep_s", "fs_hz", "n_chirps")
_TARGET_KEYS = {"range_m": float, "velocity_mps": float, "velocity_kmh": float, "rcs_m2": float,
                "swerling": int, "name": str}


def preset_names() -> list[str]:
    return sorted(p.stem for p in PRESET_DIR.glob("*.toml"))


def load_scene(name_or_path: str, overrides: dict | None = None) -> Scene:
    """Load a preset by name (``table1``, ``awr1642``, ``awr1642_literal``) or a TOML file.

    ``overrides`` replaces top-level keys after loading (``{"n_chirps": 32, "iq": True, "snr_db": 0}``);
    ``None`` values remove a key. Raises :class:`SceneError` listing every problem.
    """
    path = Path(name_or_path)
    if not path.suffix and (PRESET_DIR / f"{name_or_path}.toml").exists():
        path = PRESET_DIR / f"{name_or_path}.toml"
    if not path.exists():
        raise SceneError([f"{name_or_path}: no such scene file or preset "
                          f"(presets: {', '.join(preset_names())})"])
    try:
        d = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
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


def scene_from_dict(d: dict, source: str) -> Scene:
    """Validate a scene dictionary (the parsed TOML) and build the :class:`Scene`.

    ``source`` names the origin in messages (a file name). Raises :class:`SceneError` with all problems.
    """
    problems: list[str] = []
    p = _Checker(source, problems)
    if not isinstance(d, dict):
        raise SceneError([f"{source}: a scene must be a table, got {type(d).__name__}"])
    for key in d:
        if key not in _RADAR_KEYS:
            p.fail(key, f"unknown key{_suggest(key, _RADAR_KEYS)}")
    v = {k: p.typed(k, d[k], t) for k, t in _RADAR_KEYS.items() if k in d and k not in ("targets", "attackers")}
    for k in _REQUIRED:
        if k not in d:
            p.fail(k, "missing (required)")
    for k, default in _DEFAULTS.items():
        v.setdefault(k, default)
    v.setdefault("name", Path(source).stem)
    for k in ("fc_hz", "bandwidth_hz", "t_sweep_s", "fs_hz", "tx_power_w", "temperature_k"):
        p.positive(k, v.get(k))
    for k in ("t_chirp_s", "t_cycle_s", "adc_full_scale", "sigma_n", "n_samples", "waveform_oversample"):
        if k in v:
            p.positive(k, v[k])
    if v.get("t_adc_start_s", 0.0) is not None and v["t_adc_start_s"] < 0:
        p.fail("t_adc_start_s", f"must be >= 0, got {v['t_adc_start_s']}")
    n_chirps = v.get("n_chirps")
    if isinstance(n_chirps, int) and (n_chirps < 2 or n_chirps % 2):
        p.fail("n_chirps", f"must be an even number >= 2 (half the chirps are active), got {n_chirps}")
    if v["adc_bits"] is not None and not 0 <= v["adc_bits"] <= 24:
        p.fail("adc_bits", f"must be 0 (ideal ADC) to 24, got {v['adc_bits']}")
    if "radar_speed_kmh" in v:
        if "radar_speed_mps" in d:
            p.fail("radar_speed_kmh", "give radar_speed_mps or radar_speed_kmh, not both")
        kmh = v.pop("radar_speed_kmh")
        v["radar_speed_mps"] = kmh * KMH if kmh is not None else None
    if "sigma_n" in v and "snr_db" in v:
        p.fail("snr_db", "give sigma_n or snr_db, not both")
    targets = tuple(_target(p, i, t) for i, t in enumerate(_list(p, d, "targets")))
    raw_attackers = _list(p, d, "attackers")
    if problems:
        raise SceneError(problems)

    t_chirp = v.get("t_chirp_s", v["t_sweep_s"])
    n_samples = v.get("n_samples", round((v["t_sweep_s"] - v["t_adc_start_s"]) * v["fs_hz"]))
    t_cycle = v.get("t_cycle_s", n_chirps * t_chirp)
    if t_chirp < v["t_sweep_s"]:
        p.fail("t_chirp_s", f"the chirp period must be >= t_sweep_s = {v['t_sweep_s']:.6g} s, got {t_chirp:.6g}")
    if t_cycle < n_chirps * t_chirp * (1 - 1e-12):
        p.fail("t_cycle_s", f"must be >= n_chirps * t_chirp_s = {n_chirps * t_chirp:.6g} s, got {t_cycle:.6g}")
    t_window = v["t_adc_start_s"] + n_samples / v["fs_hz"]
    if t_window > t_chirp + 1.0 / v["fs_hz"]:
        p.fail("n_samples", f"{n_samples} samples at {v['fs_hz']:.6g} Hz from t_adc_start_s end at "
                            f"{t_window:.6g} s, after the chirp period {t_chirp:.6g} s")
    if v.get("snr_db") is not None and not targets:
        p.fail("snr_db", "sets the noise from the first target's SNR, but the scene has no targets")
    if problems:
        raise SceneError(problems)

    base = Scene(
        name=v["name"], fc_hz=v["fc_hz"], bandwidth_hz=v["bandwidth_hz"], t_sweep_s=v["t_sweep_s"],
        t_chirp_s=t_chirp, t_cycle_s=t_cycle, t_adc_start_s=v["t_adc_start_s"], fs_hz=v["fs_hz"],
        n_chirps=n_chirps, n_samples=n_samples, iq=v["iq"], adc_bits=v["adc_bits"], adc_full_scale=1.0,
        tx_power_w=v["tx_power_w"], tx_gain_db=v["tx_gain_db"], rx_gain_db=v["rx_gain_db"],
        noise_figure_db=v["noise_figure_db"], temperature_k=v["temperature_k"], sigma_n=1.0,
        radar_speed_mps=v["radar_speed_mps"], targets=targets, waveform_oversample=v["waveform_oversample"],
        description=v["description"], source=source)
    sigma_n = _sigma_n(base, v)
    if not (math.isfinite(sigma_n) and sigma_n > 0):   # snr_db = +-1e300 passes the type check, say
        p.fail("snr_db" if v.get("snr_db") is not None else "sigma_n",
               f"gives a noise RMS of {sigma_n:g}; it must be finite and > 0")
        raise SceneError(problems)
    full_scale = v.get("adc_full_scale")
    if full_scale is None:
        total_w = sigma_n ** 2 + sum(base.echo_power_w(t) for t in targets)
        full_scale = math.sqrt(total_w) * 10 ** (v["adc_headroom_db"] / 20)
    scene = _replace(base, sigma_n=sigma_n, adc_full_scale=full_scale)

    specs = []
    for i, a in enumerate(raw_attackers):
        spec = _attacker_spec(p, i, a, scene)
        if spec is not None:
            specs.append(spec)
    if problems:
        raise SceneError(problems)
    scene = _replace(scene, attackers=tuple(specs))
    return _replace(scene, warnings=tuple(physics_warnings(scene)))


def _replace(scene: Scene, **changes) -> Scene:
    from dataclasses import replace
    return replace(scene, **changes)


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


def physics_warnings(scene: Scene) -> list[str]:
    """Legal but suspicious physics, each explained (also used for ``Scene.warnings``)."""
    out = []
    src = scene.source or scene.name
    nyq = scene.max_beat_hz
    kind = "complex (I/Q) sampling rate" if scene.iq else "real (I-only) Nyquist rate fs/2"
    for i, t in enumerate(scene.targets):
        fb = scene.beat_hz(t)
        if fb < 0 or fb >= nyq:
            folded = fold_beat_hz(scene, fb)
            r_fold = folded * C_MPS / (2 * scene.slope_hz_per_s)
            f_range = scene.slope_hz_per_s * 2 * t.range_m / C_MPS
            r_range = fold_beat_hz(scene, f_range) * C_MPS / (2 * scene.slope_hz_per_s)
            out.append(f"{src}: targets[{i}].range_m: {t.range_m:g} m beats at {fb / 1e6:.2f} MHz "
                       f"({f_range / 1e6:.2f} MHz from range alone), beyond the {nyq / 1e6:g} MHz {kind} "
                       f"(max range {scene.max_range_m:.3g} m): it folds to {folded / 1e6:.2f} MHz and "
                       f"appears at about {r_fold:.2f} m ({r_range:.2f} m without Doppler)")
        tau = 2 * t.range_m / C_MPS
        if tau > scene.t_adc_start_s + 0.5 * scene.n_samples / scene.fs_hz:
            out.append(f"{src}: targets[{i}].range_m: round trip {tau * 1e6:.3g} us is more than half "
                       f"the sampling window: most samples hold no echo of this chirp")
        rr = scene.range_rate_mps(t)
        vmax = scene.max_velocity_mps
        if abs(rr) > vmax:
            folded_v = (rr + vmax) % (2 * vmax) - vmax
            out.append(f"{src}: targets[{i}].velocity_mps: range rate {rr:.3g} m/s ({rr * 3.6:.0f} km/h) is "
                       f"beyond the unambiguous +-{vmax:.3g} m/s (lambda / 4 t_chirp, t_chirp = "
                       f"{scene.t_chirp_s * 1e6:g} us): the Doppler FFT shows {folded_v:.3g} m/s")
    from carav_stream.radar.attackers import make_attacker
    for i, spec in enumerate(scene.attackers):
        attacker = make_attacker(spec.kind, scene, **spec.kwargs())
        out.extend(f"{src}: attackers[{i}]: {w}" for w in attacker.physics_warnings())
        peak = attacker.peak_amplitude()
        if scene.adc_bits and peak > scene.adc_full_scale:
            out.append(f"{src}: attackers[{i}]: expected peak {peak:.3g} exceeds the ADC full scale "
                       f"{scene.adc_full_scale:.3g} ({peak / scene.adc_full_scale:.1f}x): the ADC "
                       f"will clip (counted per cycle in 'clipped')")
    return out


def fold_beat_hz(scene: Scene, beat_hz: float) -> float:
    """Where a beat frequency lands after sampling: mod fs (complex), folded into [0, fs/2] (real)."""
    f = beat_hz % scene.fs_hz
    if not scene.iq and f > scene.fs_hz / 2:
        f = scene.fs_hz - f
    return f


class _Checker:
    def __init__(self, source: str, problems: list[str]):
        self.source, self.problems = source, problems

    def fail(self, where: str, msg: str) -> None:
        self.problems.append(f"{self.source}: {where}: {msg}")

    def typed(self, where: str, value: Any, typ: type) -> Any:
        if typ is float and isinstance(value, (int, float)) and not isinstance(value, bool):
            if not math.isfinite(value):
                self.fail(where, f"must be finite, got {value}")
                return None
            return float(value)
        if typ is int and isinstance(value, int) and not isinstance(value, bool):
            return value
        if typ is bool and isinstance(value, bool):
            return value
        if typ in (str, list) and isinstance(value, typ):
            return value
        want = {float: "a number", int: "an integer", bool: "true or false", str: "a string", list: "a list"}[typ]
        self.fail(where, f"must be {want}, got {value!r}")
        return None

    def positive(self, where: str, value: Any) -> None:
        if value is not None and value <= 0:
            self.fail(where, f"must be > 0, got {value:g}")


def _suggest(key: str, known) -> str:
    close = difflib.get_close_matches(key, list(known), n=1)
    return f" (did you mean {close[0]!r}?)" if close else f" (known: {', '.join(sorted(known))})"


def _list(p: _Checker, d: dict, key: str) -> list:
    value = d.get(key, [])
    if not isinstance(value, list) or not all(isinstance(x, dict) for x in value):
        p.fail(key, f"must be a list of tables ([[{key}]]), got {value!r}")
        return []
    return value


def _target(p: _Checker, i: int, t: dict) -> Target | None:
    where = f"targets[{i}]"
    for key in t:
        if key not in _TARGET_KEYS:
            p.fail(f"{where}.{key}", f"unknown key{_suggest(key, _TARGET_KEYS)}")
    v = {k: p.typed(f"{where}.{k}", t[k], typ) for k, typ in _TARGET_KEYS.items() if k in t}
    if "range_m" not in t:
        p.fail(f"{where}.range_m", "missing (required)")
    if "velocity_mps" in t and "velocity_kmh" in t:
        p.fail(f"{where}.velocity_kmh", "give velocity_mps or velocity_kmh, not both")
    for k in ("range_m", "rcs_m2"):
        if v.get(k) is not None:
            p.positive(f"{where}.{k}", v[k])
    sw = v.get("swerling", 0)
    if sw is not None and sw not in (0, 1, 2, 3, 4):
        p.fail(f"{where}.swerling", f"must be 0, 1, 2, 3 or 4, got {sw}")
    if any(v.get(k) is None for k in t if k in _TARGET_KEYS) or "range_m" not in t:
        return None
    velocity = v["velocity_kmh"] * KMH if "velocity_kmh" in v else v.get("velocity_mps", 0.0)
    return Target(range_m=v["range_m"], velocity_mps=velocity, rcs_m2=v.get("rcs_m2", 1.0), swerling=sw)


def _attacker_spec(p: _Checker, i: int, a: dict, scene: Scene) -> AttackerSpec | None:
    from carav_stream.radar.attackers import AttackerError, make_attacker
    where = f"attackers[{i}]"
    kind = a.get("kind")
    params = {k: val for k, val in a.items() if k != "kind"}
    if not isinstance(kind, str):
        p.fail(f"{where}.kind", f"missing or not a string, got {kind!r}")
        return None
    try:
        make_attacker(kind, scene, **params)
    except AttackerError as exc:
        for problem in exc.problems:
            p.fail(f"{where}.{problem[0]}" if problem[0] else where, problem[1])
        return None
    frozen = {k: tuple(val) if isinstance(val, list) else val for k, val in params.items()}
    return AttackerSpec(kind, tuple(sorted(frozen.items())))
