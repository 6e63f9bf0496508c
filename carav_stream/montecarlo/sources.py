"""Cycle sources from a plain description: what `carav sweep`'s options and a study's [[scenes]] entry say."""
from __future__ import annotations

from carav_stream.montecarlo.array_source import ArraySource
from carav_stream.montecarlo.engine import PaperSource
from carav_stream.montecarlo.paper_model import paper_scene
from carav_stream.montecarlo.radar_source import RadarSource
from carav_stream.radar.scene_loader import load_scene

__all__ = ["source_from_spec"]


def source_from_spec(spec: dict):
    """The cycle source of a plain description (what `carav sweep` options and a study's [[scenes]] entry say):
    model radar | paper, preset or scene file, nr, ns, iq, snr_db, ideal_adc, activation, fidelity,
    attack_params, receivers (default the scene's own count, `getattr(scene, "n_rx", 1)`: the paper model on more
    than one is `ArraySource`; the radar model renders the scene's own receivers only)."""
    preset = spec.get("preset") or ("table1" if spec.get("scene") is None else None)
    receivers = spec.get("receivers")
    if spec.get("model", "radar") == "paper":
        scene = paper_scene(preset.split("_")[0], n_chirps=spec.get("nr"), n_samples=spec.get("ns"),
                            iq=bool(spec.get("iq")), snr_db=spec.get("snr_db") or 0.0)
        n_rx = getattr(load_scene(preset), "n_rx", 1) if receivers is None else receivers
        return PaperSource(scene) if n_rx == 1 else ArraySource(scene, n_rx)
    overrides = {}
    for key, name in (("nr", "n_chirps"), ("ns", "n_samples"), ("snr_db", "snr_db")):
        if spec.get(key) is not None:
            overrides[name] = spec[key]
    if spec.get("iq"):
        overrides["iq"] = True
    if spec.get("ideal_adc"):
        overrides["adc_bits"] = 0
    scene = load_scene(spec.get("scene") or preset, overrides or None)
    own = getattr(scene, "n_rx", 1)
    if receivers is not None and receivers != own:
        raise ValueError(f"receivers: scene {scene.name} has {own} receiver{'s' * (own != 1)} and the radar model "
                         f"renders the scene's own, not {receivers} (the paper model takes any count)")
    return RadarSource(scene, attack_params=spec.get("attack_params") or {},
                       activation=spec.get("activation") or "seeded", fidelity=spec.get("fidelity") or "auto")
