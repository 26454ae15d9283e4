"""The six presets and their loader (jaxga.config.presets).

The expected numbers below were written from the papers (papers/000-004), not copied from
the TOML files: every value a paper gives is asserted against that paper.
"""

from __future__ import annotations

import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

from jaxga.config.presets import load_preset, preset_info, preset_names, preset_variants
from jaxga.config.schema import SCHEMA, Config
from jaxga.core.errors import ParameterError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]
PAPER_PRESETS = ("agacd", "iga_zhang", "iga_zhu", "imga", "mpmga", "sga")
PRESETS = tuple(preset_names())
"""Every preset file of the package (discovered: a new preset is its TOML file and its
card, docs/cards, with no list to extend here)."""
VARIANTS = {
    "hybrid": [],
    "pareto": [],
    "agacd": ["50x50"],
    "iga_zhang": ["env2", "env3"],
    "iga_zhu": [],
    "imga": [],
    "mpmga": ["50x50"],
    "sga": ["50x50", "agacd", "iga_zhu", "imga", "mpmga"],
}


def check(config: Config, expected: dict) -> None:
    for key, want in expected.items():
        got = config[key]
        if isinstance(want, float):
            assert got == pytest.approx(want), key
        elif isinstance(want, (list, tuple)):
            assert list(got) == pytest.approx(list(want)), key
        else:
            assert got == want, key


# ----------------------------------------------------------------------------- loading


def test_the_six_paper_presets_and_jaxgas_own_exist():
    assert set(PAPER_PRESETS) | {"hybrid"} <= set(preset_names())
    info = preset_info()
    assert [name for name, _, _ in info] == sorted(PRESETS)
    for name, paper, description in info:
        assert paper and description, name


@pytest.mark.parametrize("name", PRESETS)
def test_every_preset_and_variant_loads_and_validates(name):
    if name in VARIANTS:  # the variants the papers' settings need
        assert preset_variants(name) == sorted(VARIANTS[name])
    for variant in [None, *preset_variants(name)]:
        config = load_preset(name, variant)
        assert isinstance(config, Config)
        assert config["name"] == name
        # the corner rule is the map's (jaxga.maps.default_corner_rule), not a preset's
        assert config["map.corner_rule"] == "map"
        assert all(key in SCHEMA for key, _ in config.items)
        if variant is not None:
            assert variant in config["description"]


@pytest.mark.parametrize("name", PRESETS)
def test_every_value_in_a_preset_file_has_a_source_comment(name):
    """Each parameter line names its table / section, or says it is not in the paper."""
    text = (ROOT / "presets" / f"{name}.toml").read_text(encoding="utf-8")
    for line in text.splitlines():
        if re.match(r"^[A-Za-z_][\w.]*\s*=", line) and line.split("=")[0].strip() not in (
            "name", "paper", "description"
        ):
            assert "#" in line, f"{name}.toml: no source comment on {line!r}"


# --------------------------------------------------------------------- paper values


def test_imga_section_5_1():
    # Li, Hu, Liu 2021, 5.1: NP = 100, max_gen = 50, PC = 0.8, PM = 0.2, a = 6, b = 1, c = 3;
    # 4.4: stop after 40 generations without improvement; 4.1-4.5 operators.
    check(load_preset("imga"), {
        "population.size": 100, "generations": 50,
        "crossover.probability": 0.8, "mutation.probability": 0.2,
        "fitness.method": "imga", "fitness.a": 6.0, "fitness.b": 1.0, "fitness.c": 3.0,
        "termination.stagnation": 40,
        "init.method": "median_insertion", "init.unique": True,  # 4.1 (iii)
        "selection.method": "layered_thirds",
        "crossover.method": "common_point", "mutation.method": "neighbour_point",
        "simplify.method": "none", "post.method": "shortcut_greedy",
        "islands.count": 1,
    })


