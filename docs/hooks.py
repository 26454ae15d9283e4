"""MkDocs hooks: pages generated from the code, so that they cannot drift from it.

A page that holds ``<!-- generated: operators -->`` gets the operator registry's table
(:mod:`jaxga.operators.registry`); ``<!-- generated: presets -->`` gets one section per paper
card (``docs/cards/*.toml``: every value of a preset with the paper's section it comes
from); ``<!-- generated: doe -->`` the table of a designed experiment run by the build.
The figures under ``docs/figures/generated/`` are drawn by the build from runs of the
current code (:func:`make_figures`). Loaded by ``mkdocs.yml`` (``hooks:``).
"""

from __future__ import annotations

import re
from pathlib import Path

CARDS = Path(__file__).resolve().parent / "cards"
GENERATED = Path(__file__).resolve().parent / "figures" / "generated"
"""The figures the build draws (not in git: made afresh by every build)."""
_MADE: dict[str, str] = {}


def operators_table() -> str:
    """Markdown: every registered operator, family by family, with its summary, its own
    keys and its traits."""
    from jaxga.operators import registry

    out = []
    for family in registry.FAMILIES:
        out += [f"### {family}", "", "| name | what it does | its keys | traits |",
                "|---|---|---|---|"]
        for op in registry.operators(family):
            keys = ", ".join(f"`{k}`" for k in op.params) or "-"
            traits = ", ".join(sorted(op.traits)) or "-"
            former = f" (formerly {', '.join(op.aliases)})" if op.aliases else ""
            summary = op.summary.replace("|", "/")
            out.append(f"| `{op.name}`{former} | {summary} | {keys} | {traits} |")
        out.append("")
    return "\n".join(out)


_LINE = re.compile(r"^(?P<key>[A-Za-z_]+)\s*=\s*(?P<value>[^#]+?)\s*(#\s*(?P<note>.*))?$")


def card_section(path: Path) -> str:
    """Markdown: one paper card as a heading, the card's opening comment and a table of
    (stage, key, value, where it comes from); a comment that continues on the next
    lines is joined."""
    lines = path.read_text().splitlines()
    intro = []
    for line in lines:
        if not line.startswith("#"):
            break
        intro.append(line.lstrip("# ").rstrip())
    rows, section = [], "run"
    for line in lines[len(intro):]:
        stripped = line.strip()
        if stripped.startswith("[") and stripped.endswith("]"):
            section = stripped[1:-1]
        elif stripped.startswith("#") and rows and line.startswith(" "):
            rows[-1][3] += " " + stripped.lstrip("# ")
        elif (m := _LINE.match(stripped)) and m["key"] != "preset":
            rows.append([section, m["key"], m["value"], m["note"] or ""])
    table = ["| stage | key | value | source |", "|---|---|---|---|"]
    table += [f"| {s} | `{k}` | `{v}` | {n.replace('|', '/')} |" for s, k, v, n in rows]
    return "\n".join([f"### {path.stem}", "", " ".join(intro), "", *table, ""])


def presets_sections() -> str:
    """Markdown: every paper card, in name order."""
    return "\n".join(card_section(p) for p in sorted(CARDS.glob("*.toml")))


def make_figures() -> dict[str, str]:
    """Run the examples the site shows and draw them into :data:`GENERATED`: the README's
    main job (Zhu & Pan's GA on the built-in 20 x 20 map: best paths and convergence), a
    plan on the ROS map of docs/examples with a 0.1 m robot, and AGACD's designed
    experiment (its Table 3 factors, 2 seeds); returns the markdown of the DOE table."""
    import matplotlib

    matplotlib.use("Agg")
    import jaxga
    from jaxga.doe import AGACD_TABLE3, run_doe
    from jaxga.plot import plot_result

    GENERATED.mkdir(parents=True, exist_ok=True)
    main = jaxga.run("iga_zhu", "classic_ga_gapp3_20x20", seeds=20)
    plot_result(main, "classic_ga_gapp3_20x20", GENERATED / "main_job.png")
    office = Path(__file__).resolve().parent / "examples" / "office.yaml"
    planner = jaxga.Planner(str(office), robot_radius=0.1, seeds=8)
    plan = planner.plan(start_world=(-0.55, -0.55), goal_world=(1.85, 1.85))
    grid = planner.map.grid.replace(start=plan.start, goal=plan.goal)
    plot_result(plan, grid, GENERATED / "office_plan.png", info=planner.map)
    doe = run_doe("agacd", "classic_ga_gapp3_20x20", list(AGACD_TABLE3), "agacd-table4",
                  seeds=2, generations=30)
    return {"doe": "```text\n" + doe.table() + "\n\n" + doe.equation() + "\n```"}


def on_pre_build(config) -> None:  # noqa: ARG001 - hook API
    """Draw the figures and run the experiment the pages show (:func:`make_figures`)."""
    _MADE.update(make_figures())


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 - hook API
    """Replace the generation markers of a page."""
    if "<!-- generated: doe -->" in markdown:
        markdown = markdown.replace("<!-- generated: doe -->", _MADE.get("doe", ""))
    if "<!-- generated: operators -->" in markdown:
        markdown = markdown.replace("<!-- generated: operators -->", operators_table())
    if "<!-- generated: presets -->" in markdown:
        markdown = markdown.replace("<!-- generated: presets -->", presets_sections())
    return markdown


_ROLE = re.compile(r":(?:func|class|meth|mod|data|attr|exc|obj):<code>(~?)([\w.]+)</code>")
_ID = re.compile(r'id="([\w.]+)"')


def resolve_roles(html: str) -> str:
    """The docstrings' Sphinx roles (``:func:`jaxga.run```), which the renderer leaves as
    text, as code: a link where the page documents the name (its full name, or the one
    documented name that ends with it), plain code elsewhere; ``~a.b.c`` shows ``c``."""
    ids = set(_ID.findall(html))

    def link(m: re.Match) -> str:
        short, name = m[1], m[2]
        shown = name.rsplit(".", 1)[-1] if short else name
        target = name if name in ids else None
        if target is None:
            ends = [i for i in ids if i.endswith("." + name)]
            target = ends[0] if len(ends) == 1 else None
        code = f"<code>{shown}</code>"
        return f'<a href="#{target}">{code}</a>' if target else code

    return _ROLE.sub(link, html)


def on_page_content(html: str, **kwargs) -> str:
    """MkDocs hook: the rendered docstrings' roles as links or code (:func:`resolve_roles`)."""
    return resolve_roles(html)
