"""No import cycle among the modules of host/inclino and emulator/inclino_emu,
and the layers import downwards only.

The graph is read from the source (tests/importgraph.py): every import
statement, the function-local ones included, so a lazy import cannot hide a
cycle.  A cycle is a strongly connected component of more than one module.

The layers (CONTRIBUTING.md, "Layers"), each importing only those below it:
  application  the command line (inclino.cli), the benchmarks, the emulated
               turntable and the demo: they run the emulated probe
  emulator     inclino_emu: the probe emulation (register-level chips, HAL,
               the firmware through cffi, flash, pseudo-terminal, control channel)
  library      every other module of inclino: the model library (world and
               sensor errors), engines, formats, link, procedures, calibration,
               diagnosis, survey
So the library never imports the emulator, the emulator imports only the
library, and the application imports the emulator only inside functions
(`inclino --help` and the library's users never load it).
"""
from __future__ import annotations

import shutil
from pathlib import Path

from importgraph import cycles, import_graph, modules_under

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = {"inclino": ROOT / "host" / "inclino", "inclino_emu": ROOT / "emulator" / "inclino_emu"}

APPLICATION = ("inclino.__main__", "inclino.entry", "inclino.cli", "inclino.benchmarks", "inclino.procedures.turntable_emulated",
               "inclino.procedures.demo", "inclino.procedures.demo_temp")
ORDER = {"library": 0, "emulator": 1, "application": 2}


def layer(module: str) -> str:
    if module == "inclino_emu" or module.startswith("inclino_emu."):
        return "emulator"
    if any(module == a or module.startswith(a + ".") for a in APPLICATION):
        return "application"
    return "library"


def upward_edges(graph) -> list[str]:
    """Imports from a layer to one above it."""
    return sorted(f"{a} ({layer(a)}) -> {b} ({layer(b)})" for a in graph for b in graph[a]
                  if ORDER[layer(b)] > ORDER[layer(a)])


def _graph(packages=PACKAGES, lazy=True):
    modules = {}
    for name, root in packages.items():
        modules.update(modules_under(root, name))
    return import_graph(modules, lazy)


def _report(cyc, graph):
    lines = []
    for c in cyc:
        members = set(c)
        edges = [f"{a} -> {b}" for a in c for b in sorted(graph[a] & members)]
        lines.append(" <-> ".join(c) + "\n    " + "\n    ".join(edges))
    return "\n".join(lines)


def test_no_import_cycle_among_modules():
    g = _graph()
    # the walker saw both trees, sub-packages included
    assert {"inclino.cli", "inclino.calib.joint", "inclino.diagnose.analysis", "inclino_emu.runner"} <= set(g)
    assert g["inclino.diagnose.core"] >= {"inclino.model.effects", "inclino.engines.reference"}
    found = cycles(g)
    assert not found, "import cycles (lazy imports included):\n" + _report(found, g)


def test_layers_import_downwards_only():
    g = _graph()
    # the rule sees real edges of every kind: application -> emulator and library, emulator -> library
    kinds = {(layer(a), layer(b)) for a in g for b in g[a]}
    assert {("application", "emulator"), ("application", "library"), ("emulator", "library")} <= kinds
    assert not upward_edges(g), "imports against the layers:\n  " + "\n  ".join(upward_edges(g))


def test_the_application_imports_the_emulator_only_lazily():
    eager = _graph(lazy=False)
    found = sorted(f"{a} -> {b}" for a in eager for b in eager[a] if layer(b) == "emulator" and layer(a) != "emulator")
    assert not found, "module-level imports of the emulator:\n  " + "\n  ".join(found)
    # the lazy-only walk still sees the module-level imports
    assert "inclino.formats.dataset" in eager["inclino.model.scenario"]


def test_lazy_and_relative_imports_are_edges(tmp_path):
    """The walker resolves `from . import x`, `from .x import y`, `from pkg
    import mod`, `import pkg.mod` and imports inside functions."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("NAME = 1\n")
    (pkg / "a.py").write_text("from . import b\n")
    (pkg / "b.py").write_text("def f():\n    from .sub.c import g\n    return g\n")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "c.py").write_text("import pkg.d\n\ndef g():\n    from pkg import NAME\n    return NAME\n")
    (pkg / "d.py").write_text("class K:\n    def m(self):\n        from .e import x\n")
    (pkg / "sub" / "f.py").write_text("from .. import e\n")
    (pkg / "e.py").write_text("")
    g = import_graph(modules_under(pkg, "pkg"))
    assert g["pkg.a"] == {"pkg.b"}
    assert g["pkg.b"] == {"pkg.sub.c"}
    assert g["pkg.sub.c"] == {"pkg.d", "pkg"}
    assert g["pkg.d"] == {"pkg.e"} and g["pkg.sub.f"] == {"pkg.e"}
    assert cycles(g) == []


def test_a_planted_cycle_is_reported(tmp_path):
    """Copy two small modules of the package that do not import each other,
    make each import the other lazily, and the walker names the pair; the
    untouched copy has no cycle."""
    src = PACKAGES["inclino"]
    pkg = tmp_path / "inclino"
    pkg.mkdir()
    for f in ("__init__.py", "errors.py", "fw_sources.py"):
        shutil.copy(src / f, pkg / f)
    clean = import_graph(modules_under(pkg, "inclino"))
    assert cycles(clean) == []
    with open(pkg / "errors.py", "a", encoding="utf-8") as f:
        f.write("\n\ndef _planted():\n    from inclino import fw_sources\n    return fw_sources\n")
    with open(pkg / "fw_sources.py", "a", encoding="utf-8") as f:
        f.write("\n\ndef _planted():\n    from .errors import DataError\n    return DataError\n")
    planted = import_graph(modules_under(pkg, "inclino"))
    assert cycles(planted) == [["inclino.errors", "inclino.fw_sources"]]


def test_a_planted_upward_import_fails_the_check(tmp_path):
    """A library module that imports the emulator, even inside a function, is
    an import against the layers; at module level in the application too."""
    src = PACKAGES["inclino"]
    host = tmp_path / "inclino"
    emu = tmp_path / "inclino_emu"
    (host / "cli").mkdir(parents=True)
    emu.mkdir()
    (host / "__init__.py").write_text("")
    shutil.copy(src / "errors.py", host / "errors.py")
    (host / "cli" / "__init__.py").write_text("def f():\n    from inclino_emu import runner\n")
    (emu / "__init__.py").write_text("")
    (emu / "runner.py").write_text("from inclino.errors import DataError\n")
    pkgs = {"inclino": host, "inclino_emu": emu}
    assert upward_edges(_graph(pkgs)) == []
    assert cycles(_graph(pkgs)) == []
    with open(host / "errors.py", "a", encoding="utf-8") as f:
        f.write("\n\ndef _planted():\n    import inclino_emu.runner\n")
    assert upward_edges(_graph(pkgs)) == ["inclino.errors (library) -> inclino_emu.runner (emulator)"]
    (host / "cli" / "__init__.py").write_text("from inclino_emu import runner\n")
    eager = _graph(pkgs, lazy=False)
    assert eager["inclino.cli"] == {"inclino_emu.runner"}
