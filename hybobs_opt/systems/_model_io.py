"""``to_dict`` / ``from_dict`` for every system class, written once (the work is in :mod:`.model_dict`)."""

from __future__ import annotations

from typing import Any

from ..errors import ModelError


class ModelDictMixin:
    """Adds the model-file dictionary form to a system class (exact round trip)."""

    def to_dict(self) -> dict[str, Any]:
        """The model-file dictionary (:mod:`hybobs_opt.systems.model_dict`; JSON/TOML/YAML-ready)."""
        from .model_dict import system_to_dict

        return system_to_dict(self)

    @classmethod
    def from_dict(cls, data: Any):
        """Inverse of :meth:`to_dict`; ``ModelError`` names the entry at fault."""
        from .model_dict import system_from_dict

        system = system_from_dict(data)
        if not isinstance(system, cls):
            raise ModelError("class", f"a model of a {cls.__name__}", f"class {data.get('class')!r}")
        return system
