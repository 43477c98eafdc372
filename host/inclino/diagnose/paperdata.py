"""The papers' measured tables, transcribed: one CSV data file per table in
papers_data/, each opening with `# source=` and `# notes=` lines.

The transcriptions are from the plain-text copies in the project's seeds
(Ren 2014: Sensors 14(6):9256-9270 as published; Li 2021: Drilling
Engineering 48(5):76-82).  Every number is as printed; what had to be read
rather than copied is said in the table's notes.  `table(name)` parses one,
`write_tables(dir)` copies them out.
"""
from __future__ import annotations

import csv
import io
import os
from importlib import resources

from inclino.formats import safeio

NAMES = ("li2021_table2", "li2021_table4", "li2021_table5", "ren2014_table1", "ren2014_table2")


def _load(name: str) -> dict:
    text = resources.files("inclino.diagnose").joinpath("papers_data", f"{name}.csv").read_text("utf-8")
    meta, body = {}, []
    for line in text.splitlines(keepends=True):
        if line.startswith("# ") and "=" in line and not body:
            k, v = line[2:].split("=", 1)
            meta[k.strip()] = v.strip()
        else:
            body.append(line)
    return {"source": meta.get("source", ""), "notes": meta.get("notes", ""), "csv": "".join(body)}


class _Tables(dict):
    def __missing__(self, name):
        if name not in NAMES:
            raise KeyError(name)
        self[name] = _load(name)
        return self[name]

    def items(self):
        return [(n, self[n]) for n in NAMES]


TABLES = _Tables()


def table(name: str):
    """(rows as a list of dicts with floats where the cell is a number,
    source, notes)."""
    t = TABLES[name]
    rows = []
    for r in csv.DictReader(io.StringIO(t["csv"])):
        out = {}
        for k, v in r.items():
            try:
                out[k] = float(v)
            except ValueError:
                out[k] = v
        rows.append(out)
    return rows, t["source"], t["notes"]


def write_tables(outdir: str) -> list:
    os.makedirs(outdir, exist_ok=True)
    paths = []
    for name, t in TABLES.items():
        p = os.path.join(outdir, f"{name}.csv")
        safeio.write_output(p, f"# source={t['source']}\n# notes={t['notes']}\n{t['csv']}")
        paths.append(p)
    return paths
