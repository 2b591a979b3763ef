"""Old path of :mod:`hybobs_opt.geometry._lp_kernels` (the same module object, see :mod:`hybobs_opt.lp`)."""

import sys

from .geometry import _lp_kernels as _kernels

sys.modules[__name__] = _kernels
