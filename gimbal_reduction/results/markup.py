"""The presentation layer's one builder: Typst markup from the data the stages write, and the PDF.

Every report (``results.study.report``: the model report and one per scene;
``results.study.study_report``: the study's) is Typst source built from the JSON/CSV files of the
stages with these functions only, so the look of a table, a figure, a note, a verdict and a number
is defined once, here (the figures' own style is ``results.study.figures.STYLE``).

* ``s(text)``: any text as a Typst string literal (every character safe);
* ``sci(x)``: a number as Typst math (``1.23 times 10^(-4)``), "--" for NaN/None, or the cell
  text itself for a string (``decision.NOT_RESOLVABLE`` ...);
* ``table``, ``figure``, ``note``: numbered table and figure blocks, a grey "not available" box;
* ``verdict_marks``: a finding's per-rate verdicts as short words of the body font (no symbol
  glyph a fallback font would have to supply);
* ``page_setup``: the document head every report shares; ``compile_pdf``: source -> PDF.
"""
from __future__ import annotations

import json
import os
from importlib import metadata

import numpy as np

from gimbal_reduction.workflow import yamlfile
from gimbal_reduction.workflow.provenance import atomic_path, typst_metadata, versions

# A per-rate verdict in a table cell: a short word (the body font has it; "◐" came from a fallback).
MARKS = {"reproduced": "yes", "partly reproduced": "part", "not reproduced": "no",
         "not evaluated": "n.e.", "not resolvable": "n.r."}
MARKS_LEGEND = ("per rate (outer, middle, inner, platform): yes = reproduced or holds, part = partly, "
                "no = not reproduced, n.e. = not evaluated, n.r. = not resolvable (within the truth's "
                "own error)")


def read_json(path):
    with open(path) as f:
        return json.load(f)


def read_yaml(path):
    return yamlfile.load_file(path)        # a duplicate key is refused


def report_versions() -> dict:
    """The versions a report prints: the provenance's and those of the presentation tools."""
    out = versions()
    for mod in ("typst", "matplotlib", "numba", "jax"):
        try:
            out[mod] = metadata.version(mod)
        except metadata.PackageNotFoundError:
            pass
    return out


def s(text) -> str:
    """A Typst string literal inserted as text: #"..." (any characters are safe)."""
    text = "" if text is None else str(text)
    return '#"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def sci(x, digits=3) -> str:
    """A number as Typst math: 0.0123 -> $1.23 times 10^(-2)$; plain for 0.01 <= |x| < 1000; a
    string (a cell's word, e.g. "not resolvable") as text."""
    if isinstance(x, str):
        return s(x)
    if x is None or not np.isfinite(x):
        return "--"
    if x == 0:
        return "$0$"
    e = int(np.floor(np.log10(abs(x))))
    if -2 <= e < 3:
        return f"${x:.{digits}g}$"
    m = x / 10 ** e
    return f"${m:.{digits}g} times 10^({e})$"


def ms(x) -> str:
    """A time given in milliseconds, as text with its unit (3 significant digits): "1.31 ms",
    "30.1 s" from 1 s, "14.4 min" from 10 min, "2.31 h" from 10 h; "--" when unknown."""
    if x is None or not np.isfinite(x):
        return "--"
    for scale, unit in ((3.6e6, "h"), (6e4, "min"), (1e3, "s")):
        if x >= 10 * scale if unit != "s" else x >= scale:
            return s(f"{x / scale:.3g} {unit}")
    return s(f"{x:.3g} ms")


def table(header, rows, caption, label=None, columns=None, size="8pt") -> str:
    """A numbered Typst table figure; header: list of markup, rows: list of lists of markup."""
    ncol = len(header)
    cols = columns or f"{ncol}"
    cells = ", ".join(f"[{c}]" for r in rows for c in r)
    head = ", ".join(f"[*{h}*]" for h in header)
    lab = f" <{label}>" if label else ""
    return (f"#figure(text(size: {size}, table(columns: {cols}, align: left, inset: 4pt, "
            f"stroke: 0.4pt + luma(160), table.header({head}), {cells})), caption: [{caption}], "
            f"kind: table){lab}\n\n")


def figure(path, caption, root, width="100%", label=None) -> str:
    lab = f" <{label}>" if label else ""
    rel = "/" + os.path.relpath(os.path.abspath(path), root).replace(os.sep, "/")
    return f'#figure(image("{rel}", width: {width}), caption: [{caption}]){lab}\n\n'


def note(text) -> str:
    return f"#block(fill: luma(235), inset: 6pt, radius: 3pt, width: 100%)[_Not available:_ {text}]\n\n"


def verdict_marks(per_rate: dict, rates=("outer", "middle", "inner", "platform")) -> str:
    """A finding's per-rate verdicts as one cell text: "yes yes no n.r." (``MARKS``)."""
    return " ".join(MARKS.get((per_rate or {}).get(r, "not evaluated"), "?") for r in rates)


def page_setup(title: str, subtitle: str, outline_depth: int | None = 2) -> str:
    """The head of every report: A4, numbered pages, numbered headings, table captions on top,
    a centred title block and (unless None) the outline."""
    return ('#set document(title: ' + s(title)[1:] + ')\n'
            '#set page(paper: "a4", margin: 2cm, numbering: "1")\n'
            '#set text(size: 10pt)\n#set par(justify: true)\n'
            '#set heading(numbering: "1.1")\n'
            '#show figure.where(kind: table): set figure.caption(position: top)\n'
            '#show table: set par(justify: false)\n'
            f'#align(center)[#text(size: 16pt, weight: "bold")[{s(title)}] \\ '
            f'#text(size: 10pt)[{subtitle}]]\n\n'
            + ("" if outline_depth is None else f"#outline(depth: {outline_depth})\n\n"))


def compile_pdf(source: str, out_pdf: str, root: str, record: dict | None = None) -> str:
    """Write ``source`` beside ``out_pdf`` (NAME.typ) and compile it atomically, with the
    provenance record (default ``gimbal_reduction.workflow.provenance.provenance()``) in the PDF's
    ``/Subject``."""
    import typst  # optional heavy dependency (the Typst compiler): imported only to compile the PDF
    os.makedirs(os.path.dirname(os.path.abspath(out_pdf)), exist_ok=True)
    typ = os.path.splitext(os.path.abspath(out_pdf))[0] + ".typ"
    with open(typ, "w") as f:
        f.write(typst_metadata(record) + source)
    with atomic_path(out_pdf) as tmp:
        typst.compile(typ, output=str(tmp), root=root)
    return out_pdf
