"""The package layout: stages import only earlier stages, no import cycles, old paths alias.

The import graph is read from the source with ``ast`` (every ``import``, including those
inside functions, which the code uses to keep start-up light), so the rules hold for code
paths a test run may never take. docs/architecture.md states the same order.
"""

import ast
import importlib
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("vidtrack", "fits", "calibration")

#: vidtrack's stages, lowest first: a module may import its own stage and lower ranks only.
STAGE_RANK = {
    "vidtrack": 0, "vidtrack._moved": 0, "vidtrack.errors": 0, "vidtrack._atomic": 0,
    "vidtrack._progress": 0, "vidtrack._lazy": 0,
    "vidtrack.scene": 1,
    "vidtrack.footage": 2,
    "vidtrack.track": 3,
    "vidtrack.world": 4,
    "vidtrack.report": 5,
    "vidtrack.run": 6,
    "vidtrack.experiment": 7, "vidtrack.synth": 7, "vidtrack.predict": 7,
    "vidtrack.scene_template": 7,
    "vidtrack.bench": 8, "vidtrack.design": 8, "vidtrack.rehearsal": 8, "vidtrack.view": 8,
    "vidtrack.cli": 9, "vidtrack.__main__": 10,
}


def _module_name(path):
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_module(name):
    base = REPO.joinpath(*name.split("."))
    return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()


