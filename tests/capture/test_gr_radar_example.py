"""examples/gnuradio/gr_radar_to_carav.grc is the radar of its scene, examples/gnuradio/gr_radar_fmcw.toml, and of
graphs/gr_radar.toml: its variables, evaluated as GNU Radio Companion would, give the scene's chirp, ADC window,
carrier, target and noise, the echo the scene's radar equation gives, and the graph's activation pattern. Runs
without GNU Radio (the flowgraph itself runs in tests/integration/test_gnuradio.py)."""
import math
from pathlib import Path

import pytest
import yaml

from carav_stream.radar.scene_loader import load_scene
from carav_stream.runtime.loader import load_graph

ROOT = Path(__file__).resolve().parents[2]
GRC = ROOT / "examples" / "gnuradio" / "gr_radar_to_carav.grc"
SCENE = ROOT / "examples" / "gnuradio" / "gr_radar_fmcw.toml"
GR_RADAR_C_MPS = 3e8                       # gr-radar's speed of light (its static target simulator's c_light)


def grc_values(path: Path) -> dict:
    """The flowgraph's variables and its numeric parameters (their defaults), each evaluated in terms of the others
    with `math` imported, as the Python that grcc generates does."""
    blocks = yaml.safe_load(path.read_text())["blocks"]
    pending = {b["name"]: str(b["parameters"]["value"]) for b in blocks
               if b["id"] == "variable" or b["id"] == "parameter" and b["parameters"]["type"] != "str"}
    space: dict = {"math": math}
    while pending:
        solved = []
        for name, text in pending.items():
            try:
                space[name] = eval(text, dict(space))          # noqa: S307 - the project's own example file
            except NameError:
                continue
            solved.append(name)
        if not solved:
            raise AssertionError(f"{path.name}: cannot evaluate {sorted(pending)}")
        for name in solved:
            del pending[name]
    return space


@pytest.fixture(scope="module")
def grc():
    return grc_values(GRC)


def test_the_flowgraph_s_chirp_and_adc_window_are_the_scene_s(grc):
    scene = load_scene(str(SCENE))
    assert grc["samp_rate"] == scene.fs_hz and grc["sweep_hz"] == scene.bandwidth_hz
    assert grc["samp_up"] / grc["samp_rate"] == pytest.approx(scene.t_sweep_s, rel=1e-12)
    assert scene.t_chirp_s == scene.t_sweep_s                          # gr-radar's chirps follow without a gap
    assert grc["adc_skip"] / grc["samp_rate"] == pytest.approx(scene.t_adc_start_s, rel=1e-12)
    assert (grc["n_samples"], grc["n_chirps"]) == (scene.n_samples, scene.n_chirps) and scene.iq
    assert grc["fc_hz"] == scene.fc_hz


def test_the_flowgraph_s_car_echo_and_noise_are_the_scene_s(grc):
    scene = load_scene(str(SCENE))
    car = scene.targets[0]
    assert (grc["range_m"], grc["rcs_m2"], car.velocity_mps, scene.radar_speed_mps) == (car.range_m, car.rcs_m2, 0, 0)
    assert 2 * car.range_m / GR_RADAR_C_MPS * grc["samp_rate"] <= grc["adc_skip"]   # the wrapped ramp is dropped
    # gr-radar's echo amplitude, c sqrt(rcs) / ((4 pi)^1.5 R^2 fc) of the ramp's, times rf_gain: carav's radar
    # equation (its c, not gr-radar's 3e8 m/s)
    echo = grc["rf_gain"] * GR_RADAR_C_MPS * math.sqrt(car.rcs_m2) / ((4 * math.pi) ** 1.5 * car.range_m ** 2
                                                                      * grc["fc_hz"])
    assert echo == pytest.approx(math.sqrt(scene.echo_power_w(car)), rel=2e-3)
    assert grc["sigma_n"] == pytest.approx(scene.sigma_n, rel=1e-12)


def test_the_flowgraph_s_pattern_is_the_graph_s():
    graph = load_graph(ROOT / "graphs" / "gr_radar.toml")
    assert graph.params["scene"] == str(SCENE)
    pattern = graph.nodes["source"].params["pattern"]
    assert grc_values(GRC)["pattern"] == [int(d) for d in pattern] and len(pattern) == load_scene(str(SCENE)).n_chirps
