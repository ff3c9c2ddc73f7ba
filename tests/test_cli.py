"""The command line frame: every subcommand listed, with help and an example; exit codes."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from vidtrack.cli import COMMANDS


def test_top_level_help_lists_every_command(vidtrack_cli):
    out = vidtrack_cli("--help")
    assert out.returncode == 0
    for name in COMMANDS:
        assert name in out.stdout


@pytest.mark.parametrize("name", COMMANDS)
def test_every_command_has_help_with_an_example(vidtrack_cli, name):
    out = vidtrack_cli(name, "--help")
    assert out.returncode == 0, out.stderr
    assert "Example" in out.stdout or "example" in out.stdout
    assert "vidtrack " + name in out.stdout


def test_unknown_command_is_bad_usage(vidtrack_cli):
    out = vidtrack_cli("no-such-command")
    assert out.returncode == 2
    assert "invalid choice" in out.stderr


@pytest.mark.parametrize("args, where", [
    (("no-such-command",), "vidtrack"), (("fit", "--bogus"), "vidtrack fit"),
    (("predict", "--n-rpm", "x"), "vidtrack predict"), (("anova",), "vidtrack anova"),
    (("calibrate", "ruler", "--length-m"), "vidtrack calibrate ruler"),
])
def test_usage_errors_are_one_line(vidtrack_cli, args, where):
    out = vidtrack_cli(*args)
    assert out.returncode == 2
    lines = [ln for ln in out.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"{where}: error: "), out.stderr
    assert f"(see '{where} --help')" in lines[0]


def test_version(vidtrack_cli):
    import vidtrack

    out = vidtrack_cli("--version")
    assert out.returncode == 0 and vidtrack.__version__ in out.stdout


# ---------------------------------------------------------------- -v / -q and logging

WORKED = ("--n-rpm", "450", "--blade-angle-deg", "-10", "--speed-kmh", "6")
OUTSIDE = ("--n-rpm", "900", "--blade-angle-deg", "0", "--speed-kmh", "7.2")
NO_COVARIANCE = "vidtrack predict: the regression carries no coefficient covariance"


def test_default_stderr_is_unchanged(vidtrack_cli):
    res = vidtrack_cli("predict", *WORKED)
    assert res.returncode == 0 and res.stderr == ""
    res = vidtrack_cli("predict", *OUTSIDE)
    assert res.returncode == 0
    assert res.stderr.splitlines() == [
        "vidtrack predict: warning: n_rpm = 900 lies outside the design range [350, 750] "
        "(coded +3.5): the prediction is an extrapolation of the regression"]


@pytest.mark.parametrize("where", ["before", "after"])
def test_verbose_shows_info_records_before_or_after_the_command(vidtrack_cli, where):
    args = ("-v", "predict", *WORKED) if where == "before" else ("predict", *WORKED, "-v")
    res = vidtrack_cli(*args)
    assert res.returncode == 0, res.stderr
    assert NO_COVARIANCE in res.stderr
    assert all(line.startswith("vidtrack predict: ") for line in res.stderr.splitlines())
    assert "k4 = 21.84" in res.stdout                 # the result is printed as before


@pytest.mark.parametrize("where", ["before", "after"])
def test_quiet_before_or_after_the_command_leaves_only_errors(vidtrack_cli, where):
    args = ("-q", "predict", *OUTSIDE) if where == "before" else ("predict", *OUTSIDE, "-q")
    res = vidtrack_cli(*args)
    assert res.returncode == 0 and res.stderr == ""
    bad = vidtrack_cli("-q", "predict", "--n-rpm", "60", "--blade-angle-deg", "0",
                       "--speed-kmh", "7.2")
    assert bad.returncode == 2 and bad.stderr.startswith("vidtrack predict: error: ")


def test_double_verbose_shows_debug_records_with_their_logger(vidtrack_cli):
    from tests.test_rsm import CHEN_ARGS

    res = vidtrack_cli("-v", "anova", *CHEN_ARGS, "--response", "k1", "-v")
    assert res.returncode == 0, res.stderr
    assert ("vidtrack anova: debug: [fits.rsm.fit] eliminated A:C (p = 0.8092 > alpha "
            "0.05)") in res.stderr.splitlines()
    assert "Regression" in res.stdout


def test_verbose_is_accepted_after_a_commands_mode(vidtrack_cli):
    res = vidtrack_cli("calibrate", "ruler", "--length-m", "0.5", "--from", "80,482",
                       "--to", "205,482", "-v")
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("k = 0.004 m/px")


@pytest.fixture
def restore_logging():
    import logging

    from vidtrack.cli import LOGGERS

    saved = {n: (logging.getLogger(n).level, list(logging.getLogger(n).handlers))
             for n in LOGGERS}
    yield
    for n, (level, handlers) in saved.items():
        logger = logging.getLogger(n)
        logger.setLevel(level)
        logger.handlers[:] = handlers


def test_records_are_under_the_vidtrack_logger(caplog, capsys, restore_logging):
    from vidtrack.cli import main

    with caplog.at_level("INFO"):
        assert main(["predict", *OUTSIDE, "-v"]) == 0
    names = {r.name for r in caplog.records}
    assert "vidtrack.predict.forward" in names and "vidtrack.cli.predict" in names
    warning = next(r for r in caplog.records if r.levelname == "WARNING")
    assert warning.name == "vidtrack.cli.predict" and "n_rpm = 900" in warning.getMessage()
    err = capsys.readouterr().err.splitlines()
    assert err[-1].startswith("vidtrack predict: warning: n_rpm = 900")
    assert err[0].startswith("vidtrack predict: the regression carries")
    # a second call replaces the handler: no line twice
    assert main(["predict", *OUTSIDE]) == 0
    assert len(capsys.readouterr().err.splitlines()) == 1


def test_the_library_logs_nothing_without_configuration(capsys):
    import logging
    import subprocess
    import sys

    code = ("import logging, warnings\n"
            "warnings.simplefilter('ignore')\n"
            "from vidtrack.predict import predict\n"
            "predict(900, 0, 7.2)\n"
            "logging.getLogger('vidtrack.predict.forward').warning('a warning')\n"
            "import vidtrack, fits, calibration\n"
            "print([type(h).__name__ for n in ('vidtrack', 'fits', 'calibration')\n"
            "       for h in logging.getLogger(n).handlers])\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stderr == ""                 # NullHandler: no "last resort" output
    assert res.stdout.strip() == "['NullHandler', 'NullHandler', 'NullHandler']"
    assert logging.getLogger("vidtrack").handlers


# ---------------------------------------------------------------- progress bars

def test_no_bar_and_no_tqdm_when_stderr_is_not_a_terminal():
    import subprocess
    import sys

    code = ("import sys\n"
            "from vidtrack._progress import progress\n"
            "items = [1, 2, 3]\n"
            "assert progress(items, desc='x') is items\n"
            "bar = progress(total=3)\n"
            "bar.update(); bar.close()\n"
            "print('tqdm' in sys.modules)\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "False" and res.stderr == ""


def test_a_notebook_gets_a_bar_even_without_a_terminal(monkeypatch):
    import sys
    import types

    from vidtrack import _progress

    monkeypatch.setitem(sys.modules, "ipykernel", types.ModuleType("ipykernel"))
    assert _progress.in_notebook() and _progress.bars_enabled()
    items = [1, 2, 3]
    bar = _progress.progress(items, desc="frames")
    from tqdm.std import tqdm as std_tqdm
    assert isinstance(bar, std_tqdm) and list(bar) == items
    bar.close()
    # --quiet wins everywhere
    assert _progress.progress(items, quiet=True) is items
    assert not _progress.bars_enabled(quiet=True)


# ---------------------------------------------------------------- profiling a command

CHEN = Path(__file__).resolve().parents[1] / "datasets" / "published" / "chen2018_table2_ccd.csv"
ANOVA = ("anova", CHEN, "--response", "k1", "--factor", "A=n_rpm:550:100", "--factor",
         "B=blade_angle_deg:0:5", "--factor", "C=speed_kmh:7.2:1.8", "--json")


def _profiled_functions(path):
    """(file name, function) pairs of a cProfile statistics file, as pstats reads it."""
    import pstats

    return {(Path(file).name, name) for file, _, name in pstats.Stats(str(path)).stats}


def test_any_command_can_be_profiled(vidtrack_cli, tmp_path):
    """``vidtrack --profile FILE COMMAND``: a profile pstats reads, holding the function
    that did the command's work; the command's output is what it is without it."""
    prof = tmp_path / "anova.prof"
    res = vidtrack_cli("--profile", prof, *ANOVA)
    assert res.returncode == 0, res.stderr
    assert ("fit.py", "fit_rsm") in _profiled_functions(prof)
    assert json.loads(res.stdout) == json.loads(vidtrack_cli(*ANOVA).stdout)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["anova.prof"]   # no temporary


def test_the_console_script_under_cprofile_writes_its_profile(tmp_path):
    """``python -m cProfile -o F $(which vidtrack) ...``: the console script lets the
    interpreter finish under a profiler (on Python 3.12+ cProfile watches through
    sys.monitoring, not sys.setprofile), so cProfile writes the file."""
    script = shutil.which("vidtrack", path=str(Path(sys.executable).parent))
    if script is None:
        pytest.skip("no vidtrack console script beside this Python (not installed)")
    prof = tmp_path / "anova.prof"
    res = subprocess.run([sys.executable, "-m", "cProfile", "-o", str(prof), script,
                          *map(str, ANOVA)], capture_output=True, text=True, timeout=600,
                         stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stderr
    assert ("fit.py", "fit_rsm") in _profiled_functions(prof)


def test_a_profile_never_replaces_a_file_that_is_not_one(vidtrack_cli, tmp_path):
    """--profile naming an input (or any file that is not a profile) is refused before
    any work, exit 2, the file untouched; an earlier profile is replaced."""
    table = tmp_path / "table.csv"
    shutil.copy(CHEN, table)
    res = vidtrack_cli("--profile", table, *ANOVA[:1], table, *ANOVA[2:])
    assert res.returncode == 2
    assert res.stderr.startswith(f"vidtrack anova: error: --profile {table}: exists and is "
                                 "not a profile")
    assert table.read_bytes() == CHEN.read_bytes()
    prof = tmp_path / "again.prof"
    for _ in range(2):
        assert vidtrack_cli("--profile", prof, *ANOVA).returncode == 0
    assert ("fit.py", "fit_rsm") in _profiled_functions(prof)
