"""The GA's operators, one module per family, as pure per-individual (or per-pair) functions.

- :mod:`~jaxga.operators.init`: initialisers (the papers' walks and insertions, the field walk);
- :mod:`~jaxga.operators.selection`: selection schemes;
- :mod:`~jaxga.operators.crossover`: crossovers (the splice they share in
  :mod:`~jaxga.operators.joins`, Zhu & Pan's column crossover in
  :mod:`~jaxga.operators.column_crossover`);
- :mod:`~jaxga.operators.mutation`: mutations;
- :mod:`~jaxga.operators.repair`: reconnection of broken paths;
- :mod:`~jaxga.operators.postprocess`: simplification and post-optimisation;
- :mod:`~jaxga.operators.islands`: migration between populations;
- :mod:`~jaxga.operators.schedules`: time schedules of the adaptive operators;
- :mod:`~jaxga.operators.guide`: the exact distance fields that steer the field operators;
- :mod:`~jaxga.operators.lift`: per-individual operators applied to a population;
- :mod:`~jaxga.operators.fitness`: the papers' objectives as operators;
- :mod:`~jaxga.operators.simplify`: the per-generation simplifications;
- :mod:`~jaxga.operators.registry`: the registry every operator is declared in.

Each operator is declared once, at the end of its family's module; importing this package
imports every family's module, so the registry holds them all, in the order of
:data:`jaxga.operators.registry.FAMILIES`.
"""

from jaxga.operators import (  # noqa: F401 - each family's module declares its operators
    crossover,
    fitness,
    init,
    mutation,
    postprocess,
    selection,
    simplify,
)
