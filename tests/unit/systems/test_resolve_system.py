"""resolve_system: example names, model files, PATH.py:FUNCTION and module:FUNCTION, and their errors.

Every error is a ModelError whose message names the file (or module) and the entry at fault.
The systems built from files are checked against numbers computed by hand.
"""

import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import hybobs_opt
from hybobs_opt.errors import ModelError
from hybobs_opt.systems import PWASystem
from hybobs_opt.systems.model_file import save_model
from hybobs_opt.systems.resolve import resolve_system

BUILDER = textwrap.dedent("""
    import numpy as np
    from hybobs_opt.systems import Polytope, PWAMode, PWASystem

    CALLS = []

    def build(gain=0.5, bound=2.0):
        CALLS.append((gain, bound))
        mode = PWAMode(gain * np.eye(1), np.zeros((1, 0)), np.array([1.0]), np.array([[2.0]]),
                       Polytope(np.zeros((0, 1)), np.zeros(0)), name="only")
        return PWASystem((mode,), Polytope.from_box([-bound], [bound]), None, ("x",), (), ("y",), name="scalar")

    def gap():
        X = Polytope.from_box([-1.0], [1.0])
        modes = tuple(PWAMode(np.eye(1), np.zeros((1, 0)), np.zeros(1), np.eye(1), Polytope(A, b))
                      for A, b in ((np.array([[1.0]]), np.array([-0.5])), (np.array([[-1.0]]), np.array([-0.5]))))
        return PWASystem(modes, X, None, ("x",))

    def broken():
        raise RuntimeError("the plant data are missing")

    def not_a_system():
        return {"class": "pwa"}

    def nothing():
        return None

    def type_error_inside():
        return len(5)

    NOT_CALLABLE = 3
""")


@pytest.fixture
def builder_file(tmp_path):
    path = tmp_path / "my_plant.py"
    path.write_text(BUILDER)
    return path


def test_path_function_with_params(builder_file):
    s = resolve_system(f"{builder_file}:build", {"gain": 0.25, "bound": 4.0})
    assert isinstance(s, PWASystem) and s.name == "scalar"
    np.testing.assert_array_equal(s.state_bounds.b, [4.0, 4.0])
    assert s.step([2.0])[0] == 0.25 * 2.0 + 1.0   # by hand: x+ = 0.25 x + 1
    assert s.output([2.0])[0] == 4.0
    default = resolve_system(f"{builder_file}:build")
    assert default.step([2.0])[0] == 2.0           # 0.5 * 2 + 1


def test_module_function(tmp_path, monkeypatch):
    package = tmp_path / "plantpkg_for_resolve_test"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "plants.py").write_text(BUILDER)
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        s = resolve_system("plantpkg_for_resolve_test.plants:build", {"gain": 2.0})
        assert s.step([1.5])[0] == 2.0 * 1.5 + 1.0
        with pytest.raises(ModelError) as info:
            resolve_system("plantpkg_for_resolve_test.plants:absent")
        assert str(info.value).startswith("plantpkg_for_resolve_test.plants:absent: expected a function")
        assert "build" in str(info.value)  # lists what is there
    finally:
        for name in [k for k in sys.modules if k.startswith("plantpkg_for_resolve_test")]:
            del sys.modules[name]


def test_module_function_of_the_toolbox():
    s = resolve_system("hybobs_opt.studies.paper002_powertrain.systems:powertrain3")
    assert isinstance(s, PWASystem) and s.n == 3


def test_example_name_with_params():
    s = resolve_system("powertrain3")
    assert s.to_dict() == hybobs_opt.get_example("powertrain3").build().to_dict()
    other = resolve_system("powertrain3", {"gear_ratio": 0.1})
    assert other.to_dict() != s.to_dict()


@pytest.mark.parametrize("fmt", ["json", "toml", "yaml"])
def test_model_file(tmp_path, builder_file, fmt):
    original = resolve_system(f"{builder_file}:build", {"gain": 0.125})
    path = save_model(original, tmp_path / f"plant.{fmt}")
    s = resolve_system(str(path))
    assert s.to_dict() == original.to_dict()
    assert s.step([1.0])[0] == 1.125


# ---------------------------------------------------------------------------------- errors

def raises(name, params=None) -> str:
    with pytest.raises(ModelError) as info:
        resolve_system(name, params)
    return str(info.value)


def test_params_given_to_a_model_file(tmp_path, builder_file):
    path = save_model(resolve_system(f"{builder_file}:build"), tmp_path / "plant.toml")
    message = raises(str(path), {"gain": 1.0})
    assert message.startswith(f"{path}: params: expected no parameters") and "gain" in message


