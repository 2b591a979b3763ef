"""The five seed papers as studies of the toolbox: their systems, scenarios, published design
settings, comparisons and figure data.  Studies import the core (``hybobs_opt.systems``,
``regions``, ``lmi``, ``mhe``, ``observers`` ...), never the reverse.

``list_examples()`` returns the example systems in paper order, ``get_example(name)`` looks one
up.  Importing this package registers the examples without importing their modules (the
factories are imported on first call), so listing them is cheap.

=========================  ============================================================
package                    paper
=========================  ============================================================
``paper000_driveline``     000 Balluchi et al., hybrid observer of a driveline
``paper001_sliding_mode``  001 Djemai et al., sliding-mode observers
``paper002_powertrain``    002 observability regions, lookup and MHE observers (PWA)
``paper003_switching``     003 observers of PWA systems with constant drift
``paper004_nonmonotonic``  004 Rajamani et al., switched-gain observers
=========================  ============================================================
"""

from hybobs_opt.systems.resolve import register_resolver

from .registry import PAPERS, Example, LazyCallable, resolve_example, get_example, list_examples, register

# Registration order = paper order (000 ... 004); each package calls register() at import.
from . import paper000_driveline  # noqa: E402,F401
from . import paper001_sliding_mode  # noqa: E402,F401
from . import paper002_powertrain  # noqa: E402,F401
from . import paper003_switching  # noqa: E402,F401
from . import paper004_nonmonotonic  # noqa: E402,F401

# Saved results that name an example (``hybobs regions --out``) are rebuilt through this resolver.
register_resolver("examples", resolve_example)

__all__ = ["PAPERS", "Example", "LazyCallable", "get_example", "list_examples", "register"]
