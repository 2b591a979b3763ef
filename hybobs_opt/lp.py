"""Old path of :mod:`hybobs_opt.geometry.lp` (issue 13 moved the LP layer into the geometry package).

``import hybobs_opt.lp`` and ``from hybobs_opt.lp import solve_lp`` give the very module object
of :mod:`hybobs_opt.geometry.lp`, so ``monkeypatch.setattr(lp, "linprog", ...)`` reaches the code.
"""

import sys

from .geometry import lp as _lp

sys.modules[__name__] = _lp