def test_agacd_table_6_20x20():
    # Hao et al. 2021, Table 6 (AGACD): population 60, 300 iterations, pc_high 0.7,
    # pc_low 0.65, pm_high 0.3, pm_low 0.15; 4.4: I1 = 1.2, I2 = 1.4.
    config = load_preset("agacd")
    check(config, {
        "population.size": 60, "generations": 300,
        "crossover.adaptive": True, "crossover.pc_low": 0.65, "crossover.pc_high": 0.7,
        "mutation.adaptive": True, "mutation.pm_low": 0.15, "mutation.pm_high": 0.3,
        "fitness.method": "agacd", "fitness.importance_ratios": [1.2, 1.4],
        "fitness.smoothness_floor": 0.1,
        "init.method": "greedy_random_target", "selection.method": "roulette_elite",
        "crossover.method": "cut_and_check", "mutation.method": "point_checked",
        "post.method": "shortcut_greedy",
    })
    # eq. 25: the ratios give w = (0.4118, 0.3431, 0.2451)
    i1, i2 = config["fitness.importance_ratios"]
    w3 = 1.0 / (1.0 + i2 + i1 * i2)
    weights = (i1 * i2 * w3, i2 * w3, w3)
    assert weights == pytest.approx((0.4118, 0.3431, 0.2451), abs=5e-5)


def test_agacd_table_10_50x50():
    # Hao et al. 2021, Table 10 (AGACD): population 80, 500 iterations, pc_high 0.9,
    # pc_low 0.75, pm_high 0.3, pm_low 0.15; everything else as for 20 x 20.
    config = load_preset("agacd", "50x50")
    check(config, {
        "population.size": 80, "generations": 500,
        "crossover.pc_low": 0.75, "crossover.pc_high": 0.9,
        "mutation.pm_low": 0.15, "mutation.pm_high": 0.3,
        "crossover.adaptive": True, "mutation.adaptive": True,
        "fitness.importance_ratios": [1.2, 1.4],
    })


def test_mpmga_table_2():
    # Hao et al. 2020, Table 2 (MPMGA): initial population 60 in small populations of 20,
    # 200 iterations, pc high 0.8 / low 0.1, pm high 0.8 / low 0.1, alpha 0.8, beta 0.2,
    # initial temperature 1, decay 0.7; 4.4: A low/low, B high pc, C high pm; accuracy
    # coefficient 1 (its SGA row). Selection replaced by migration.
    config = load_preset("mpmga")
    check(config, {
        "population.size": 20, "islands.count": 3, "generations": 200,
        "islands.crossover_probabilities": [0.1, 0.8, 0.1],
        "islands.mutation_probabilities": [0.1, 0.1, 0.8],
        "fitness.method": "mpmga", "fitness.alpha": 0.8, "fitness.beta": 0.2,
        "fitness.c": 1.0,
        "mutation.temperature_c1": 1.0, "mutation.temperature_w": 0.7,
        "islands.topology": "mpmga", "islands.interval": 1, "selection.method": "shuffle",
        "islands.timing": "before_variation",
        "init.method": "intermittent_connect", "crossover.method": "heterologous",
        "mutation.method": "segment_sa", "post.method": "shortcut_greedy",
    })
    assert config["population.size"] * config["islands.count"] == 60
    assert config["fitness.alpha"] + config["fitness.beta"] == pytest.approx(1.0)  # eq. 4
    assert config["islands.migrants"] >= 1


def test_mpmga_50x50_from_agacd_table_10():
    # Hao et al. 2021, Table 10 (MPMGA): 45 = 3 x 15, 500 iterations, pc 0.8 / 0.3,
    # pm 0.6 / 0.1, accuracy coefficient 1, initial temperature 1, decay 0.9.
    config = load_preset("mpmga", "50x50")
    check(config, {
        "population.size": 15, "islands.count": 3, "generations": 500,
        "islands.crossover_probabilities": [0.3, 0.8, 0.3],
        "islands.mutation_probabilities": [0.1, 0.1, 0.6],
        "fitness.c": 1.0, "mutation.temperature_c1": 1.0, "mutation.temperature_w": 0.9,
    })
    assert config["population.size"] * config["islands.count"] == 45


def test_iga_zhu_table_3():
    # Zhu & Pan 2024, Table 3 (IGA): Popnum 200, N 50, pc 0.8, pm 0.4, ps 0.4, omega 0.7,
    # c1 1, c2 2, c3 3; 4.1-4.7 operators.
    check(load_preset("iga_zhu"), {
        "population.size": 200, "generations": 50,
        "crossover.probability": 0.8, "mutation.probability": 0.4,
        "simplify.method": "simplify_adjacent", "simplify.probability": 0.4,
        "fitness.method": "iga_zhu", "fitness.omega": 0.7,
        "fitness.c1": 1.0, "fitness.c2": 2.0, "fitness.c3": 3.0,
        "init.method": "directional", "selection.method": "roulette_elite",
        "crossover.method": "common_point_or_column",
        "mutation.method": "replace_point_or_regrow",
        "post.method": "none",
    })


