"""Grid maps: loaders, Moving AI scenarios, built-in maps, generators and preprocessing.

Convention everywhere (docs/maps.md): ``blocked[y, x]`` with ``y = 0`` the **bottom** row,
``x`` the column, cell index ``p = y * W + x``. Loaders flip formats whose first row is
the top (Moving AI maps and scenarios, ASCII art, images); 0/1 text files are read with
their first line as the bottom row, like the classic GA maps.

>>> from jaxga.maps import load_map, builtin_names
>>> grid = load_map("classic_ga_gapp3_20x20")          # a built-in map
>>> grid.shape, grid.start_xy, grid.goal_xy
((20, 20), (0, 0), (19, 19))
"""

from jaxga.maps.builtin import (
    DATA_DIR,
    builtin_names,
    builtin_path,
    builtin_scenario_path,
    builtin_scenarios,
    default_corner_rule,
    scenario_path,
)
from jaxga.maps.formats import (
    FORMATS,
    detect_format,
    parse_01,
    parse_ascii,
    parse_movingai,
    save_map,
)
from jaxga.maps.generators import maze_map, random_map, rectangles_map, rooms_map
from jaxga.maps.loaders import MapInfo, load_map, load_map_info, map_name
from jaxga.maps.occupancy_grid import OccupancyGrid
from jaxga.maps.preprocess import (
    coarsen,
    coarsen_blocked,
    endpoints_connected,
    fill_enclosed,
    inflate,
    legal_moves,
    preprocess,
    reachable,
)
from jaxga.maps.scenarios import Scenario, parse_scen, read_scen

__all__ = [
    "DATA_DIR",
    "FORMATS",
    "MapInfo",
    "OccupancyGrid",
    "Scenario",
    "builtin_names",
    "builtin_path",
    "builtin_scenario_path",
    "builtin_scenarios",
    "scenario_path",
    "coarsen",
    "coarsen_blocked",
    "default_corner_rule",
    "detect_format",
    "endpoints_connected",
    "fill_enclosed",
    "inflate",
    "legal_moves",
    "load_map",
    "load_map_info",
    "map_name",
    "maze_map",
    "parse_01",
    "parse_ascii",
    "parse_movingai",
    "parse_scen",
    "preprocess",
    "random_map",
    "read_scen",
    "reachable",
    "rectangles_map",
    "rooms_map",
    "save_map",
]
