"""The FMU's documentation/index.html: the variable table and the model's docs.

Written by the build from model/c/variables.def and docs/model.md and
docs/conventions.md, so what an importer shows beside the FMU is what the
repository documents. Links to other documents of the repository become plain
text (they are not in the archive).
"""

from __future__ import annotations

import html
import re
from pathlib import Path

from fmu_build.variables import Enumeration, Range, Variable

DOCS = Path(__file__).resolve().parent.parent / "docs"
PAGES = ("model.md", "two_blocks.md", "conventions.md")

_LOCAL_LINK = re.compile(r"\[([^\]]+)\]\((?!https?:)(?!#)[^)]*\)")

STYLE = """
body { font-family: sans-serif; max-width: 60em; margin: 2em auto; line-height: 1.4; }
table { border-collapse: collapse; font-size: 90%; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; vertical-align: top; text-align: left; }
code { background: #f4f4f4; }
"""


def _markdown(text: str) -> str:
    import markdown  # only when an FMU is built: every command that finds it built starts without it

    return markdown.markdown(_LOCAL_LINK.sub(r"\1", text), extensions=["tables", "fenced_code"])


def _range_text(r: Range | None) -> str:
    """A valid range as the FMU checks it: [0, 1], (0, inf), ..."""
    if r is None:
        return ""
    low = "(-inf" if r.lower is None else ("[" if r.lower.closed else "(") + f"{r.lower.value:g}"
    high = "inf)" if r.upper is None else f"{r.upper.value:g}" + ("]" if r.upper.closed else ")")
    return f"{low}, {high}"


def _variable_rows(variables: list[Variable], enumerations: dict[str, Enumeration],
                   ranges: dict[str, Range]) -> list[str]:
    rows = []
    for v in variables:
        description = html.escape(v.description)
        if v.name in enumerations:
            items = "".join(f"<li><code>{value}</code> {html.escape(item)}: {html.escape(text)}</li>"
                            for value, item, text in enumerations[v.name].items)
            description += f"<ul>{items}</ul>"
        start = "" if v.causality == "output" else html.escape(v.start if v.type == "String" else str(v.start))
        kind = enumerations[v.name].name if v.name in enumerations else v.type
        rows.append(f"<tr><td><code>{html.escape(v.name)}</code></td><td>{v.causality}</td><td>{kind}</td>"
                    f"<td>{html.escape(v.unit)}</td><td>{start}</td><td>{_range_text(ranges.get(v.name))}</td>"
                    f"<td>{description}</td></tr>")
    return rows


def documentation_html(variables: list[Variable], enumerations: dict[str, Enumeration], model_name: str,
                       version: str, ranges: dict[str, Range] | None = None) -> str:
    """The text of documentation/index.html; ``ranges``: the valid ranges of the parameters
    (declared as min and max, an open bound as the next double inside it)."""
    out = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(model_name)} {html.escape(version)}</title>",
        f"<style>{STYLE}</style></head><body>",
        f"<h1>{html.escape(model_name)} {html.escape(version)}</h1>",
        "<p>Rigid blocks rocking on their corners on a rigid base under horizontal and vertical ground "
        "acceleration: one block, or a stack of two. SI units; angles in radians (displayed in degrees).</p>",
        '<h2 id="variables">Variables</h2>',
        "<table><tr><th>Name</th><th>Causality</th><th>Type</th><th>Unit</th><th>Start</th>"
        "<th>Valid range</th><th>Description</th></tr>",
        *_variable_rows(variables, enumerations, ranges or {}),
        "</table>",
    ]
    for page in PAGES:
        out.append(f'<hr><section id="{page[:-3]}">')
        out.append(_markdown((DOCS / page).read_text(encoding="utf-8")))
        out.append("</section>")
    out.append("</body></html>")
    return "\n".join(out) + "\n"
