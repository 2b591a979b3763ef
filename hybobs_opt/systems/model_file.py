"""Model files: a system written as JSON, TOML or YAML (the dictionary of :mod:`.model_dict`).

The format is documented by the JSON Schema shipped beside this module
(``hybobs_opt/systems/model.schema.json``, :func:`model_schema`); ``hybobs model schema`` prints it.
JSON and TOML need nothing beyond the standard library to read; writing TOML needs ``tomli-w`` and
YAML needs ``PyYAML`` (the ``models`` extra: ``pip install 'hybobs_opt[models]'``).

Every error names the file and the entry: ``mysys.toml: modes[1].guard.A: expected a matrix of
shape (any, 3), got shape (2, 4)``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ..errors import ModelError
from .._output_files import write_output_text

#: File suffixes read as model files, and their format.
MODEL_SUFFIXES: dict[str, str] = {".json": "json", ".toml": "toml", ".yaml": "yaml", ".yml": "yaml"}

SCHEMA_PATH = Path(__file__).with_name("model.schema.json")


def is_model_path(text: str) -> bool:
    """True when ``text`` ends with a model-file suffix (whether or not the file exists)."""
    return Path(text).suffix.lower() in MODEL_SUFFIXES


def _load_yaml(yaml, text: str, where: str):
    """``yaml.safe_load`` that refuses more than :data:`~hybobs_opt.limits.MAX_YAML_ALIASES`
    aliases, counted as the parser meets them (before any is expanded)."""
    from ..limits import MAX_YAML_ALIASES

    class Loader(yaml.SafeLoader):
        aliases = 0

        def compose_node(self, parent, index):
            if self.check_event(yaml.AliasEvent):
                Loader.aliases += 1
                if Loader.aliases > MAX_YAML_ALIASES:
                    raise ModelError(where, f"a YAML file with at most {MAX_YAML_ALIASES} aliases "
                                     "(hybobs_opt.limits.MAX_YAML_ALIASES; a model needs few)",
                                     f"more than {MAX_YAML_ALIASES}")
            return super().compose_node(parent, index)

    loader = Loader(text)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()


def read_model_dict(path: str | Path) -> dict[str, Any]:
    """The raw dictionary in a model file (no system built).

    Parameters
    ----------
    path : str or Path
        Model file ending in ``.json``, ``.toml``, ``.yaml`` or ``.yml``.

    Returns
    -------
    dict
        The file's content as written (JSON, TOML or YAML by the suffix).

    Raises
    ------
    ModelError
        On an unknown suffix, an unreadable or non-UTF-8 file, a parse error, or a top level that is
        not a mapping.

    See Also
    --------
    load_model : builds the system.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.geometry import Polytope
    >>> from hybobs_opt.systems import PWAMode, PWASystem
    >>> left = PWAMode(A=np.array([[0.5]]), B=np.array([[1.0]]), a=np.zeros(1), C=np.array([[1.0]]),
    ...                guard=Polytope(np.array([[1.0, 0.0]]), np.array([0.0])), name="left")    # x <= 0
    >>> right = PWAMode(A=np.array([[0.9]]), B=np.array([[1.0]]), a=np.zeros(1), C=np.array([[2.0]]),
    ...                 guard=Polytope(np.array([[-1.0, 0.0]]), np.array([0.0])), name="right")  # x >= 0
    >>> system = PWASystem((left, right), Polytope.from_box([-2.0], [2.0]), Polytope.from_box([-1.0], [1.0]),
    ...                    state_names=("x",), input_names=("u",), output_names=("y",))
    >>> import tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt.systems import read_model_dict, save_model
    >>> raw = read_model_dict(save_model(system, Path(tempfile.mkdtemp()) / "two_modes.json"))
    >>> raw["format"], raw["class"], raw["states"]
    ('hybobs-model', 'pwa', ['x'])
    """
    path = Path(path)
    kind = MODEL_SUFFIXES.get(path.suffix.lower())
    if kind is None:
        raise ModelError(str(path), f"a model file ending in {', '.join(MODEL_SUFFIXES)}", repr(path.suffix))
    from ..limits import MAX_MODEL_FILE_BYTES

    try:
        size = path.stat().st_size
        if size > MAX_MODEL_FILE_BYTES:
            raise ModelError(str(path), f"a model file of at most {MAX_MODEL_FILE_BYTES:,} bytes "
                             "(hybobs_opt.limits.MAX_MODEL_FILE_BYTES)", f"{size:,} bytes")
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ModelError(str(path), "a readable model file", f"{type(exc).__name__}: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:  # a binary file, or text in another encoding
        raise ModelError(str(path), f"a {kind.upper()} text file in UTF-8",
                         f"undecodable byte 0x{exc.object[exc.start]:02x} at offset {exc.start} (a binary file?)") from None
    try:
        if kind == "json":
            data = json.loads(text)
        elif kind == "toml":
            import tomllib

            data = tomllib.loads(text)
        else:
            yaml = _optional("yaml", "PyYAML", "read YAML model files")
            data = _load_yaml(yaml, text, str(path))
    except ModelError:
        raise
    except Exception as exc:  # json/tomllib/yaml each raise their own parse errors
        raise ModelError(str(path), f"a well-formed {kind.upper()} file", f"{type(exc).__name__}: {exc}") from None
    if not isinstance(data, dict):
        raise ModelError(str(path), "a mapping at the top level (the model's entries)", type(data).__name__)
    return data


def load_model(path: str | Path):
    """Build the system written in a model file.

    Parameters
    ----------
    path : str or Path
        Model file ending in ``.json``, ``.toml``, ``.yaml`` or ``.yml``.

    Returns
    -------
    PWASystem, HybridAutomaton, ConstantDriftSystem or ScalarNonlinearSystem
        The system the file describes (its ``class`` field), validated.

    Raises
    ------
    ModelError
        The file is missing, malformed, or an entry is wrong; the message starts with the path and
        names the entry (``modes[1].guard``, ``locations[0].flow[2]``, ...).

    See Also
    --------
    save_model : writes one.
    read_model_dict : the file's dictionary without building.
    resolve_system : a model file, an example or a function by name.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.geometry import Polytope
    >>> from hybobs_opt.systems import PWAMode, PWASystem
    >>> left = PWAMode(A=np.array([[0.5]]), B=np.array([[1.0]]), a=np.zeros(1), C=np.array([[1.0]]),
    ...                guard=Polytope(np.array([[1.0, 0.0]]), np.array([0.0])), name="left")    # x <= 0
    >>> right = PWAMode(A=np.array([[0.9]]), B=np.array([[1.0]]), a=np.zeros(1), C=np.array([[2.0]]),
    ...                 guard=Polytope(np.array([[-1.0, 0.0]]), np.array([0.0])), name="right")  # x >= 0
    >>> system = PWASystem((left, right), Polytope.from_box([-2.0], [2.0]), Polytope.from_box([-1.0], [1.0]),
    ...                    state_names=("x",), input_names=("u",), output_names=("y",))
    >>> import tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt.systems import load_model, save_model
    >>> path = save_model(system, Path(tempfile.mkdtemp()) / "two_modes.json")
    >>> load_model(path)
    PWASystem(name='pwa', n=1, m=1, p=1, modes=2)
    """
    from .model_dict import system_from_dict

    data = read_model_dict(path)
    try:
        return system_from_dict(data)
    except ModelError as exc:
        raise ModelError(f"{path}: {exc.field}", exc.expected, exc.got) from None


def save_model(system, path: str | Path) -> Path:
    """Write ``system`` as a model file; the format follows the suffix (``.json``, ``.toml``, ``.yaml``).

    Parameters
    ----------
    system : PWASystem, HybridAutomaton, ConstantDriftSystem or ScalarNonlinearSystem
        The system to write (through its ``to_dict()``).
    path : str or Path
        Target file; its suffix picks the format (TOML and YAML need the ``models`` extra).

    Returns
    -------
    Path
        ``path``.

    See Also
    --------
    load_model : reads it back.
    model_schema : the format.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.geometry import Polytope
    >>> from hybobs_opt.systems import PWAMode, PWASystem
    >>> left = PWAMode(A=np.array([[0.5]]), B=np.array([[1.0]]), a=np.zeros(1), C=np.array([[1.0]]),
    ...                guard=Polytope(np.array([[1.0, 0.0]]), np.array([0.0])), name="left")    # x <= 0
    >>> right = PWAMode(A=np.array([[0.9]]), B=np.array([[1.0]]), a=np.zeros(1), C=np.array([[2.0]]),
    ...                 guard=Polytope(np.array([[-1.0, 0.0]]), np.array([0.0])), name="right")  # x >= 0
    >>> system = PWASystem((left, right), Polytope.from_box([-2.0], [2.0]), Polytope.from_box([-1.0], [1.0]),
    ...                    state_names=("x",), input_names=("u",), output_names=("y",))
    >>> import tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt.systems import load_model, save_model, system_fingerprint
    >>> path = save_model(system, Path(tempfile.mkdtemp()) / "two_modes.json")
    >>> system_fingerprint(load_model(path)) == system_fingerprint(system)
    True
    """
    path = Path(path)
    kind = MODEL_SUFFIXES.get(path.suffix.lower())
    if kind is None:
        raise ModelError("path", f"a file name ending in {', '.join(MODEL_SUFFIXES)}", repr(str(path)))
    data = system.to_dict()
    if kind == "json":
        text = json.dumps(data, indent=1)
    elif kind == "toml":
        text = _optional("tomli_w", "tomli-w", "write TOML model files").dumps(data)
    else:
        text = _optional("yaml", "PyYAML", "write YAML model files").safe_dump(data, sort_keys=False)
    write_output_text(path, text)
    return path


def model_schema() -> dict[str, Any]:
    """The JSON Schema of model files (draft 2020-12).

    Returns
    -------
    dict
        The schema (``hybobs model schema`` prints it; ``docs/model_schema`` renders it).

    See Also
    --------
    load_model : reads files of this format.

    Examples
    --------
    >>> from hybobs_opt.systems import model_schema
    >>> schema = model_schema()
    >>> schema["title"], schema["$schema"]
    ('hybobs_opt model file', 'https://json-schema.org/draft/2020-12/schema')
    """
    return json.loads(SCHEMA_PATH.read_text())


def _optional(module: str, package: str, what: str):
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise ModelError(package, f"installed to {what} (pip install 'hybobs_opt[models]')", "not installed") from None
