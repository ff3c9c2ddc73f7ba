"""Hostile inputs: ONE table, every row the real command line in a subprocess.

Add a case by adding a row to ``CASES``, not a test. A row is a :class:`Case`:

- ``id``: what the case is (``command-what``);
- ``setup(w)``: builds the inputs in the empty work folder ``w`` (helpers below:
  :func:`files`, :func:`copied`, :func:`chen_table`, :func:`run42_copy`,
  :func:`synthetic_run`, :func:`earlier_export`, :func:`unwritable_folder`, combined with
  :func:`both`); it may return a dict of extra placeholders for ``args``;
- ``args``: the command line after ``vidtrack``, run with ``w`` as the working folder;
  ``{repo}``, ``{w}`` and the setup's placeholders are filled in (``"{ro}/out.toml"``);
- ``code``: the exit code expected (2: bad input, 0: done);
- ``stderr``: a regex the message must match (``re.search``): for exit 2 the single
  line on stderr, for exit 0 anywhere on stderr (omit it for no check);
- ``mutable``: glob patterns (relative to ``w``) of files a successful run may replace
  or remove (``synth --force`` over its own run, a re-extraction of frames);
- ``check(w, res)``: further assertions after the run.

What every row asserts, on top of that: the exit code; no ``Traceback`` on stderr; for
exit 2 exactly one non-empty line on stderr (usage errors included) and the work folder exactly as
the setup left it: no file changed, removed or added, no partial output, no temporary
left behind (every file hashed before and after); for exit 0 every file the setup made
is unchanged unless ``mutable`` names it.

Rows for ``fit`` and ``report`` (or any other command) go in the same table:
:func:`run42_copy` copies the sample run ``datasets/run42`` into the work folder.
Keep each row quick (small ``--size``/``--flight-s`` for synth, no fitting): the whole
module runs in well under a minute.
"""

import csv
import fnmatch
import hashlib
import os
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

from conftest import run_vidtrack

REPO = Path(__file__).resolve().parents[1]
PUBLISHED = REPO / "datasets" / "published"
CHEN = PUBLISHED / "chen2018_table2_ccd.csv"
RUN42 = REPO / "datasets" / "run42"
MARKER = "vidtrack-synth.toml"

#: Small and quick synth options (a 64x48 run of 18 frames per view renders in 0.2 s).
TINY = ("--size", "64x48", "--flight-s", "0.005", "--exposure-samples", "1", "-q")
#: The Chen 2018 factors in natural units (the table holds their coded columns A, B, C).
FACTORS = ("--factor", "A=n_rpm:550:100", "--factor", "B=blade_angle_deg:0:5",
           "--factor", "C=speed_kmh:7.2:1.8")
SETTING = ("--n-rpm", "450", "--blade-angle-deg", "-10", "--speed-kmh", "6")
RULER = ("--length-m", "0.5", "--from", "80,482", "--to", "205,482")


@dataclass(frozen=True)
class Case:
    id: str
    args: tuple
    setup: object = None
    code: int = 2
    stderr: str = ""
    mutable: tuple = ()
    check: object = None


# ------------------------------------------------------------------ setup helpers

def files(contents):
    """A setup writing files: ``files({"run/scene.toml": "schema = 1\n"})`` (text as
    UTF-8, bytes as they are; folders made as needed)."""
    def setup(w):
        for name, content in contents.items():
            path = w / name
            path.parent.mkdir(parents=True, exist_ok=True)
            if isinstance(content, bytes):
                path.write_bytes(content)
            else:
                path.write_text(content, encoding="utf-8")
    return setup


def copied(source, name=None):
    """A setup copying the file ``source`` into the work folder (as ``name``)."""
    def setup(w):
        shutil.copy(source, w / (name or Path(source).name))
    return setup


def both(*setups):
    """Several setups in turn; their placeholders merged."""
    def setup(w):
        out = {}
        for s in setups:
            made = s(w)
            if isinstance(made, dict):
                out.update(made)
        return out
    return setup