def test_iga_zhang():
    # Zhang Ke-qi: crossover probability 0.8, the corner-removing mutation at one random
    # position with probability 1, stratified selection, fitness from eq. 2; Table 1
    # iterations 45/40/35 (the whole chain: tests/config/test_cards.py).
    config = load_preset("iga_zhang")
    check(config, {
        "crossover.probability": 0.8,
        "mutation.method": "delete_corner", "mutation.probability": 1.0,
        "simplify.method": "none",
        "selection.method": "stratified", "fitness.method": "iga_zhang",
        "init.method": "random_walk", "crossover.method": "common_point",
        "generations": 45,
    })
    # jaxga's defaults (the paper gives no numbers): a = 2, v = 1, v_t = 0.5, r = 0.5
    check(config, {"fitness.a": 2.0, "fitness.v": 1.0, "fitness.v_t": 0.5, "fitness.r": 0.5})
    k = (config["fitness.v"] - config["fitness.v_t"]) * math.pi * config["fitness.r"] / (
        2 * config["fitness.v"] * config["fitness.v_t"])
    assert k == pytest.approx(math.pi / 4)
    assert load_preset("iga_zhang", "env2")["generations"] == 40
    assert load_preset("iga_zhang", "env3")["generations"] == 35


def test_sga_baselines():
    # AGACD Table 6 BGA: population 60, 300 iterations, pc 0.8, pm 0.3.
    check(load_preset("sga"), {
        "population.size": 60, "generations": 300,
        "crossover.probability": 0.8, "mutation.probability": 0.3,
        "init.method": "random_walk", "selection.method": "roulette",
        "crossover.method": "common_point", "mutation.method": "neighbour_point",
        "fitness.method": "sga", "post.method": "none", "simplify.method": "none",
    })
    # AGACD Table 10 BGA: 60, 500, pc 0.9, pm 0.3
    check(load_preset("sga", "50x50"), {
        "population.size": 60, "generations": 500,
        "crossover.probability": 0.9, "mutation.probability": 0.3,
    })
    # IMGA 5.1/5.2: GA with the same control parameters: 100, 50, 0.8, 0.2
    check(load_preset("sga", "imga"), {
        "population.size": 100, "generations": 50,
        "crossover.probability": 0.8, "mutation.probability": 0.2,
    })
    # MPMGA Table 2 PCDA/SGA: 60, 200, pc 0.8, pm 0.1, alpha 0.8, beta 0.2, accuracy 1
    check(load_preset("sga", "mpmga"), {
        "population.size": 60, "generations": 200,
        "crossover.probability": 0.8, "mutation.probability": 0.1,
        "fitness.alpha": 0.8, "fitness.beta": 0.2, "fitness.c": 1.0,
    })
    # Zhu & Pan Table 3 GA: 200, 50, pc 0.8, pm 0.4
    check(load_preset("sga", "iga_zhu"), {
        "population.size": 200, "generations": 50,
        "crossover.probability": 0.8, "mutation.probability": 0.4,
    })


# ------------------------------------------------------------- overrides and --set


def test_overrides_and_sets():
    config = load_preset(
        "imga",
        overrides={"crossover.probability": 0.7, "mutation": {"probability": 0.05}},
        sets=["generations=7", "islands.crossover_probabilities=[0.2, 0.9]",
              "map.corner_rule=strict", "crossover.adaptive = true",
              "description=a b=c"],
    )
    check(config, {
        "crossover.probability": 0.7, "mutation.probability": 0.05, "generations": 7,
        "islands.crossover_probabilities": [0.2, 0.9], "map.corner_rule": "strict",
        "crossover.adaptive": True, "description": "a b=c",
    })
    # --set wins over overrides, overrides over the variant, the variant over the file
    config = load_preset("agacd", "50x50", overrides={"generations": 10},
                         sets=["generations=11"])
    assert config["generations"] == 11 and config["population.size"] == 80
    assert load_preset("agacd", "50x50", overrides={"generations": 10})["generations"] == 10
    assert load_preset("imga", sets="generations=3")["generations"] == 3  # a single string
    assert load_preset("imga", sets=["population.size=30"])["population.size"] == 30  # int
    # decimals that TOML refuses but that are plainly numbers (they were words)
    config = load_preset("imga", sets=["crossover.probability=.5", "mutation.probability=1."])
    assert config["crossover.probability"] == 0.5 and config["mutation.probability"] == 1.0
    assert load_preset("imga", sets=["description=1.2.3"])["description"] == "1.2.3"


