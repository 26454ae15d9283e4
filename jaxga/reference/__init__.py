"""Independent references: exact optima of the path problems, and of the papers' fitness functions.

- :mod:`~jaxga.reference.optima`: exact 8-connected shortest paths (Dijkstra, NumPy and JAX)
  and exact any-angle shortest paths (visibility graph), the certificates of every gap;
- :mod:`~jaxga.reference.lower_bound`: the Euclidean shortest path around the obstacles
  (the taut string), a proven lower bound of the any-angle optimum that scales with the
  obstacles' corners, not the map's cells;
- :mod:`~jaxga.reference.fitness`: the exact optimum of a preset's own fitness over
  8-connected paths.

The shortest-path functions are re-exported here (``jaxga.reference.shortest_path``).
"""

from jaxga.reference.any_angle import (
    C_OCTILE,
    any_angle_shortest_path,
    any_angle_shortest_path_np,
    obstacle_adjacent_cells,
)
from jaxga.reference.lower_bound import euclidean_lower_bound, euclidean_lower_bound_np
from jaxga.reference.optima import (
    SQRT2,
    XY,
    OctileGraph,
    ReferencePath,
    clear_many_np,
    clear_np,
    clear_pairs_np,
    distances_from,
    legal_moves_np,
    path_length,
    require,
    shortest_path,
    shortest_path_np,
)

__all__ = [
    "C_OCTILE",
    "OctileGraph",
    "ReferencePath",
    "SQRT2",
    "XY",
    "any_angle_shortest_path",
    "any_angle_shortest_path_np",
    "clear_many_np",
    "clear_np",
    "clear_pairs_np",
    "distances_from",
    "euclidean_lower_bound",
    "euclidean_lower_bound_np",
    "legal_moves_np",
    "obstacle_adjacent_cells",
    "path_length",
    "require",
    "shortest_path",
    "shortest_path_np",
]