def chen_table(name="t.csv", edit=None):
    """Chen 2018 Table 2 copied to ``name``; ``edit(rows)`` changes the rows (lists of
    cells, the header first) in place before they are written."""
    def setup(w):
        with open(CHEN, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
        if edit is not None:
            edit(rows)
        with open(w / name, "w", newline="", encoding="utf-8") as f:
            csv.writer(f, lineterminator="\n").writerows(rows)
    return setup


def cell(row, column, value):
    """An edit of :func:`chen_table`: data row ``row`` (1-based), ``column`` -> value."""
    def edit(rows):
        rows[row][rows[0].index(column)] = value
    return edit


def run42_copy(name="run", drop=("vidtrack",), scene=None):
    """A setup copying ``datasets/run42`` to ``w/name`` without ``drop`` (its outputs by
    default); ``scene(text)`` returns an edited scene.toml. For ``fit``/``report`` rows."""
    def setup(w):
        shutil.copytree(RUN42, w / name, ignore=shutil.ignore_patterns(*drop))
        if scene is not None:
            path = w / name / "scene.toml"
            path.write_text(scene(path.read_text(encoding="utf-8")), encoding="utf-8")
    return setup


def synthetic_run(name="run", *options):
    """A setup rendering a tiny synthetic run (with its marker) into ``w/name``."""
    def setup(w):
        res = run_vidtrack("synth", w / name, *TINY, *options)
        assert res.returncode == 0, res.stderr
    return setup


def earlier_export(name="out", frames=range(10), unlisted=("frame_000099.png",),
                   listed_extra=()):
    """A folder ``name`` holding an earlier ``vidtrack frames`` export: dummy images
    listed by its frames.csv, ``unlisted`` images it does not list, and notes.txt."""
    def setup(w):
        out = w / name
        out.mkdir()
        rows = ["frame,t_s,file"]
        for i in frames:
            (out / f"frame_{i:06d}.png").write_bytes(b"old")
            rows.append(f"{i},{i / 1200!r},frame_{i:06d}.png")
        rows += [f"0,0.0,{extra}" for extra in listed_extra]
        for extra in unlisted:
            (out / extra).write_bytes(b"not from frames.csv")
        (out / "notes.txt").write_text("mine")
        (out / "frames.csv").write_text("\n".join(rows) + "\n")
    return setup


def _can_write(folder):
    try:
        probe = Path(folder) / ".probe"
        probe.write_bytes(b"")
        probe.unlink()
        return True
    except OSError:
        return False


def unwritable_folder(w):
    """``{ro}``: a folder this process cannot write to (mode 555; as root, which ignores
    modes, a kernel folder such as /sys); skips when there is none."""
    ro = w / "readonly"
    ro.mkdir()
    ro.chmod(0o555)
    if not _can_write(ro):
        return {"ro": str(ro)}
    ro.chmod(0o755)
    ro.rmdir()
    for candidate in ("/sys", "/proc/sys"):
        if Path(candidate).is_dir() and not _can_write(candidate):
            return {"ro": candidate}
    pytest.skip("no folder this process cannot write to (root on a writable system)")


def scene_value(key, value, view="front"):
    """A scene.toml edit for :func:`run42_copy`: ``key = value`` in ``[views.VIEW]``."""
    def edit(text):
        head = f"[views.{view}]\n"
        assert head in text
        return text.replace(head, f"{head}{key} = {value}\n", 1)
    return edit


def scene_scale(value, view="front"):
    """A scene.toml edit: the view's ruler replaced by ``m_per_px = value``."""
    def edit(text):
        text = re.sub(rf"\[views\.{view}\.ruler\]\n(?:[a-z_]+ = .*\n)+", "", text)
        return scene_value("m_per_px", value, view)(text)
    return edit


# ------------------------------------------------------------------ post-checks

def listing(folder, *names):
    def check(w, res):
        assert sorted(p.name for p in (w / folder).iterdir()) == sorted(names)
    return check


def all_of(*checks):
    def check(w, res):
        for c in checks:
            c(w, res)
    return check


def unchanged(path, content):
    def check(w, res):
        assert (w / path).read_bytes() == content
    return check


def marker_lists(folder, *names):
    def check(w, res):
        import tomllib

        data = tomllib.loads((w / folder / MARKER).read_text())
        assert data["generator"] == "vidtrack synth" and data["vidtrack_version"]
        assert sorted(data["files"]) == sorted([*names, MARKER])
    return check


def stdout_has(pattern):
    def check(w, res):
        assert re.search(pattern, res.stdout), res.stdout[-2000:]
    return check


# ------------------------------------------------------------------ the table

def _dup_rows(rows):
    rows += rows[1:]


def _dup_run_id(rows):
    rows[5][0] = rows[4][0]


def _dup_column(rows):
    rows[0][5] = "k1"


def _ragged(rows):
    rows[3].append("9")


CASES = [
    # ---- synth: never writes over footage it did not render (issue item 1) ----------
    Case("synth-force-over-a-real-run",
         setup=run42_copy(drop=("vidtrack", "truth.json", MARKER)),
         args=("synth", "run", "--force", "--size", "160x120", "--flight-s", "0.1", "-q"),
         stderr=r"run: the folder is not empty \(holds front\.avi, scene\.toml, top\.avi\) "
                r"and has no vidtrack-synth\.toml.*expected"),
    Case("synth-force-over-a-real-run-with-throws",
         setup=files({"run/scene.toml": "schema = 1\n", "run/throws/01/front.avi": b"footage",
                     "run/throws/notes.txt": "mine"}),
         args=("synth", "run", "--force", *TINY, "--throws", "2"),
         stderr=r"not empty .*no vidtrack-synth\.toml"),
    Case("synth-real-run-without-force", setup=run42_copy(drop=("vidtrack", MARKER)),
         args=("synth", "run", *TINY), stderr=r"not empty .*no vidtrack-synth\.toml"),
    Case("synth-own-run-without-force", setup=synthetic_run("run"),
         args=("synth", "run", *TINY), stderr=r"not empty .*pass --force"),
    Case("synth-force-replaces-only-its-own-files",
         setup=both(synthetic_run("run"), files({"run/notes.txt": "mine"})),
         args=("synth", "run", "--force", *TINY, "--views", "top", "--format", "png"),
         code=0, mutable=("run/*",),
         check=all_of(listing("run", "notes.txt", "scene.toml", "top", "truth.json", MARKER),
                      unchanged("run/notes.txt", b"mine"),
                      marker_lists("run", "scene.toml", "top", "truth.json"))),
    Case("synth-force-keeps-an-entry-its-marker-does-not-list",
         setup=both(synthetic_run("run", "--views", "front"), files({"run/top/x.png": "mine"})),
         args=("synth", "run", "--force", *TINY, "--views", "top", "--format", "png"),
         stderr=r"run/top: exists, and the marker vidtrack-synth\.toml does not list it"),
    Case("synth-force-re-renders-datasets-run42", setup=run42_copy(),
         args=("synth", "run", "--force", *TINY), code=0, mutable=("run/*",),
         check=marker_lists("run", "front.avi", "top.avi", "scene.toml", "truth.json")),
    Case("synth-marker-not-synths",
         setup=files({"run/front.avi": b"x", f"run/{MARKER}": "junk = [\n"}),
         args=("synth", "run", "--force", *TINY),
         stderr=r"vidtrack-synth\.toml: the marker of a synthetic run cannot be read"),
    Case("synth-out-is-a-file", setup=files({"afile.txt": "x"}), args=("synth", "afile.txt", *TINY),
         stderr=r"afile\.txt: exists and is not a folder"),
    Case("synth-parent-is-a-file", setup=files({"afile.txt": "x"}),
         args=("synth", "afile.txt/run", *TINY), stderr=r"afile\.txt is a file, not a folder"),
    Case("synth-out-in-unwritable-folder", setup=unwritable_folder,
         args=("synth", "{ro}/run", *TINY), stderr=r"cannot write in .*expected a folder"),
    # ---- synth: sizes, counts and numbers bounded (items 2, 8) -----------------------
    Case("synth-frames-1e11", args=("synth", "run", "--frames", "100000000000", "-q"),
         stderr=r"frames must be <= 100000, got 100000000000"),
    Case("synth-fps-1e300", args=("synth", "run", "--fps", "1e300", "--flight-s", "1e-300"),
         stderr=r"fps must be between 0\.1 and 1e\+07 frames/s, got 1e\+300"),
    Case("synth-fps-nan", args=("synth", "run", "--fps", "nan"), stderr=r"fps must be finite"),
    Case("synth-throws-negative", args=("synth", "run", "--throws", "-1"),
         stderr=r"throws must be >= 1, got -1"),
    Case("synth-cp-1e300", args=("synth", "run", "--cp", "1e300", *TINY),
         stderr=r"cp_s_per_m must be <= 10"),
    Case("synth-full-well-1e300", args=("synth", "run", "--full-well-e", "1e300", *TINY),
         stderr=r"full_well_e must be <= 1000000000\.0"),
    Case("synth-spin-axis-1e300", args=("synth", "run", "--spin-axis", "1e300,0,0", *TINY),
         stderr=r"spin_axis must be a direction .* within \+-1e6"),
    Case("synth-m-per-px-1e-300", args=("synth", "run", "--m-per-px", "1e-300", *TINY),
         stderr=r"m_per_px must be >= 1e-09"),

    # ---- predict: sizes and settings bounded (items 2, 8) ----------------------------
    Case("predict-points-1e9", args=("predict", *SETTING, "--points", "1000000000"),
         stderr=r"--points must be between 2 and 1000000 samples, got 1000000000"),
    Case("predict-points-negative", args=("predict", *SETTING, "--points", "-5"),
         stderr=r"--points must be between 2 and 1000000"),
    Case("predict-n-rpm-1e300", args=("predict", "--n-rpm", "1e300", *SETTING[2:]),
         stderr=r"--n-rpm must be between 1 and 100000 r/min, got 1e\+300"),
    Case("predict-n-rpm-1e-300", args=("predict", "--n-rpm", "1e-300", *SETTING[2:]),
         stderr=r"--n-rpm must be between 1 and 100000 r/min, got 1e-300"),
    Case("predict-n-rpm-nan", args=("predict", "--n-rpm", "nan", *SETTING[2:]),
         stderr=r"--n-rpm must be finite"),
    Case("predict-speed-1e300", args=("predict", *SETTING[:4], "--speed-kmh", "1e300"),
         stderr=r"--speed-kmh must be between 0 and 100 km/h"),
    Case("predict-phase-1e300", args=("predict", *SETTING, "--phase-deg", "1e300"),
         stderr=r"--phase-deg must be between -360 and 360 deg"),
    Case("predict-cp-from-a-feather", args=("predict", *SETTING, "--straw-mass-kg", "1e-6"),
         stderr=r"--straw-mass-kg 1e-06 gives Cp = 32\.5\d* s/m; expected Cp <= 10"),
    Case("predict-plot-over-its-regression", setup=files({"r.json": "{}"}),
         args=("predict", *SETTING, "--regression", "r.json", "--plot", "r.json"),
         stderr=r"--plot r\.json: is the input r\.json; inputs are never overwritten"),
    Case("predict-plot-is-a-folder", setup=files({"plots/keep.txt": "x"}),
         args=("predict", *SETTING, "--plot", "plots"), stderr=r"--plot plots: is a folder"),
    Case("predict-plot-parent-is-a-file", setup=files({"afile.txt": "x"}),
         args=("predict", *SETTING, "--plot", "afile.txt/p.png"),
         stderr=r"afile\.txt is a file, not a folder"),
    Case("predict-plot-in-unwritable-folder", setup=unwritable_folder,
         args=("predict", *SETTING, "--plot", "{ro}/p.png"), stderr=r"cannot write in"),

    # ---- anova: numbers that overflow, duplicates, the report over an input ----------
    Case("anova-cell-1e300", setup=chen_table(edit=cell(3, "k1", "1e300")),
         args=("anova", "t.csv", "--response", "k1"),
         stderr=r"t\.csv: row 3 \(line 4\), column 'k1': '1e300' is too large; expected a "
                r"number within \+-1e\+150"),
    Case("anova-cell-1e150-is-computed", setup=chen_table(edit=cell(3, "k1", "1e150")),
         args=("anova", "t.csv", "--response", "k1"), code=0, check=stdout_has("Response k1")),
    Case("anova-coded-factor-1e100", setup=chen_table(edit=cell(3, "A", "1e100")),
         args=("anova", "t.csv", "--response", "k1"),
         stderr=r"row 3, factor A: the value 1e\+100 is beyond \+-1e\+12"),
    Case("anova-factor-step-1e-300", setup=chen_table(),
         args=("anova", "t.csv", "--response", "k1", "--factor", "A=n_rpm:550:1e-300",
               *FACTORS[2:]),
         stderr=r"factor A: step 1e-300 is outside 1e-12 to 1e\+12"),
    Case("anova-duplicated-rows", setup=chen_table(edit=_dup_rows),
         args=("anova", "t.csv", "--response", "k1"),
         stderr=r"row 33 \(line 34\) repeats row 1 \(line 2\) in every column.*"
                r"--allow-duplicate-rows"),
    Case("anova-duplicated-rows-allowed", setup=chen_table(edit=lambda r: r.append(r[1])),
         args=("anova", "t.csv", "--response", "k1", "--allow-duplicate-rows"), code=0,
         check=stdout_has(r"Response k1")),
    Case("anova-duplicate-run-id", setup=chen_table(edit=_dup_run_id),
         args=("anova", "t.csv", "--response", "k1"),
         stderr=r"rows 4 and 5 \(lines 5 and 6\) have the same run '4'; expected each run once"),
    Case("anova-duplicate-column-name", setup=chen_table(edit=_dup_column),
         args=("anova", "t.csv", "--response", "k1"),
         stderr=r"names column 'k1' twice \(columns 5 and 6\)"),
    Case("anova-report-over-its-table", setup=chen_table(),
         args=("anova", "t.csv", "--response", "k1", "--report", "./t.csv"),
         stderr=r"--report \./t\.csv: is the input t\.csv; inputs are never overwritten"),
    Case("anova-report-over-a-compared-table",
         setup=both(chen_table(), chen_table("p.csv")),
         args=("anova", "t.csv", "--response", "k1", "--compare", "p.csv", "--report", "p.csv"),
         stderr=r"--report p\.csv: is the input p\.csv"),
    Case("anova-report-through-a-link-to-its-table",
         setup=both(chen_table(), lambda w: os.symlink("t.csv", w / "r.html")),
         args=("anova", "t.csv", "--response", "k1", "--report", "r.html"),
         stderr=r"--report r\.html: is the input t\.csv"),
    Case("anova-report-in-unwritable-folder", setup=both(chen_table(), unwritable_folder),
         args=("anova", "t.csv", "--response", "k1", "--report", "{ro}/r.html"),
         stderr=r"--report .*/r\.html: cannot write in"),
    Case("anova-empty-file", setup=files({"t.csv": ""}),
         args=("anova", "t.csv", "--response", "k1"),
         stderr=r"t\.csv: the file is empty; expected a CSV table with a header row"),
    Case("anova-header-only", setup=files({"t.csv": "run,A,B,C,k1\n"}),
         args=("anova", "t.csv", "--response", "k1"), stderr=r"header but no rows"),
    Case("anova-not-utf8", setup=files({"t.csv": b"run,A,k1\n1,0,\xff\xfe\n"}),
         args=("anova", "t.csv", "--response", "k1"), stderr=r"not a readable CSV table"),
    Case("anova-ragged-row", setup=chen_table(edit=_ragged),
         args=("anova", "t.csv", "--response", "k1"), stderr=r"not a readable CSV table"),
    Case("anova-alpha-nan", setup=chen_table(), args=("anova", "t.csv", "--response", "k1",
                                                      "--alpha", "nan"),
         stderr=r"alpha must be between 0 and 1, got nan"),

    # ---- frames: no stale images, outputs checked first (item 12) --------------------
    Case("frames-removes-the-earlier-extractions-images",
         setup=both(copied(RUN42 / "front.avi"),
                    earlier_export("out")),
         args=("frames", "front.avi", "out", "--fps", "1200", "--range", "5:8", "-q"), code=0,
         mutable=("out/*",),
         check=listing("out", "frame_000005.png", "frame_000006.png", "frame_000007.png",
                       "frame_000099.png", "frames.csv", "notes.txt")),
    Case("frames-earlier-csv-names-a-file-outside",
         setup=both(copied(RUN42 / "front.avi"),
                    files({"precious.png": b"keep"}),
                    earlier_export("out", listed_extra=("../precious.png",))),
         args=("frames", "front.avi", "out", "--fps", "1200", "--range", "0:2", "-q"), code=0,
         mutable=("out/*",), check=unchanged("precious.png", b"keep")),
    Case("frames-fps-1e300", args=("frames", "{repo}/datasets/run42/front.avi", "out",
                                   "--fps", "1e300"),
         stderr=r"fps must be between 0\.1 and 1e\+07 frames/s .*got 1e\+300"),
    Case("frames-fps-1e-300", args=("frames", "{repo}/datasets/run42/front.avi", "out",
                                    "--fps", "1e-300"), stderr=r"fps must be between 0\.1"),
    Case("frames-every-negative", args=("frames", "{repo}/datasets/run42/front.avi", "out",
                                        "--every", "-3"), stderr=r"--every must be >= 1"),
    Case("frames-channel-not-a-channel",
         args=("frames", "{repo}/datasets/run42/front.avi", "out", "--channel", "purple"),
         stderr=r"channel must be one of luma, red, green, blue, chroma, auto, got 'purple'"),
    Case("frames-colour-channel-of-grey-footage",
         args=("frames", "{repo}/datasets/run42/front.avi", "out", "--channel", "red"),
         stderr=r"front\.avi: channel \"red\" takes the red channel of colour footage, but "
                r"this video is grey"),
    Case("frames-out-is-its-source", setup=copied(RUN42 / "front.avi"),
         args=("frames", "front.avi", "front.avi", "--fps", "1200"),
         stderr=r"front\.avi: is the input front\.avi"),
    Case("frames-out-parent-is-a-file", setup=files({"afile.txt": "x"}),
         args=("frames", "{repo}/datasets/run42/front.avi", "afile.txt/out", "--fps", "1200"),
         stderr=r"afile\.txt is a file, not a folder"),
    Case("frames-out-in-unwritable-folder", setup=unwritable_folder,
         args=("frames", "{repo}/datasets/run42/front.avi", "{ro}/out", "--fps", "1200"),
         stderr=r"cannot write in"),

    # ---- calibrate: finite scales, outputs checked first (items 8, 12) ---------------
    Case("calibrate-ruler-scale-overflows",
         args=("calibrate", "ruler", "--length-m", "1e300", "--from", "0,0", "--to", "1e-10,0",
               "-o", "c.toml"),
         stderr=r"= inf m per pixel; expected a scale between 1e-09 and 1000 m per pixel"),
    Case("calibrate-ruler-span-overflows",
         args=("calibrate", "ruler", "--length-m", "1", "--from=-1e308,0", "--to", "1e308,0",
               "-o", "c.toml"), stderr=r"span .* overflows"),
    Case("calibrate-output-is-a-folder", setup=files({"cal.toml/keep.txt": "x"}),
         args=("calibrate", "ruler", *RULER, "-o", "cal.toml"), stderr=r"is a folder"),
    Case("calibrate-output-parent-is-a-file", setup=files({"afile.txt": "x"}),
         args=("calibrate", "ruler", *RULER, "-o", "afile.txt/c.toml"),
         stderr=r"-o afile\.txt/c\.toml: .*afile\.txt is a file, not a folder"),
    Case("calibrate-output-in-unwritable-folder", setup=unwritable_folder,
         args=("calibrate", "ruler", *RULER, "-o", "{ro}/c.toml"), stderr=r"cannot write in"),
    Case("calibrate-output-is-an-input", setup=files({"board.toml": b"not an image"}),
         args=("calibrate", "checkerboard", "board.toml", "--pattern", "9x6", "--square-m",
               "0.025", "-o", "board.toml"),
         stderr=r"-o board\.toml: is the input board\.toml"),
    Case("calibrate-length-nan", args=("calibrate", "ruler", "--length-m", "nan", *RULER[2:]),
         stderr=r"--length-m must be a finite number > 0"),

    # ---- scene.toml read by fit: physical ranges (item 8) ----------------------------
    Case("scene-fps-1e-300", setup=run42_copy(scene=lambda t: t.replace("fps = 1200",
                                                                        "fps = 1e-300", 1)),
         args=("fit", "run", "-q"),
         stderr=r"run/scene\.toml: views\.front\.fps must be between 0\.1 and 1e\+07 "
                r"frames/s, got 1e-300"),
    Case("scene-fps-1e300", setup=run42_copy(scene=lambda t: t.replace("fps = 1200",
                                                                       "fps = 1e300", 1)),
         args=("fit", "run", "-q"), stderr=r"views\.front\.fps must be between .*got 1e\+300"),
    Case("scene-m-per-px-1e-300", setup=run42_copy(scene=scene_scale("1e-300")),
         args=("fit", "run", "-q"),
         stderr=r"views\.front\.m_per_px must be between 1e-09 and 1000 m per pixel"),
    Case("scene-m-per-px-inf", setup=run42_copy(scene=scene_scale("inf")),
         args=("fit", "run", "-q"), stderr=r"views\.front\.m_per_px must be a finite number"),
    Case("scene-calibration-file-with-inf-scale",
         setup=both(run42_copy(scene=lambda t: scene_scale("0.005")(t).replace(
             "m_per_px = 0.005", 'calibration = "cal.toml"')),
             files({"run/cal.toml": "schema = 1\n[scale]\nm_per_px = inf\n"})),
         args=("fit", "run", "-q"),
         stderr=r"views\.front\.calibration .*m_per_px must be a finite number, got inf"),
]


# ------------------------------------------------------------------ fit and report
# Every row here is refused before any footage is tracked (each runs in well under a
# second). Cases that need a fit, a FIFO (hashing would block on it) or a timeout are
# in tests/test_cli_fit.py and tests/test_cli_report.py.

#: experiment.toml of a two-run experiment (the runs are copies of run42); ``{name}``
#: is factor A's name.
EXPERIMENT = ('schema = 1\ndesign = "{design}"\nresponses = {responses}\nruns = "runs/*"\n'
              '[factors.A]\nname = "{name}"\ncentre = 550\nstep = 100\n')


def experiment(name="n_rpm", design="ccd", responses='["k1", "k2", "k3", "k4"]',
               scene=None, names=("run42-a", None)):
    """A setup: ``exp/`` with experiment.toml and two copies of run42 in ``exp/runs/``
    (the second one's scene.toml edited by ``scene(text)``), their ``[run] name`` set
    to ``names`` (None: run42's own)."""
    def setup(w):
        for i, r in enumerate(("a", "b")):
            def edit(text, i=i):
                text = text if names[i] is None else _named(names[i])(text)
                return scene(text) if scene is not None and i == 1 else text
            run42_copy(f"exp/runs/{r}", drop=("vidtrack", "truth.json",
                                               "vidtrack-synth.toml"), scene=edit)(w)
        (w / "exp" / "experiment.toml").write_text(
            EXPERIMENT.format(name=name, design=design, responses=responses))
    return setup


def unwritable_run(w):
    """run42 copied to ``run`` and made read-only (mode 555); skips when this process
    writes there anyway (root)."""
    run42_copy()(w)
    run = w / "run"
    run.chmod(0o555)
    try:
        (run / ".probe").write_bytes(b"")
    except OSError:
        return {}
    (run / ".probe").unlink()
    run.chmod(0o755)
    pytest.skip("this process writes into a mode-555 folder (root): no read-only run folder")


def top_links_to_front(w):
    """The top view's footage is a link to the front view's."""
    (w / "run" / "top.avi").unlink()
    os.symlink("front.avi", w / "run" / "top.avi")


def top_source(value):
    def edit(text):
        return text.replace('source = "top.avi"', f'source = "{value}"', 1)
    return edit


CASES += [
    # ---- the same footage for two views: a cross-check, before any tracking (item 3) ---
    Case("fit-same-footage-for-both-views",
         setup=run42_copy(scene=top_source("front.avi")), args=("fit", "run"),
         stderr=r"run 'run42' \(run\): the inputs disagree: views front and top both read "
                r"run/front\.avi: .*--accept-disagreement"),
    Case("fit-same-footage-through-a-link",
         setup=both(run42_copy(), top_links_to_front), args=("fit", "run"),
         stderr=r"views front and top both read .*--accept-disagreement"),
    # ---- sources that are not files or folders: refused before they are read (item 10)
    Case("fit-source-is-a-character-device",
         setup=run42_copy(scene=top_source("/dev/zero")), args=("fit", "run"),
         stderr=r"run 'run42' \(run\), view top: views\.top\.source: /dev/zero is a "
                r"character device; expected a video file, an image folder or a \.cine"),
    # ---- checked at open time, not after tracking (item 7) ----------------------------
    Case("fit-sync-frame-past-the-end",
         setup=run42_copy(scene=scene_value("sync_frame", "900", "top")), args=("fit", "run"),
         stderr=r"run 'run42' \(run\), view top: views\.top\.sync_frame = 900 is not among "
                r"its 372 frames, 0\.\.371 in run/top\.avi"),
    Case("fit-sync-frame-outside-the-frames-used",
         setup=run42_copy(scene=lambda t: scene_value("frames", "[0, 100]", "top")(
             scene_value("sync_frame", "150", "top")(t))), args=("fit", "run"),
         stderr=r"views\.top\.sync_frame = 150 is not among the frames used, 0\.\.99 "
                r"\(views\.top\.frames = \[0, 100\]\)"),
    # ---- outputs that cannot be written: found before any tracking (item 6) ----------
    Case("fit-out-folder-is-a-file", setup=both(run42_copy(), files({"run/vidtrack": "x"})),
         args=("fit", "run"),
         stderr=r"run 'run42' \(run\): run/vidtrack is a file; expected a folder for "
                r"vidtrack's outputs"),
    Case("fit-fit-json-is-a-folder",
         setup=both(run42_copy(), files({"run/vidtrack/fit.json/keep.txt": "x"})),
         args=("fit", "run"),
         stderr=r"run/vidtrack/fit\.json is a folder; expected a file vidtrack can replace"),
    Case("fit-tracks-h5-is-a-folder",
         setup=both(run42_copy(), files({"run/vidtrack/tracks.h5/keep.txt": "x"})),
         args=("fit", "run"), stderr=r"run/vidtrack/tracks\.h5 is a folder"),
    Case("fit-run-folder-read-only", setup=unwritable_run, args=("fit", "run"),
         stderr=r"run 'run42' \(run\): cannot create run/vidtrack \(Permission denied\); "
                r"expected a run folder you can write to"),
    # ---- counts a user types are bounded (item 12) ----------------------------------
    Case("fit-jobs-1000", setup=run42_copy(), args=("fit", "run", "--jobs", "1000"),
         stderr=r"--jobs must be between 1 and 256, got 1000"),
    Case("fit-jobs-0", setup=run42_copy(), args=("fit", "run", "--jobs", "0"),
         stderr=r"--jobs must be between 1 and 256, got 0"),
    Case("fit-bootstrap-1e7", setup=run42_copy(), args=("fit", "run", "--bootstrap", "10000000"),
         stderr=r"--bootstrap must be between 0 and 100000 resamples, got 10000000"),
    Case("fit-seed-negative", setup=run42_copy(), args=("fit", "run", "--seed", "-1"),
         stderr=r"--seed must be between 0 and 4294967295, got -1"),
    Case("report-jobs-1000", setup=experiment(), args=("report", "exp", "--jobs", "1000"),
         stderr=r"--jobs must be between 1 and 256, got 1000"),
    Case("fit-scheduler-not-an-address", setup=run42_copy(),
         args=("fit", "run", "--scheduler", "notanaddress"),
         stderr=r"--scheduler notanaddress: not a scheduler address .*expected e\.g\. tcp://"),
    # ---- report: the experiment checked against every scene before fitting (item 7) --
    Case("report-misspelt-factor", setup=experiment(name="n_rmp"), args=("report", "exp"),
         stderr=r"exp/runs/a/scene\.toml: \[factors\] has no 'n_rmp' \(did you mean "
                r"'n_rpm'\?\), which experiment\.toml's factor A names"),
    Case("report-factor-not-a-number",
         setup=experiment(scene=lambda t: t.replace("n_rpm = 550", 'n_rpm = "fast"')),
         args=("report", "exp"),
         stderr=r"exp/runs/b/scene\.toml: factors\.n_rpm must be a finite number .*got 'fast'"),
    Case("report-unknown-response", setup=experiment(responses='["k1", "k5"]'),
         args=("report", "exp"), stderr=r"responses names 'k5'; expected some of k1, k2, k3, k4"),
    Case("report-orthogonal-design", setup=experiment(design="orthogonal"),
         args=("report", "exp"),
         stderr=r"design = 'orthogonal': 'vidtrack report' analyses a ccd design"),
    Case("report-a-run-with-the-same-footage-twice",
         setup=experiment(scene=top_source("front.avi")), args=("report", "exp"),
         stderr=r"run 'run42' \(exp/runs/b\): the inputs disagree: views front and top both "
                r"read"),
    Case("report-a-run-whose-source-is-missing",
         setup=both(experiment(), lambda w: (w / "exp/runs/b/top.avi").unlink()),
         args=("report", "exp"),
         stderr=r"run 'run42' \(exp/runs/b\), view top: views\.top\.source: "
                r"exp/runs/b/top\.avi does not exist"),
    Case("report-out-folder-is-a-file",
         setup=both(experiment(), files({"exp/vidtrack": "x"})), args=("report", "exp"),
         stderr=r"experiment 'exp': exp/vidtrack is a file"),
]


def manual_csv(text, name="m.csv"):
    """A setup writing a manual points file ``run/NAME`` (after :func:`run42_copy`)."""
    return files({f"run/{name}": text})


def with_manual(name="m.csv", view="front"):
    return scene_value("manual_points", f'"{name}"', view)


CASES += [
    # ---- corrections of the tracker: exclude_frames, manual_points (issue 13) ---------
    Case("fit-exclude-frames-reversed",
         setup=run42_copy(scene=scene_value("exclude_frames", "[[10, 5]]")), args=("fit", "run"),
         stderr=r"run/scene\.toml: views\.front\.exclude_frames\[0\] must be a non-empty range "
                r"\[first, end\) with 0 <= first < end, got \[10, 5\]"),
    Case("fit-exclude-frames-not-pairs",
         setup=run42_copy(scene=scene_value("exclude_frames", "[5, 10]")), args=("fit", "run"),
         stderr=r"views\.front\.exclude_frames\[0\] must be two integers \[first, end\)"),
    Case("fit-exclude-frames-floats",
         setup=run42_copy(scene=scene_value("exclude_frames", "[[5.0, 10]]", "top")),
         args=("fit", "run"), stderr=r"views\.top\.exclude_frames\[0\] must be two integers"),
    Case("fit-exclude-frames-outside-the-frames-range",
         setup=run42_copy(scene=lambda t: scene_value("frames", "[0, 100]")(
             scene_value("exclude_frames", "[[90, 120]]")(t))), args=("fit", "run"),
         stderr=r"views\.front\.exclude_frames\[0\] must lie inside frames \[0, 100\), "
                r"got \[90, 120\]"),
    Case("fit-exclude-frames-past-the-footage",
         setup=run42_copy(scene=scene_value("exclude_frames", "[[900, 910]]", "top")),
         args=("fit", "run"),
         stderr=r"run 'run42' \(run\), view top: views\.top\.exclude_frames\[0\] = \[900, 910\] "
                r"holds none of its frames 0\.\.371 in run/top\.avi"),
    Case("fit-manual-points-missing-file", setup=run42_copy(scene=with_manual()),
         args=("fit", "run"),
         stderr=r"run/scene\.toml: views\.front\.manual_points names 'm\.csv', but there is no "
                r"such file .*expected a CSV frame,u_px,v_px"),
    Case("fit-manual-points-bad-header",
         setup=both(run42_copy(scene=with_manual()), manual_csv("frame,u,v\n60,100,50\n")),
         args=("fit", "run"),
         stderr=r"views\.front\.manual_points \(m\.csv\) has the header 'frame,u,v', without "
                r"u_px, v_px; expected a header frame,u_px,v_px"),
    Case("fit-manual-points-no-rows",
         setup=both(run42_copy(scene=with_manual()), manual_csv("frame,u_px,v_px\n")),
         args=("fit", "run"), stderr=r"\(m\.csv\) has a header but no points"),
    Case("fit-manual-points-frame-not-an-integer",
         setup=both(run42_copy(scene=with_manual()),
                    manual_csv("frame,u_px,v_px\n60,100,50\n61.5,101,50\n")),
         args=("fit", "run"),
         stderr=r"views\.front\.manual_points \(m\.csv, line 3\) frame must be an integer frame "
                r"index, got '61\.5'"),
    Case("fit-manual-points-nan-pixel",
         setup=both(run42_copy(scene=with_manual()),
                    manual_csv("frame,u_px,v_px\n60,100,nan\n")),
         args=("fit", "run"),
         stderr=r"\(m\.csv, line 2\) v_px must be a finite number \(pixels\), got 'nan'"),
    Case("fit-manual-points-empty-cell",
         setup=both(run42_copy(scene=with_manual()), manual_csv("frame,u_px,v_px\n60,,50\n")),
         args=("fit", "run"),
         stderr=r"\(m\.csv, line 2\) u_px must be a number \(pixels\), got ''"),
    Case("fit-manual-points-duplicate-frame",
         setup=both(run42_copy(scene=with_manual()),
                    manual_csv("frame,u_px,v_px\n60,100,50\n61,101,50\n60,102,50\n")),
         args=("fit", "run"),
         stderr=r"\(m\.csv, line 4\) gives frame 60 again \(first on line 2\); expected one "
                r"point per frame"),
    Case("fit-manual-points-frame-past-the-footage",
         setup=both(run42_copy(scene=with_manual()),
                    manual_csv("frame,u_px,v_px\n60,100,50\n900,101,50\n")),
         args=("fit", "run"),
         stderr=r"run 'run42' \(run\), view front: views\.front\.manual_points \(m\.csv\) has "
                r"frame 900, which is not among its frames 0\.\.371 in run/front\.avi"),
    Case("fit-manual-points-in-an-excluded-range",
         setup=both(run42_copy(scene=lambda t: with_manual()(
             scene_value("exclude_frames", "[[55, 65]]")(t))),
             manual_csv("frame,u_px,v_px\n60,100,50\n")),
         args=("fit", "run"),
         stderr=r"views\.front\.manual_points \(m\.csv\) has frame 60, which exclude_frames "
                r"\[55, 65\) takes out"),
    # ---- the grey image tracked: views.<v>.channel -----------------------------------
    Case("fit-channel-not-a-channel",
         setup=run42_copy(scene=scene_value("channel", '"purple"')), args=("fit", "run"),
         stderr=r"run/scene\.toml: views\.front\.channel must be one of \"luma\", \"red\", "
                r"\"green\", \"blue\", \"chroma\", \"auto\", got a string 'purple'$"),
    Case("fit-channel-a-number",
         setup=run42_copy(scene=scene_value("channel", "3", "top")), args=("fit", "run"),
         stderr=r"views\.top\.channel must be one of .*, got an integer 3$"),
    Case("fit-colour-channel-of-grey-footage",
         setup=run42_copy(scene=scene_value("channel", '"red"')), args=("fit", "run"),
         stderr=r"run 'run42' \(run\), view front: run/front\.avi: channel \"red\" takes the "
                r"red channel of colour footage, but this video is grey \(three equal channels "
                r"in every frame checked\); expected channel = \"luma\" or \"auto\" for grey "
                r"footage$"),
    Case("fit-manual-points-a-folder",
         setup=both(run42_copy(scene=with_manual("mp")), files({"run/mp/x.csv": "x"})),
         args=("fit", "run"),
         stderr=r"views\.front\.manual_points names 'mp', but it is not a file"),
]


# ------------------------------------------------------------------ issue 41
# Interruptions, a full disk, links, names that end up in files and terminals, numbers
# at the float limits. A full disk is a real one: a small tmpfs mounted over the output
# folder (skips, saying why, where this process cannot mount one).

def killed(out, stage, *args):
    """A setup: ``vidtrack ARGS`` killed (SIGKILL, as by a power cut or the OOM killer)
    once a file is in its staging folder ``w/out/STAGE``, so the folder is left behind."""
    def setup(w):
        proc = subprocess.Popen(
            [sys.executable, "-m", "vidtrack", *(str(a).format(w=w, repo=REPO) for a in args)],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            if (w / out).is_dir() and any(p.is_file() for p in (w / out).glob(stage + "/*")):
                break
            time.sleep(0.005)
        proc.kill()
        proc.wait()
        assert list((w / out).glob(stage)), "the command was not caught half-way"
    return setup


def interrupted_synth(name="run", *options):
    """A setup: ``vidtrack synth`` into ``w/name`` killed while it renders."""
    return killed(name, ".synth-*.part", "synth", "{w}/" + name, "--size", "320x240",
                  "--flight-s", "0.4", "-q", *options)


def no_hidden_leftovers(folder):
    def check(w, res):
        hidden = [p.name for p in (w / folder).iterdir() if p.name.startswith(".")]
        assert hidden == [], hidden
    return check


def _unmount_all(w):
    """Unmount every file system mounted under ``w`` (the tmpfs of :func:`full_disk`)."""
    with open("/proc/mounts", encoding="utf-8") as f:
        points = [line.split()[1] for line in f]
    for point in sorted(points, reverse=True):
        point = point.replace("\\040", " ")
        if point == str(w) or point.startswith(str(w) + os.sep):
            subprocess.run(["umount", point], check=False, capture_output=True)


def full_disk(folder, *, free_kb=0, size_kb=256, fill=lambda w: ()):
    """A setup: a ``size_kb`` tmpfs mounted on ``w/folder`` (made if missing), holding
    copies of the files ``fill(w)`` returns and then a filler file that leaves ``free_kb`` free: a
    real full disk for the outputs. Skips where mounting is not possible (not root,
    no mount)."""
    def setup(w):
        target = w / folder
        target.mkdir(parents=True, exist_ok=True)
        if shutil.which("mount") is None:
            pytest.skip("no mount command: cannot make a small full file system")
        res = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_kb}k", "tmpfs",
                              str(target)], capture_output=True, text=True)
        if res.returncode != 0:
            pytest.skip("cannot mount a small tmpfs to fill (needs root): "
                        + (res.stderr.strip() or f"exit {res.returncode}"))
        for source in fill(w):
            shutil.copy(source, target)
        fd = os.open(target / "filler.bin", os.O_WRONLY | os.O_CREAT, 0o644)
        try:
            while os.write(fd, b"\0" * 4096):
                pass
        except OSError:                     # the device is full
            pass
        finally:
            os.close(fd)
        if free_kb:
            with open(target / "filler.bin", "r+b") as f:
                f.truncate(max(0, os.path.getsize(target / "filler.bin") - free_kb * 1024))
    return setup