def test_missing_model_file(tmp_path):
    path = tmp_path / "absent.yaml"
    assert raises(str(path)).startswith(f"{path}: expected a readable model file")


def test_unknown_python_file(tmp_path):
    path = tmp_path / "nowhere" / "plant.py"
    message = raises(f"{path}:build")
    assert message.startswith(f"{path}:build: expected an existing Python file")


def test_a_file_that_is_not_python(tmp_path):
    path = tmp_path / "plant.txt"
    path.write_text("x = 1")
    assert raises(f"{path}:build").startswith(f"{path}:build: expected PATH.py:FUNCTION")


def test_a_file_that_raises_on_import(tmp_path):
    path = tmp_path / "raising.py"
    path.write_text("import math\nraise ImportError('no module named plantdata')\n")
    message = raises(f"{path}:build")
    assert message.startswith(f"{path}: expected a Python file that imports without error")
    assert "ImportError: no module named plantdata" in message
    path.write_text("def build(:\n")
    assert "SyntaxError" in raises(f"{path}:build")


def test_a_function_that_raises(builder_file):
    message = raises(f"{builder_file}:broken")
    assert message.startswith(f"{builder_file}:broken: expected a function that builds a system")
    assert "RuntimeError: the plant data are missing" in message


def test_a_model_error_of_the_builder_names_its_entry(builder_file):
    message = raises(f"{builder_file}:gap")
    assert message.startswith(f"{builder_file}:gap: modes[*].guard: expected")
    assert "gap" in message


@pytest.mark.parametrize("function, got", [("not_a_system", "a dict"), ("nothing", "a NoneType")])
def test_a_function_that_returns_the_wrong_type(builder_file, function, got):
    message = raises(f"{builder_file}:{function}")
    assert message.startswith(f"{builder_file}:{function}: expected a function returning a PWASystem")
    assert message.endswith(got)


def test_an_unknown_function_name(builder_file):
    message = raises(f"{builder_file}:bulid")
    assert message.startswith(f"{builder_file}:bulid: expected a function defined there")
    assert "build" in message and "broken" in message


def test_a_name_that_is_not_callable(builder_file):
    message = raises(f"{builder_file}:NOT_CALLABLE")
    assert message.startswith(f"{builder_file}:NOT_CALLABLE: expected a function returning a system")


def test_params_the_function_does_not_take(builder_file):
    message = raises(f"{builder_file}:build", {"gian": 1.0})
    assert message.startswith(f"{builder_file}:build: params: expected parameters the function accepts")
    assert "gian" in message


def test_a_type_error_inside_the_builder_is_not_blamed_on_params(builder_file):
    message = raises(f"{builder_file}:type_error_inside")
    assert "params" not in message
    assert "TypeError" in message


def test_an_unknown_module():
    message = raises("no_such_module_for_hybobs_tests.sub:build")
    assert message.startswith("no_such_module_for_hybobs_tests.sub:build: expected an importable 'module:FUNCTION'")
    assert "ModuleNotFoundError" in message


@pytest.mark.parametrize("name", ["", "   ", None, 3])
def test_not_a_name(name):
    with pytest.raises(ModelError) as info:
        resolve_system(name)
    assert info.value.field == "system name"


@pytest.mark.parametrize("name", ["no_such_example", "plant.py", "dir/plant", "module:"])
def test_a_name_of_no_form(name):
    with pytest.raises(ModelError) as info:
        resolve_system(name)
    assert info.value.field == "system name" and repr(name) in str(info.value)


ROTATION_BUILDER = str(Path(__file__).resolve().parents[3] / "examples" / "builders" / "bemporad_morari_rotation.py") + ":build"


def test_text_of_a_vector_parameter_is_read_as_that_many_numbers():
    """``output_row=(0.0, 1.0)`` declares a 2-vector: ``"1,0"`` (what ``--param output_row=1,0`` passes) measures x1."""
    system = resolve_system(ROTATION_BUILDER, {"output_row": "1,0"})
    assert [mode.C.tolist() for mode in system.modes] == [[[1.0, 0.0]], [[1.0, 0.0]]]
    assert resolve_system(ROTATION_BUILDER, {"output_row": (1.0, 0.0)}).to_dict() == system.to_dict()


@pytest.mark.parametrize("text", ["1,0,3", "1", "a,b", "1,nan", ""])
def test_a_vector_parameter_of_the_wrong_length_or_not_numbers_is_refused(text):
    with pytest.raises(ModelError) as info:
        resolve_system(ROTATION_BUILDER, {"output_row": text})
    assert info.value.field.endswith("params output_row")
    assert "2 comma-separated finite numbers" in info.value.expected and repr(text) in str(info.value)
