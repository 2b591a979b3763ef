"""Old path of the polytope type, now :mod:`hybobs_opt.geometry` (issue 13 split this module).

The class lives in :mod:`hybobs_opt.geometry.polytope`, redundancy removal in
:mod:`~hybobs_opt.geometry.redundancy`, images and projections in
:mod:`~hybobs_opt.geometry.projection`, volumes in :mod:`~hybobs_opt.geometry.volume`.  Every
name the old module had (public and private) is read from the part that defines it, and setting
one here (``monkeypatch.setattr(polytope, "HULL_PROJECTION_MAX_DIM", 1)``) sets it in every part
that holds it, so the code that reads it sees the new value.
"""

import sys
import types

from ..geometry import _common, projection, redundancy, volume
from ..geometry import polytope as _polytope

_PARTS = (_polytope, projection, redundancy, volume, _common)


class _ForwardingModule(types.ModuleType):
    """A module whose attributes are those of the geometry modules, read and written through.

    The names are also copied into this module's own namespace, because ``monkeypatch`` records
    (and restores) the entry of the module's ``__dict__``; reads still come from the parts, so a
    value set on a part directly is seen here too.
    """

    def __getattribute__(self, name: str):
        if not name.startswith("__"):
            for part in _PARTS:
                space = vars(part)
                if name in space:
                    return space[name]
        return super().__getattribute__(name)

    def __setattr__(self, name: str, value) -> None:
        super().__setattr__(name, value)
        for part in _PARTS:
            if name in vars(part):
                setattr(part, name, value)

    def __delattr__(self, name: str) -> None:
        holders = [part for part in _PARTS if name in vars(part)]
        if name in vars(self) or not holders:
            super().__delattr__(name)
        for part in holders:
            delattr(part, name)


for _part in reversed(_PARTS):
    globals().update({k: v for k, v in vars(_part).items() if not k.startswith("__") and k not in globals()})
del _part
sys.modules[__name__].__class__ = _ForwardingModule
