"""The estimation methods are the files of their package: one Method subclass a file, named after it, in order."""
import textwrap
from pathlib import Path

import pytest

from carav_stream.estimate import estimators
from carav_stream.estimate.estimators import METHODS, REGISTRY
from carav_stream.estimate.estimators._registry import discover

PACKAGE_DIR = Path(estimators.__file__).parent


def test_every_method_file_of_the_package_is_a_method_named_after_it():
    files = {p.stem for p in PACKAGE_DIR.glob("*.py") if not p.stem.startswith("_")}
    assert set(METHODS) == files
    assert all(REGISTRY[name].name == name and type(REGISTRY[name]).__module__.endswith(f".{name}")
               for name in METHODS)


def test_methods_keep_their_declared_order():
    assert [REGISTRY[m].order for m in METHODS] == sorted(REGISTRY[m].order for m in METHODS)
    assert METHODS[0] == "fft_peak" and METHODS[-1] == "ml"


def _package(tmp_path, monkeypatch, name: str, files: dict[str, str]) -> Path:
    folder = tmp_path / name
    folder.mkdir()
    (folder / "__init__.py").write_text("")
    for stem, text in files.items():
        (folder / f"{stem}.py").write_text(textwrap.dedent(text))
    monkeypatch.syspath_prepend(str(tmp_path))
    return folder


def test_a_new_method_file_is_registered_in_its_order_and_helpers_are_not(tmp_path, monkeypatch):
    method = """
        from carav_stream.estimate.estimators import Method

        class M(Method):
            order = {order}
            range_words = velocity_words = "a test's"
    """
    folder = _package(tmp_path, monkeypatch, "methods_new_file", {
        "_helpers": "X = 1\n", "alpha": method.format(order=2), "beta": method.format(order=1),
        "gamma": method.format(order=1)})
    found = discover(folder, "methods_new_file")
    assert list(found) == ["beta", "gamma", "alpha"]
    assert found["alpha"].start_pad == 8 and found["alpha"].refine is None


def test_a_method_file_without_exactly_one_method_class_is_refused_naming_the_file(tmp_path, monkeypatch):
    folder = _package(tmp_path, monkeypatch, "methods_two_classes", {"twice": """
        from carav_stream.estimate.estimators import Method

        class A(Method):
            order = 1
            range_words = velocity_words = "a test's"

        class B(Method):
            order = 2
            range_words = velocity_words = "a test's"
    """})
    with pytest.raises(ImportError, match=r"twice\.py.*one Method subclass.*\['A', 'B'\]"):
        discover(folder, "methods_two_classes")


def test_a_method_without_an_order_is_refused_naming_its_class(tmp_path, monkeypatch):
    folder = _package(tmp_path, monkeypatch, "methods_no_order", {"loose": """
        from carav_stream.estimate.estimators import Method

        class Loose(Method):
            start_pad = 2
    """})
    with pytest.raises(ImportError, match=r"loose\.py: Loose sets no integer `order`"):
        discover(folder, "methods_no_order")


def test_a_method_that_does_not_say_how_it_reads_range_and_velocity_is_refused(tmp_path, monkeypatch):
    folder = _package(tmp_path, monkeypatch, "methods_no_words", {"mute": """
        from carav_stream.estimate.estimators import Method

        class Mute(Method):
            order = 1
            range_words = "the grid"
    """})
    with pytest.raises(ImportError, match=r"mute\.py: Mute sets no velocity_words"):
        discover(folder, "methods_no_words")
