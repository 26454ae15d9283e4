"""The problem and its paths: grids, path arrays, exact geometry, objectives, errors.

- :mod:`~jaxga.core.errors`: the exceptions every layer raises;
- :mod:`~jaxga.core.grid`: the occupancy grid, its moves and corner rules;
- :mod:`~jaxga.core.paths`: fixed-capacity masked paths and their invariants;
- :mod:`~jaxga.core.geometry`: exact line of sight between cell centres;
- :mod:`~jaxga.core.objectives`: the papers' objectives and fitness combiners.
"""
