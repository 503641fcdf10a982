"""``python -m pytdcr.cli``: the ``tdcr`` console script."""

from . import entry

entry()