@pytest.mark.parametrize("bad", ["crossover.probability", "=0.5", "generations=", "  = 1"])
def test_malformed_set(bad):
    with pytest.raises(ParameterError, match="malformed --set"):
        load_preset("imga", sets=[bad])


@pytest.mark.parametrize("text, key", [
    ("crossover.probability=1.5", "crossover.probability"),
    ("crossover.probability=-0.1", "crossover.probability"),
    ("population.size=1", "population.size"),
    ("generations=ten", "generations"),
    ("crossover.adaptive=1", "crossover.adaptive"),
    ("selection.method=best", "selection.method"),
    ("crossover.probabilty=0.5", "crossover.probabilty"),
    ("islands.mutation_probabilities=[0.1, 2.0]", "islands.mutation_probabilities"),
])
def test_bad_set_names_the_key(text, key):
    with pytest.raises(ParameterError, match=re.escape(key)) as info:
        load_preset("imga", sets=[text])
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("value, key, words", [
    (10**5000, "fitness.omega", "fitness.omega must be finite, got an integer of about "
     "5,001 digits"),  # beyond the largest float, and Python's 4,300-digit repr
    (10**5000, "population.size", "population.size = an integer of about 5,001 digits is "
     "above its maximum"),
    (-(10**400), "crossover.probability", "crossover.probability must be finite, got an "
     "integer of about 401 digits"),
    ("z" * 5000, "selection.method", "selection.method = 'zzz"),
    (["x" * 5000], "fitness.omega", "fitness.omega must be a number, got ['xxx"),
    ([10**5000], "fitness.omega", "fitness.omega must be a number, got a list too long"),
], ids=["float-key", "int-key", "negative", "long-string", "long-list", "huge-in-list"])
def test_a_huge_value_is_refused_in_a_short_line(value, key, words):
    """A value of thousands of digits or characters: a ParameterError naming the key, the
    value shown in at most 80 characters (not an OverflowError, not a line as long as the
    value)."""
    with pytest.raises(ParameterError) as info:
        load_preset("iga_zhu", overrides={key: value})
    text = str(info.value)
    assert words in text and "\n" not in text and len(text) < 250, text


@pytest.mark.parametrize("body, words", [
    ("x = " + "[" * 3000 + "]" * 3000, "malformed TOML: nested too deeply"),
    ("x = " + "{a=" * 3000 + "1" + "}" * 3000, "malformed TOML: nested too deeply"),
    (".".join(["a"] * 3000) + " = 1", "unknown configuration key 'a.a.a"),
], ids=["arrays", "inline-tables", "dotted-key"])
def test_a_preset_file_nested_thousands_deep_is_refused_in_one_line(tmp_path, body, words):
    """Arrays, tables or a dotted key thousands deep: a RecursionError traceback before
    (from tomllib, or from jaxga's own flatten); a ParameterError naming the file."""
    path = tmp_path / "deep.toml"
    path.write_text(f'base = "sga"\n{body}\n')
    with pytest.raises(ParameterError) as info:
        load_preset(str(path))
    assert words in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(ParameterError, match="--set init.clearance_weights: a value nested "
                       "too deeply"):
        load_preset("sga", sets=["init.clearance_weights=" + "[" * 3000 + "]" * 3000])


def test_a_finite_number_is_one_a_float_holds():
    from jaxga.core.fields import finite_number

    assert finite_number(10**308) and finite_number(1.5) and finite_number(-3)
    for value in (2**1024 - 1, -(10**309), float("inf"), float("nan"), True, "1", None):
        assert not finite_number(value), value


