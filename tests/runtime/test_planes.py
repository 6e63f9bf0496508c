"""The data planes' registry and seam: planes are found as modules (the built-in ones, then CARAV_PLANE_PATH's
folders), refused by name when unknown or malformed, and the plan gives a plane's resources to the ports whose
edges stay on the host, and to nothing else."""
from pathlib import Path

import pytest

from carav_stream.runtime import planes
from carav_stream.runtime.loader import load_graph
from carav_stream.runtime.plan import plan_specs
from carav_stream.runtime.planes.shm import ShmPlane

ROOT = Path(__file__).resolve().parents[2]
PLANE_FILE = '''
from carav_stream.runtime.planes import Plane


class {name}(Plane):
    pass
'''


def test_the_default_plane_comes_first_and_a_folder_of_the_plane_path_adds_its_modules(tmp_path, monkeypatch):
    monkeypatch.delenv(planes.PATH_ENV, raising=False)
    assert planes.names() == ("zmq", "shm")
    (tmp_path / "aaa.py").write_text(PLANE_FILE.format(name="Aaa"))
    (tmp_path / "shm.py").write_text(PLANE_FILE.format(name="NotTheSharedMemoryPlane"))
    (tmp_path / "_private.py").write_text("")
    monkeypatch.setenv(planes.PATH_ENV, str(tmp_path))
    assert planes.names() == ("zmq", "shm", "aaa")
    aaa = planes.get("aaa")
    assert aaa.__name__ == "Aaa" and aaa.name == "aaa"
    assert planes.get("shm") is ShmPlane and ShmPlane.name == "shm"     # a folder's module named like it: unused


def test_an_unknown_plane_and_a_module_without_one_plane_are_refused_naming_them(tmp_path, monkeypatch):
    monkeypatch.setenv(planes.PATH_ENV, str(tmp_path))
    (tmp_path / "empty.py").write_text("X = 1\n")
    (tmp_path / "broken.py").write_text("raise RuntimeError('no disk')\n")
    with pytest.raises(planes.PlaneError, match="unknown data plane 'nope'; known planes: zmq, shm, broken, empty"):
        planes.get("nope")
    with pytest.raises(planes.PlaneError, match=r"empty.py: a plane module must define exactly one Plane subclass"):
        planes.get("empty")
    with pytest.raises(planes.PlaneError, match=r"broken.py: plane module failed to import: RuntimeError: no disk"):
        planes.get("broken")


def test_a_graph_naming_an_unknown_plane_is_refused_with_the_planes_it_may_name():
    with pytest.raises(ValueError, match=r"run.transport: must be one of \['zmq', 'shm'\], got 'nope'"):
        load_graph(ROOT / "graphs" / "demo.toml", ["run.transport=nope"])


class Recording(planes.Plane):
    """Gives every port it is asked about resources naming it, and one file descriptor."""

    def __init__(self) -> None:
        super().__init__({}, Path("."))
        self.asked: list[tuple[str, list[str]]] = []

    def open_port(self, port, edges):
        self.asked.append((port, edges))
        return planes.PortResources(f"w:{port}", [f"r:{e}" for e in edges], (100 + len(self.asked),))


def test_the_plan_asks_the_plane_about_ports_whose_edges_stay_on_the_host_and_hands_out_what_it_gave():
    graph = load_graph(ROOT / "graphs" / "two_hosts.toml")      # source, channel, attacker, adc on "front"
    plane = Recording()
    specs = plan_specs(graph, "front", Path("/tmp/x"), 0, plane)
    # source.rho and adc.frames feed nodes on "back": they stay inline, the plane is not asked
    assert [port for port, _ in plane.asked] == ["source.tx", "channel.rx", "channel.air", "attacker.attack"]
    assert plane.asked[0][1] == ["source.tx -> channel.tx"]
    assert specs["source"].plane_out == {"tx": "w:source.tx"} and specs["source"].inherit_fds == [101]
    assert specs["channel"].plane_in == {"tx": "r:source.tx -> channel.tx"}
    assert specs["channel"].inherit_fds == [101, 102, 103]          # its input's and its two outputs'
    assert specs["adc"].plane_out == {} and specs["adc"].plane_in.keys() == {"rx", "attack"}