def _imports(path, name):
    """Modules of this project that ``path`` imports (a package counts when its names are used)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            subs = [f"{target}.{a.name}" for a in node.names]
            found.update(s for s in subs if _is_module(s))
            if not all(_is_module(s) for s in subs):
                found.add(target)
    return {m for m in found if m.split(".")[0] in PACKAGES and m != name}


@pytest.fixture(scope="module")
def graph():
    edges = {}
    for top in PACKAGES:
        for path in sorted((REPO / top).rglob("*.py")):
            name = _module_name(path)
            edges[name] = _imports(path, name)
    return edges


def _stage(name):
    best = max((k for k in STAGE_RANK if name == k or name.startswith(k + ".")), key=len,
               default=None)
    assert best is not None, f"{name} belongs to no stage in STAGE_RANK: add it there and to " \
                             "docs/architecture.md"
    return best


def test_graph_is_read(graph):
    # the reader must see the real structure, or every rule below passes vacuously
    assert len(graph) > 60
    assert "vidtrack.track.tracker" in graph["vidtrack.world.orthogonal"]
    assert "fits.lsq" in graph["vidtrack.run.pipeline"]


def test_numbers_and_pixels_never_import_the_app(graph):
    bad = [(m, d) for m, deps in graph.items() for d in deps
           if (m.startswith("fits") and not d.startswith("fits"))
           or (m.startswith("calibration") and not d.startswith("calibration"))]
    assert bad == []


#: What the package root's own imports may load besides the shared utilities: the
#: tracking stage's package, made callable (``from vidtrack import track``); its
#: ``__init__`` imports nothing.
ROOT_LOADS = {"vidtrack.track"}
#: The root's names that the stages may import from it (rank 0: no stage's code).
ROOT_OWN = {"__version__", "LOGGERS", "VidtrackError", "_moved", "_lazy", "_atomic",
            "_progress", "errors"}


def _root_api():
    """The package root's table of public names, loaded on first use: {module: names}."""
    tree = ast.parse((REPO / "vidtrack" / "__init__.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and [t.id for t in node.targets] == ["_EXPORTS"]:
            return ast.literal_eval(node.value)
    raise AssertionError("vidtrack/__init__.py has no _EXPORTS table")


def test_vidtrack_stages_import_only_earlier_stages(graph):
    bad = []
    for m, deps in graph.items():
        if not m.startswith("vidtrack"):
            continue
        if m == "vidtrack":          # the root: its own imports, checked below
            deps = deps - ROOT_LOADS
        here = _stage(m)
        for d in deps:
            if not d.startswith("vidtrack"):
                continue
            there = _stage(d)
            # rank 0 is the shared utilities, which any stage (and each other) may use
            if there != here and STAGE_RANK[there] and STAGE_RANK[there] >= STAGE_RANK[here]:
                bad.append(f"{m} ({here}) imports {d} ({there})")
    assert not bad, "\n".join(bad)


def test_a_rule_breach_is_caught(graph):
    # the check above must fail on a breach: a report importing the run would be one
    fake = dict(graph)
    fake["vidtrack.report.run_page"] = graph["vidtrack.report.run_page"] | {
        "vidtrack.run.pipeline"}
    with pytest.raises(AssertionError, match="run_page"):
        test_vidtrack_stages_import_only_earlier_stages(fake)
    with pytest.raises(AssertionError, match="fits.lsq"):
        test_no_import_cycles({"fits.lsq": {"fits.errmodel"}, "fits.errmodel": {"fits.lsq"}})


def test_no_import_cycles(graph):
    # a submodule importing its package counts (the package's __init__ runs first)
    state, cycles = {}, []

    def visit(node, stack):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == "open":
                cycles.append(" -> ".join(stack[stack.index(nxt):] + [nxt]))
            elif nxt not in state:
                visit(nxt, stack)
        stack.pop()
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node, [])
    assert cycles == [], cycles


def test_the_root_api_is_loaded_on_first_use_and_no_stage_imports_it():
    # the root re-exports the public calls of later stages (its _EXPORTS, PEP 562): it
    # names them but loads none until asked, so importing vidtrack stays cheap and no
    # cycle can form at import time, as long as no stage takes those names from the root
    import subprocess

    code = ("import sys, vidtrack\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('vidtrack', 'fits', 'calibration', 'numpy', 'pandas', 'cv2')))\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=REPO, timeout=120)
    assert res.returncode == 0, res.stderr
    loaded = set(ast.literal_eval(res.stdout.strip()))
    assert loaded == {"vidtrack", "vidtrack._lazy", "vidtrack._moved"} | ROOT_LOADS
    exported = {n for names in _root_api().values() for n in names}
    bad = []
    for path in sorted((REPO / "vidtrack").rglob("*.py")):
        if path == REPO / "vidtrack" / "__init__.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and node.module == "vidtrack" and not node.level:
                bad += [f"{path.relative_to(REPO)}: {a.name}" for a in node.names
                        if a.name in exported or a.name not in ROOT_OWN]
    assert bad == [], "stages must import these from their own modules:\n" + "\n".join(bad)


def test_the_root_api_resolves_to_the_stages_objects():
    import inspect

    import vidtrack
    from vidtrack.track.tracker import track

    for module, names in _root_api().items():
        assert _is_module(module), module
        for name in names:
            assert getattr(vidtrack, name) is getattr(importlib.import_module(module), name)
    assert set(vidtrack.__all__) >= {"open_source", "track", "fit_run", "read_tracks"}
    # `track` is the package (its modules import as before), called as the tracker
    assert vidtrack.track is importlib.import_module("vidtrack.track")
    assert importlib.import_module("vidtrack.track.tracker").track is track
    assert inspect.signature(vidtrack.track) == inspect.signature(track)
    with pytest.raises(TypeError, match="source"):
        vidtrack.track()


@pytest.mark.parametrize("old", sorted(importlib.import_module("vidtrack._moved").MOVED))
def test_old_import_paths_still_work_with_a_warning(old):
    from vidtrack._moved import MOVED

    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=MOVED[old].replace(".", r"\.")):
        module = importlib.import_module(old)
    assert module is importlib.import_module(MOVED[old])
    # every target really exists (a stale table entry would alias to nothing)
    assert _is_module(MOVED[old])


def test_moved_table_covers_every_public_module_of_the_last_release():
    # the flat 0.1 modules that user code and docs imported (private ones are not aliased)
    released = {"frames", "cine", "timebase", "background", "tracker", "stereo", "pipeline",
                "tracks_io", "fit_record", "run_report", "anova_report"}
    from vidtrack._moved import MOVED

    assert {m.removeprefix("vidtrack.") for m in MOVED} == released
    for name in released:
        assert not _is_module(f"vidtrack.{name}"), f"vidtrack.{name} exists and is aliased"
