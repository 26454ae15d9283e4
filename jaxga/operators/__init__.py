"""The GA's operators, one module per family, as pure per-individual (or per-pair) functions.

- :mod:`~jaxga.operators.init`: initialisers (the papers' walks and insertions, the field walk);
- :mod:`~jaxga.operators.selection`: selection schemes;
- :mod:`~jaxga.operators.crossover`: crossovers;
- :mod:`~jaxga.operators.mutation`: mutations;
- :mod:`~jaxga.operators.repair`: reconnection of broken paths;
- :mod:`~jaxga.operators.postprocess`: simplification and post-optimisation;
- :mod:`~jaxga.operators.islands`: migration between populations;
- :mod:`~jaxga.operators.schedules`: time schedules of the adaptive operators;
- :mod:`~jaxga.operators.guide`: the exact distance fields that steer the field operators;
- :mod:`~jaxga.operators.lift`: per-individual operators applied to a population.

Each is registered once in :mod:`jaxga.config.registry`.
"""