#: Runs fitted once per test process, copied by :func:`fitted_run` (a fit takes seconds).
_FITTED = {}


def fitted_run(name="run", run_name=None):
    """A setup: run42 fitted (its vidtrack/ outputs with stages.json) copied to
    ``w/name``, its ``[run] name`` set to ``run_name``; the fit is made once per test
    process and ``run_name`` and copied with its times kept, so later fits reuse it.
    Another ``run_name`` is the run fitted under its own name, renamed and fitted again
    (the views' tracks reused from views.h5, the world track and the fit made again)."""
    def setup(w):
        import atexit
        import tempfile

        if run_name not in _FITTED:
            root = Path(tempfile.mkdtemp(prefix="vidtrack-fitted-"))
            atexit.register(shutil.rmtree, root, True)
            base = root / "run"
            if run_name is None:
                run42_copy("run", drop=("vidtrack", "truth.json", MARKER))(base.parent)
            else:
                fitted_run("run")(base.parent)
                scene = base / "scene.toml"
                scene.write_text(_named(run_name)(scene.read_text(encoding="utf-8")),
                                 encoding="utf-8")
            res = run_vidtrack("fit", base, "-q")
            assert res.returncode == 0, res.stderr
            _FITTED[run_name] = base
        (w / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copytree(_FITTED[run_name], w / name)
    return setup


def _named(run_name):
    def edit(text):
        import json

        return re.sub(r'(?m)^name = .*$', lambda m: "name = " + json.dumps(run_name), text,
                      count=1)
    return edit


def fitted_experiment(*run_names, n_rpm=(450, 550, 650, 750, 850, 950, 1050, 1150)):
    """A setup: ``exp/`` whose runs ``runs/a``, ``runs/b``... are fitted copies of run42
    named ``run_names`` (see :func:`fitted_run`), with experiment.toml (factor A). Each
    copy's fit.json is given its n_rpm (``n_rpm[i]``) and k's scaled by
    (1 + i/10 + i^2/50) as if its footage had shown them, and stages.json the new
    file's digest, so that the report reuses every fit and has something to analyse."""
    def setup(w):
        import hashlib
        import json

        for i, (letter, rn) in enumerate(zip("abcdefgh", run_names)):
            fitted_run(f"exp/runs/{letter}", rn)(w)
            out = w / "exp" / "runs" / letter / "vidtrack"
            record = json.loads((out / "fit.json").read_text(encoding="utf-8"))
            record["factors"]["n_rpm"] = n_rpm[i]
            for c in record["coefficients"].values():
                if c["determined"]:
                    c["value"] *= 1 + i / 10 + i * i / 50
            text = json.dumps(record, indent=2) + "\n"
            (out / "fit.json").write_text(text, encoding="utf-8")
            stages = json.loads((out / "stages.json").read_text(encoding="utf-8"))
            stages["fit"]["files"]["fit.json"] = hashlib.sha256(text.encode()).hexdigest()
            (out / "stages.json").write_text(json.dumps(stages), encoding="utf-8")
        (w / "exp" / "experiment.toml").write_text(
            EXPERIMENT.format(name="n_rpm", design="ccd", responses='["k1", "k3"]'))
    return setup


def same_dlt_for_both_cameras(text):
    """A scene edit of a ``synth --cameras perspective`` run: cam1 given cam2's DLT."""
    dlt = re.search(r"\[views\.cam2\].*?\n(dlt = \[.*?\]\npixel_origin = .*?\n)", text,
                    re.S).group(1)
    return re.sub(r"projection = \[\n(?:    .*\n)+\]\n", dlt, text, count=1)


def scene_edit(name, edit):
    def setup(w):
        path = w / name / "scene.toml"
        path.write_text(edit(path.read_text(encoding="utf-8")), encoding="utf-8")
    return setup


def link(target, name):
    def setup(w):
        (w / name).parent.mkdir(parents=True, exist_ok=True)
        os.symlink(target, w / name)
    return setup


def flip_byte(name, offset, mask=0xFF):
    def setup(w):
        data = bytearray((w / name).read_bytes())
        data[offset] ^= mask
        (w / name).write_bytes(bytes(data))
    return setup


def csv_cells_not_formulas(path, column):
    def check(w, res):
        with open(w / path, newline="", encoding="utf-8") as f:
            for row in csv.DictReader(f):
                assert row[column][:1] not in ("=", "+", "-", "@", "\t", "\r"), row[column]
    return check


def no_control_characters(w, res):
    for stream in (res.stdout, res.stderr):
        bad = [c for c in stream if ord(c) < 32 and c not in "\n" or ord(c) == 127]
        assert not bad, repr(stream[-2000:])


def stderr_lacks(pattern):
    def check(w, res):
        assert not re.search(pattern, res.stderr), res.stderr[-2000:]
    return check


#: A run name as a spreadsheet formula with a terminal escape sequence in it.
FORMULA = '=HYPERLINK("http://x.example","\u001b[2J\u001b[31mclick")'
#: Run names of a four-run experiment that a spreadsheet would take for formulas.
REPORT_NAMES = (FORMULA, "+1-2", "@SUM(A1)", "-b")
#: Offset of TriggerTime's high byte (seconds) in a .cine header (cine.py, _HEADER).
CINE_TRIGGER_HIGH_BYTE = 43

CASES += [
    # ---- an interrupted synth is run again (item 1) -----------------------------------
    Case("synth-rerun-after-a-killed-synth", setup=interrupted_synth("run"),
         args=("synth", "run", *TINY), code=0, mutable=("run/*",),
         check=all_of(no_hidden_leftovers("run"),
                      marker_lists("run", "front.avi", "top.avi", "scene.toml",
                                   "truth.json"))),
    Case("synth-force-rerun-after-a-killed-force-synth",
         setup=both(synthetic_run("run"), interrupted_synth("run", "--force")),
         args=("synth", "run", "--force", *TINY), code=0, mutable=("run/*",),
         check=no_hidden_leftovers("run")),
    Case("frames-rerun-after-a-killed-export",
         setup=both(files({"out/notes.txt": "mine"}),
                    killed("out", ".frames-*.part", "frames", "{repo}/datasets/run42/front.avi",
                           "{w}/out", "--fps", "1200", "-q")),
         args=("frames", "{repo}/datasets/run42/front.avi", "out", "--fps", "1200",
               "--range", "0:2", "-q"), code=0, mutable=("out/.frames-*",),
         check=all_of(no_hidden_leftovers("out"),
                      listing("out", "frame_000000.png", "frame_000001.png", "frames.csv",
                              "notes.txt"))),
    Case("synth-hidden-file-not-its-own",
         setup=files({"run/.synth-notes.txt": "mine"}), args=("synth", "run", *TINY),
         stderr=r"run: the folder is not empty \(holds \.synth-notes\.txt\)"),
    # ---- calibrated cameras without parallax (item 2) ---------------------------------
    Case("fit-calibrated-cameras-with-the-same-dlt",
         setup=both(synthetic_run("run", "--cameras", "perspective"),
                    scene_edit("run", same_dlt_for_both_cameras)),
         args=("fit", "run"),
         stderr=r"run/scene\.toml: views\.cam2 has its camera centre where views\.cam1 has "
                r"its .*no parallax.*expected cameras at different places"),
    # ---- an experiment's runs: names once, links that lead nowhere (items 3, 4) ------
    Case("report-two-runs-with-the-same-name",
         setup=experiment(names=(None, None)), args=("report", "exp"),
         stderr=r"exp/runs/a and exp/runs/b both have the run name 'run42' \(\[run\] name "
                r"in scene\.toml\); expected each run of an experiment named once"),
    Case("report-a-run-folder-that-is-a-dangling-link",
         setup=both(experiment(), link("gone", "exp/runs/c")),
         args=("report", "exp"),
         stderr=r"exp/experiment\.toml: runs = 'runs/\*' matches exp/runs/c, a link to "
                r"gone, which does not exist; expected every run folder there"),
    Case("report-a-run-folder-that-is-a-link-loop",
         setup=both(experiment(), link("c", "exp/runs/c")),
         args=("report", "exp"), stderr=r"matches exp/runs/c, a link .*loop"),
    Case("report-a-run-folder-through-a-good-link",
         setup=both(experiment(name="n_rmp"),
                    run42_copy("elsewhere/c", scene=_named("run42-c")),
                    link("../../elsewhere/c", "exp/runs/c")),
         args=("report", "exp"), stderr=r"exp/runs/a/scene\.toml: \[factors\] has no 'n_rmp'"),
    Case("report-the-same-run-twice-through-a-link",
         setup=both(experiment(), link("b", "exp/runs/c")), args=("report", "exp"),
         stderr=r"exp/runs/b and exp/runs/c both have the run name 'run42'"),
    # ---- a full disk: every command, exit 2, outputs whole or absent (item 5) ---------
    Case("fit-full-disk", setup=both(run42_copy(), full_disk("run/vidtrack")),
         args=("fit", "run", "-q"),
         stderr=r"^vidtrack fit: error: run 'run42' \(run\): no space left on device writing "
                r"run/vidtrack/\S+; expected room for the outputs"),
    Case("fit-nearly-full-disk",
         setup=both(run42_copy(), full_disk("run/vidtrack", free_kb=48, size_kb=512)),
         args=("fit", "run", "-q"), stderr=r"no space left on device writing run/vidtrack/"),
    Case("frames-full-disk", setup=full_disk("d"),
         args=("frames", "{repo}/datasets/run42/front.avi", "d/out", "--fps", "1200",
               "--range", "0:40", "-q"),
         stderr=r"no space left on device writing d/out/\S+; expected room"),
    Case("frames-nearly-full-disk", setup=full_disk("d", free_kb=64),
         args=("frames", "{repo}/datasets/run42/front.avi", "d/out", "--fps", "1200",
               "--range", "0:40", "-q"), stderr=r"no space left on device writing d/out/"),
    Case("frames-full-disk-out-is-the-mount-point", setup=full_disk("out", free_kb=64),
         args=("frames", "{repo}/datasets/run42/front.avi", "out", "--fps", "1200",
               "--range", "0:40", "-q"), stderr=r"no space left on device writing out/"),
    Case("frames-into-a-mount-point", setup=full_disk("out", size_kb=4096, free_kb=2048),
         args=("frames", "{repo}/datasets/run42/front.avi", "out", "--fps", "1200",
               "--range", "0:3", "-q"), code=0,
         check=listing("out", "filler.bin", "frames.csv", "frame_000000.png",
                       "frame_000001.png", "frame_000002.png")),
    Case("synth-full-disk", setup=full_disk("d"), args=("synth", "d/run", *TINY),
         stderr=r"no space left on device writing d/run/"),
    Case("synth-nearly-full-disk", setup=full_disk("d", free_kb=40),
         args=("synth", "d/run", *TINY), stderr=r"no space left on device writing d/run/"),
    Case("anova-report-full-disk", setup=both(chen_table(), full_disk("d")),
         args=("anova", "t.csv", "--response", "k1", "--report", "d/r.html"),
         stderr=r"no space left on device writing d/r\.html"),
    Case("calibrate-full-disk", setup=full_disk("d"),
         args=("calibrate", "ruler", *RULER, "-o", "d/c.toml"),
         stderr=r"no space left on device writing d/c\.toml"),
    Case("predict-plot-full-disk", setup=full_disk("d"),
         args=("predict", *SETTING, "--plot", "d/p.png"),
         stderr=r"no space left on device writing d/p\.png"),
    Case("init-full-disk",
         setup=full_disk("run", size_kb=4096, fill=lambda w: [RUN42 / "front.avi"]),
         args=("init", "run", "--front", "front.avi"),
         stderr=r"no space left on device writing run/scene\.toml"),
    Case("overlay-full-disk",
         setup=both(fitted_run("run"), lambda w: (w / "run/vidtrack").rename(w / "saved"),
                    full_disk("run/vidtrack", size_kb=8192, free_kb=16,
                              fill=lambda w: sorted((w / "saved").iterdir())),
                    lambda w: shutil.rmtree(w / "saved")),
         args=("overlay", "run", "-q"),
         stderr=r"no space left on device writing run/vidtrack/overlay_"),
    Case("report-full-disk", setup=both(fitted_experiment(*REPORT_NAMES),
                                        full_disk("exp/vidtrack")),
         args=("report", "exp", "-q"),
         stderr=r"no space left on device writing exp/vidtrack/"),
    # ---- numbers at the float limits in a scene, before any tracking (item 7) ---------
    Case("fit-manual-point-1e308",
         setup=both(run42_copy(scene=with_manual()), manual_csv("frame,u_px,v_px\n60,1e308,50\n")),
         args=("fit", "run"),
         stderr=r"run/scene\.toml: views\.front\.manual_points \(m\.csv, line 2\) u_px must be "
                r"within \+-1e\+06 px \(an image position\), got '1e308'"),
    Case("fit-origin-1e308",
         setup=run42_copy(scene=lambda t: t.replace("origin_px = [", "origin_px = [1e308, 0] #",
                                                    1)),
         args=("fit", "run"),
         stderr=r"run/scene\.toml: views\.front\.origin_px must be within \+-1e\+06 px .*got "
                r"\[1e\+308, 0\]"),
    Case("fit-ruler-end-1e300",
         setup=run42_copy(scene=lambda t: re.sub(r"from_px = \[[^\]]*\]", "from_px = [0, -1e300]",
                                                 t, count=1)),
         args=("fit", "run"), stderr=r"ruler\.from_px must be within \+-1e\+06 px"),
    Case("fit-target-at-1e308",
         setup=run42_copy(scene=scene_value("target", "{ frame = 10, at_px = [1e308, 1] }")),
         args=("fit", "run"), stderr=r"views\.front\.target\.at_px must be within \+-1e\+06 px"),
    # ---- a damaged .cine header (item 8) ---------------------------------------------
    Case("frames-cine-trigger-time-flipped",
         setup=both(synthetic_run("run", "--format", "cine", "--views", "front"),
                    flip_byte("run/front.cine", CINE_TRIGGER_HIGH_BYTE)),
         args=("frames", "run/front.cine", "out", "-q"),
         stderr=r"run/front\.cine: damaged header: trigger_time .*expected"),
    Case("fit-cine-trigger-time-flipped",
         setup=both(synthetic_run("run", "--format", "cine", "--views", "front"),
                    flip_byte("run/front.cine", CINE_TRIGGER_HIGH_BYTE)),
         args=("fit", "run"), stderr=r"run/front\.cine: damaged header: trigger_time"),
    # ---- names that end up in files and on the terminal (item 9) ---------------------
    Case("fit-run-name-with-escape-sequences", setup=fitted_run("run", FORMULA),
         args=("fit", "run"), code=0, mutable=("run/vidtrack/*",),
         check=all_of(no_control_characters, stdout_has(r"\\x1b\[2J"))),
    Case("report-run-names-that-are-formulas", setup=fitted_experiment(*REPORT_NAMES),
         args=("report", "exp"), code=0, mutable=("exp/runs/*/vidtrack/*",),
         check=all_of(csv_cells_not_formulas("exp/vidtrack/coefficients.csv", "run"),
                      no_control_characters,
                      stderr_lacks(r"Warning:|warnings\.warn|\.py:\d+"))),
    Case("report-aliased-term-is-a-warning-line-not-a-python-warning",
         setup=fitted_experiment(*REPORT_NAMES, n_rpm=(450, 650, 450, 650)),
         args=("report", "exp"), code=0, mutable=("exp/runs/*/vidtrack/*",),
         stderr=r"(?m)^vidtrack report: warning: response 'k1': term\(s\) A\^2 cannot be "
                r"estimated from this design .*; left out of the model$",
         check=stderr_lacks(r"AliasedTermWarning|warnings\.warn|\.py:\d+")),
    Case("report-run-folder-name-with-a-newline",
         setup=both(experiment(),
                    lambda w: (w / "exp/runs/b").rename(w / "exp/runs/b\nc"),
                    scene_edit("exp/runs/b\nc", lambda t: t.replace("fps = 1200", "fps = 0", 1))),
         args=("report", "exp"), stderr=r"exp/runs/b\\nc/scene\.toml: views\.front\.fps"),
    Case("fit-scene-duplicate-key",
         setup=run42_copy(scene=lambda t: t.replace("fps = 1200", "fps = 1200\nfps = 600", 1)),
         args=("fit", "run"),
         stderr=r"run/scene\.toml: views\.front\.fps is given twice \(line \d+\); expected "
                r"each key once"),
    Case("fit-scene-duplicate-table",
         setup=run42_copy(scene=lambda t: t + "\n[views.top]\nfps = 1\n"),
         args=("fit", "run"), stderr=r"run/scene\.toml: the table \[views\.top\] is declared "
                                     r"twice \(line \d+\)"),
    Case("anova-cell-nan", setup=chen_table(edit=cell(3, "k1", "nan")),
         args=("anova", "t.csv", "--response", "k1"),
         stderr=r"t\.csv: row 3 \(line 4\), column 'k1': the cell is NaN \('nan'\); expected "
                r"a number"),
    # ---- the stage cache says when it reuses (item 11) -------------------------------
    Case("fit-says-when-it-reuses-a-stage", setup=fitted_run("run"),
         args=("fit", "run", "--model", "linear"), code=0, mutable=("run/vidtrack/*",),
         stderr=r"note: run 'run42' \(run\): tracks reused from run/vidtrack/tracks\.h5 "
                r"\(computed at \S+, same scene, footage, tracker and settings"),
]


def physics_value(key, value):
    """A scene edit: ``key = value`` in run42's [physics] table."""
    def edit(text):
        return text.replace("[physics]\n", f"[physics]\n{key} = {value}\n", 1) if \
            f"{key} =" not in text else re.sub(rf"(?m)^{key} = .*$", f"{key} = {value}", text)
    return edit


def straw_table(text):
    return lambda scene: re.sub(r"(?ms)^\[straw\]\n.*?(?=^\[)", "[straw]\n" + text + "\n",
                                scene, count=1)


def renamed_camera_view(name):
    """A scene edit of a ``synth --cameras perspective`` run: cam2 renamed ``name``."""
    return lambda text: text.replace("[views.cam2]", f"[views.{name}]", 1)


CASES += [
    # ---- numbers at the float limits, refused when the scene is read -----------------
    Case("fit-gravity-1e308", setup=run42_copy(scene=physics_value("gravity_m_s2", "1e308")),
         args=("fit", "run"),
         stderr=r"run/scene\.toml: physics\.gravity_m_s2 must be between 0\.01 and 1000 "
                r"m/s\^2, got 1e\+308"),
    Case("fit-air-density-1e308",
         setup=run42_copy(scene=physics_value("air_density_kg_m3", "1e308")),
         args=("fit", "run"), stderr=r"physics\.air_density_kg_m3 must be between 0 and 100"),
    Case("fit-straw-mass-5e-324",
         setup=run42_copy(scene=straw_table("mass_kg = 5e-324\narea_m2 = 0.01\n"
                                            "drag_coefficient = 1.0\n")),
         args=("fit", "run"), stderr=r"straw\.mass_kg must be between 1e-09 and 1000 kg"),
    Case("fit-straw-cp-1e300", setup=run42_copy(scene=straw_table("cp_s_per_m = 1e300\n")),
         args=("fit", "run"),
         stderr=r"straw\.cp_s_per_m gives Cp = 1e\+300 s/m; expected Cp <= 10 s/m"),
    Case("fit-machine-speed-1e308",
         setup=run42_copy(scene=lambda t: t.replace("[machine]\nspeed_kmh = 7.2",
                                                    "[machine]\nspeed_kmh = 1e308", 1)),
         args=("fit", "run"), stderr=r"machine\.speed_kmh must be between 0 and 100 km/h"),
    Case("fit-factor-1e308",
         setup=run42_copy(scene=lambda t: t.replace("n_rpm = 550", "n_rpm = 1e308", 1)),
         args=("fit", "run"),
         stderr=r"run/scene\.toml: factors\.n_rpm must be within \+-1e\+12 .*got 1e\+308"),
    Case("report-factor-centre-1e308",
         setup=both(experiment(), lambda w: (w / "exp/experiment.toml").write_text(
             (w / "exp/experiment.toml").read_text().replace("centre = 550",
                                                             "centre = 1e308"))),
         args=("report", "exp"),
         stderr=r"exp/experiment\.toml: factors\.A\.centre must be between -1e\+12 and 1e\+12"),
    Case("report-factor-step-5e-324",
         setup=both(experiment(), lambda w: (w / "exp/experiment.toml").write_text(
             (w / "exp/experiment.toml").read_text().replace("step = 100", "step = 5e-324"))),
         args=("report", "exp"), stderr=r"factors\.A\.step must be between 1e-12 and 1e\+12"),
    # ---- names that end up in file names and table columns ---------------------------
    Case("fit-camera-view-named-a-path",
         setup=both(synthetic_run("run", "--cameras", "perspective"),
                    scene_edit("run", renamed_camera_view('"../../escaped"'))),
         args=("fit", "run"),
         stderr=r"run/scene\.toml: views\.'\.\./\.\./escaped' is not a usable view name: it "
                r"names output files .*expected a letter or digit"),
    Case("fit-camera-view-named-a-formula",
         setup=both(synthetic_run("run", "--cameras", "perspective"),
                    scene_edit("run", renamed_camera_view('"=1+1"'))),
         args=("fit", "run"), stderr=r"views\.'=1\+1' is not a usable view name"),
    Case("fit-camera-view-named-with-an-escape",
         setup=both(synthetic_run("run", "--cameras", "perspective"),
                    scene_edit("run", renamed_camera_view('"cam\\u001b[2J"'))),
         args=("fit", "run"), stderr=r"views\.'cam\\x1b\[2J' is not a usable view name"),
    Case("report-run-folder-name-with-an-escape",
         setup=both(experiment(),
                    lambda w: (w / "exp/runs/b").rename(w / "exp/runs/b\x1b[2J"),
                    scene_edit("exp/runs/b\x1b[2J",
                               lambda t: t.replace("fps = 1200", "fps = 0", 1))),
         args=("report", "exp"),
         stderr=r"exp/runs/b\\x1b\[2J/scene\.toml: views\.front\.fps"),
    # ---- links ----------------------------------------------------------------------
    Case("fit-source-is-a-dangling-link",
         setup=both(run42_copy(), lambda w: (w / "run/top.avi").unlink(),
                    link("nowhere.avi", "run/top.avi")),
         args=("fit", "run"), stderr=r"views\.top\.source: run/top\.avi does not exist"),
    Case("fit-manual-points-a-dangling-link",
         setup=both(run42_copy(scene=with_manual()), link("gone.csv", "run/m.csv")),
         args=("fit", "run"), stderr=r"views\.front\.manual_points names 'm\.csv', but"),
    Case("synth-out-is-a-dangling-link", setup=link("gone", "run"),
         args=("synth", "run", *TINY),
         stderr=r"run: is a link to gone, which does not exist; expected a folder"),
    Case("frames-out-is-a-dangling-link", setup=link("gone", "out"),
         args=("frames", "{repo}/datasets/run42/front.avi", "out", "--fps", "1200"),
         stderr=r"out: is a link to gone, which does not exist; expected a folder"),
]


# ------------------------------------------------------------------ the runner

def _tree(folder):
    """Every file (sha256) and folder under ``folder``, hidden ones included."""
    out = {}
    for root, dirs, names in os.walk(folder):
        for d in dirs:
            out[os.path.relpath(os.path.join(root, d), folder)] = "<folder>"
        for n in names:
            p = os.path.join(root, n)
            key = os.path.relpath(p, folder)
            if os.path.islink(p):
                out[key] = "-> " + os.readlink(p)
            else:
                with open(p, "rb") as f:
                    out[key] = hashlib.sha256(f.read()).hexdigest()
    return out


def message_lines(stderr):
    """The non-empty lines of stderr (a usage error is one line too, no usage block)."""
    return [line for line in stderr.splitlines() if line.strip()]


@pytest.fixture
def work(tmp_path):
    w = tmp_path / "w"
    w.mkdir()
    yield w
    _unmount_all(w)
    for root, dirs, _ in os.walk(w):        # an unwritable folder made writable again
        for d in dirs:
            os.chmod(os.path.join(root, d), 0o755)


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_hostile_input(case, work):
    places = {"repo": str(REPO), "w": str(work)}
    if case.setup is not None:
        places.update(case.setup(work) or {})
    before = _tree(work)
    res = run_vidtrack(*(a.format(**places) for a in case.args), cwd=work, timeout=120)
    assert res.returncode == case.code, f"exit {res.returncode}:\n{res.stderr[-3000:]}"
    assert "Traceback" not in res.stderr, res.stderr[-3000:]
    after = _tree(work)
    if case.code == 2:
        lines = message_lines(res.stderr)
        assert len(lines) == 1, f"expected one line on stderr, got:\n{res.stderr}"
        assert re.search(case.stderr, lines[0]), lines[0]
        assert after == before, "the refused command changed the work folder: " + repr(
            sorted(set(after.items()) ^ set(before.items())))
    else:
        if case.stderr:
            assert re.search(case.stderr, res.stderr), res.stderr
        for path, digest in before.items():
            if not any(fnmatch.fnmatch(path, m) for m in case.mutable):
                assert after.get(path) == digest, f"input {path} changed or removed"
    if case.check is not None:
        case.check(work, res)


def test_the_table_is_well_formed():
    ids = [c.id for c in CASES]
    assert len(ids) == len(set(ids)), "case ids must be unique"
    for c in CASES:
        assert c.code != 2 or c.stderr, f"{c.id}: a refusal needs the message regex"
        re.compile(c.stderr)