def test_dotted_reads_every_spelling_of_a_key_and_refuses_two_values():
    from jaxga.config.schema import dotted

    assert dotted({"a__b": 1, "c": {"d": 2, "e": {"f": 3}}, "g.h": 4}) == {
        "a.b": 1, "c.d": 2, "c.e.f": 3, "g.h": 4}
    assert dotted({"a__b": 0.5, "a": {"b": np.float64(0.5)}}) == {"a.b": 0.5}  # the same
    with pytest.raises(ParameterError, match=r"^a\.b is given twice, as 0\.5 and 0\.9$"):
        dotted({"a__b": 0.5, "a": {"b": 0.9}})
    with pytest.raises(ParameterError, match=r"given twice, as 1 and True"):  # not one
        dotted({"a__b": 1, "a": {"b": True}})
    with pytest.raises(ParameterError, match="given twice"):
        load_preset("sga", overrides={"crossover__probability": 0.5,
                                      "crossover.probability": 0.9})


def test_a_preset_file_that_starts_with_a_byte_order_mark_loads(tmp_path):
    """Editors on Windows write a UTF-8 BOM; maps and scenarios with one load, and so does
    a preset file (tomllib refused it: "Invalid statement")."""
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + b'base = "sga"\n[crossover]\nprobability = 0.55\n')
    assert load_preset(str(path))["crossover.probability"] == 0.55


def test_flatten_keeps_the_tables_order_and_drops_empty_tables():
    from jaxga.config.schema import flatten

    table = {"a": {"b": 1, "c": {"d": 2}}, "e": 3, "f": {}, "g": [{"h": 4}]}
    assert flatten(table, "p.") == {"p.a.b": 1, "p.a.c.d": 2, "p.e": 3, "p.g": [{"h": 4}]}
    assert list(flatten(table)) == ["a.b", "a.c.d", "e", "g"]


def test_a_list_holding_an_integer_beyond_a_float_is_refused():
    with pytest.raises(ParameterError, match="islands.mutation_probabilities must be a list "
                       "of numbers, got a list too long to show"):
        load_preset("mpmga", overrides={"islands.mutation_probabilities": [0.1, 10**5000]})
    with pytest.raises(ParameterError, match=r"got \[0.1, 9999.*\[\d+ characters\]$"):
        load_preset("mpmga", overrides={"islands.mutation_probabilities": [0.1, 10**400 - 1]})


def test_bad_overrides_name_the_key():
    with pytest.raises(ParameterError, match="mutation.rate"):
        load_preset("imga", overrides={"mutation.rate": 0.1})
    with pytest.raises(ParameterError, match="fitness.omega"):
        load_preset("iga_zhu", overrides={"fitness.omega": 1.2})
    with pytest.raises(ParameterError, match="population.size"):
        load_preset("imga", overrides={"population.size": 2.5})


# -------------------------------------------------------------------------- errors


def test_unknown_preset_and_variant():
    with pytest.raises(ParameterError, match="unknown preset 'nope'"):
        load_preset("nope")
    with pytest.raises(ParameterError, match="'60x60'.*50x50"):
        load_preset("agacd", "60x60")
    with pytest.raises(ParameterError, match="has no variant"):
        load_preset("imga", "50x50")
    with pytest.raises(ParameterError, match="not found"):
        load_preset("missing/file.toml")


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def test_user_file_errors_name_file_and_key(tmp_path):
    unknown = _write(tmp_path / "unknown.toml", 'base = "imga"\n[crossover]\nrate = 0.5\n')
    with pytest.raises(ParameterError, match=r"unknown\.toml.*crossover\.rate"):
        load_preset(unknown)
    bad = _write(tmp_path / "bad.toml", 'base = "imga"\n[mutation]\nprobability = 3\n')
    with pytest.raises(ParameterError, match=r"bad\.toml.*mutation\.probability"):
        load_preset(str(bad))
    wrong_type = _write(tmp_path / "type.toml", 'base = "imga"\ngenerations = "many"\n')
    with pytest.raises(ParameterError, match=r"type\.toml.*generations"):
        load_preset(wrong_type)
    broken = _write(tmp_path / "broken.toml", "[crossover\nprobability = 0.5\n")
    with pytest.raises(ParameterError, match=r"broken\.toml.*malformed TOML") as info:
        load_preset(broken)
    assert "\n" not in str(info.value)
    huge = _write(tmp_path / "huge.toml", 'base = "imga"\ngenerations = ' + "9" * 5000 + "\n")
    with pytest.raises(ParameterError, match=r"huge\.toml.*malformed TOML.*4300 digits"):
        load_preset(huge)  # Python's limit on int(str): a ValueError TOML does not wrap
    incomplete = _write(tmp_path / "incomplete.toml", "generations = 5\n")
    with pytest.raises(ParameterError, match=r"incomplete\.toml.*missing"):
        load_preset(incomplete)
    bad_base = _write(tmp_path / "badbase.toml", 'base = "nope"\n')
    with pytest.raises(ParameterError, match=r"badbase\.toml.*unknown preset 'nope'"):
        load_preset(bad_base)
    loop = _write(tmp_path / "loop.toml", 'base = "loop.toml"\n')
    with pytest.raises(ParameterError, match="loops"):
        load_preset(loop)
    variants = _write(tmp_path / "variants.toml", 'base = "imga"\nvariants = 3\n')
    with pytest.raises(ParameterError, match=r"variants\.toml.*variants"):
        load_preset(variants)
    not_utf8 = tmp_path / "latin.toml"
    not_utf8.write_bytes(b'name = "caf\xe9"\n')
    with pytest.raises(ParameterError, match=r"latin\.toml"):
        load_preset(not_utf8)


