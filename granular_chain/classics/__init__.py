"""The classic experiments of granular-chain physics, reproduced and checked.

Each experiment runs the engine on its scene in ``scenarios/classics/`` and
compares what it measures with a reference, published or computed apart from
the engine, in a table of rows (quantity, engine, reference, relative
difference, source). ``granular-chain classics`` lists them and runs them;
docs/classics.md has one section per experiment.

========================  =========================================================================
module                    contents
========================  =========================================================================
``table``                 the :class:`Row` and the table's text, CSV and JSON forms
``experiment``            :class:`Experiment` (name, title, scenes, rows, figure), :class:`Outcome`
``registry``              :data:`EXPERIMENTS`, by name
``hertz_wave``            the exact discrete travelling wave (Petviashvili iteration)
``chain_ode``             an independent DOP853 integration of a chain (with Coulomb friction)
``solitary_wave``         experiment ``solitary_wave``
``heavy_striker``         experiment ``heavy_striker``
``newtons_cradle``        experiment ``newtons_cradle``
``dimers``                experiment ``dimers``
``tapered``               experiment ``tapered``
``precompressed``         experiment ``precompressed``
``backscatter_friction``  experiment ``backscatter_friction``
========================  =========================================================================
"""

from .experiment import SCENES, Experiment, Outcome
from .registry import EXPERIMENTS, experiment
from .table import COLUMNS, Row, format_table, table_csv, table_json

__all__ = ["Experiment", "Outcome", "SCENES", "EXPERIMENTS", "experiment", "Row", "COLUMNS",
           "format_table", "table_csv", "table_json"]
