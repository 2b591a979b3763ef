"""Old name of :mod:`hybobs_opt.contract`, the runtime observer contract (kept for imports).

``hybobs_opt.observers.base`` *is* :mod:`hybobs_opt.contract` (one module object under two names),
so ``from hybobs_opt.observers.base import Observer`` and a patch of one of its attributes keep
working.
"""

import sys

from .. import contract

sys.modules[__name__] = contract
