"""The seed papers' example systems as factories, every number cited to its paper.

``list_examples()`` returns them in paper order; ``get_example(name)`` looks one up.
Importing this package registers every example module below.
"""

from .registry import PAPERS, Example, get_example, list_examples, register

# Registration order = paper order (000 ... 004); each module calls register() at import.
from . import driveline  # noqa: E402,F401  paper 000
from . import sliding_mode  # noqa: E402,F401  paper 001
from . import powertrain  # noqa: E402,F401  paper 002
from . import switching  # noqa: E402,F401  paper 003
from . import nonmonotonic  # noqa: E402,F401  paper 004

__all__ = ["PAPERS", "Example", "get_example", "list_examples", "register"]