def test_user_file_with_base(tmp_path, monkeypatch):
    user = _write(tmp_path / "my_run.toml", "\n".join([
        'base = "agacd"',
        "generations = 42",
        "[crossover]",
        "pc_high = 0.8",
        "[variants.quick]",
        "population.size = 10",
    ]) + "\n")
    config = load_preset(user)
    check(config, {
        "name": "my_run", "generations": 42, "crossover.pc_high": 0.8,
        "population.size": 60, "crossover.pc_low": 0.65, "init.method": "greedy_random_target",
    })
    # the base's variant applies below the file, the file's own variants on top
    config = load_preset(user, "50x50")
    check(config, {"generations": 42, "population.size": 80, "crossover.pc_high": 0.8,
                   "crossover.pc_low": 0.75})
    assert load_preset(user, "quick")["population.size"] == 10
    assert preset_variants(user) == ["50x50", "quick"]
    # a base given as a path is relative to the file that names it; a bare file name works
    _write(tmp_path / "child.toml", 'base = "my_run.toml"\nname = "child"\n'
           "[mutation]\npm_low = 0.1\n")
    monkeypatch.chdir(tmp_path)
    check(load_preset("child.toml"), {"name": "child", "generations": 42,
                                      "mutation.pm_low": 0.1})
    _write(tmp_path / "plain", 'base = "imga"\n')
    assert load_preset("plain")["population.size"] == 100
    # a built-in name wins over a file of the same name in the working directory
    _write(tmp_path / "imga", "this is not TOML\n")
    assert load_preset("imga")["name"] == "imga"


def test_standalone_user_file(tmp_path):
    user = _write(tmp_path / "mine.toml", "\n".join([
        "generations = 5",
        "[population]", "size = 8",
        "[init]", 'method = "directional"',
        "[fitness]", 'method = "sga"',
        "[selection]", 'method = "tournament"', "tournament_size = 3",
        "[crossover]", 'method = "common_point"', "probability = 0.9",
        "[mutation]", 'method = "one_point"', "probability = 0.1",
    ]) + "\n")
    config = load_preset(user)
    check(config, {"name": "mine", "generations": 5, "population.size": 8,
                   "selection.tournament_size": 3, "map.corner_rule": "map",
                   "mutation.method": "replace_point"})  # the former name, accepted


# ----------------------------------------------------------------------- packaging


def test_pyproject_installs_the_presets_and_every_subpackage():
    """The TOML files are package data of jaxga.presets_data (mapped from presets/), and the
    explicit package list in pyproject.toml names every jaxga package."""
    pyproject = ROOT / "pyproject.toml"
    if not pyproject.is_file():  # pragma: no cover - tests run outside a checkout
        pytest.skip("no source checkout")
    tool = tomllib.loads(pyproject.read_text(encoding="utf-8"))["tool"]["setuptools"]
    assert tool["package-dir"]["jaxga.presets_data"] == "presets"
    assert "*.toml" in tool["package-data"]["jaxga.presets_data"]
    found = {".".join(p.parent.relative_to(ROOT).parts)
             for p in (ROOT / "jaxga").rglob("__init__.py")}
    assert set(tool["packages"]) == found | {"jaxga.presets_data"}
    on_disk = sorted(p.stem for p in (ROOT / "presets").glob("*.toml"))
    assert on_disk == preset_names()
