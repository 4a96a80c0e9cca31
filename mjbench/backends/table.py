"""The tabulated reduced model, kept under its old name: it lives in :mod:`mjbench.mechanisms.table`
(a mechanism's own model, below the plants).  This name is that module itself (``sys.modules``
alias), so reading, patching and ``from mjbench.backends.table import …`` reach the same objects."""
import sys

from ..mechanisms import table as _table

sys.modules[__name__] = _table
