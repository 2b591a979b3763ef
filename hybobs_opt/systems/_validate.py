"""Old path of :mod:`hybobs_opt._validate` (the same module object; the checks serve every layer)."""

import sys

from .. import _validate

sys.modules[__name__] = _validate
