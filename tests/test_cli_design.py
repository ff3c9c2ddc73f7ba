"""``vidtrack design`` end to end through the real command line: the folder it writes read
back by the project's own readers (experiment.toml, each run's scene.toml once filmed),
bad input refused with one line and nothing written, the run order fixed by its seed."""

import shutil
import tomllib

import pandas as pd
import pytest

from conftest import REPO
from test_cli_init import VIEW_KEYS, fill

RUN42 = REPO / "datasets" / "run42"
CHEN = ("--ccd", "A=n_rpm:550:100", "--ccd", "B=blade_angle_deg:0:5",
        "--ccd", "C=speed_kmh:7.2:1.8")
HOU = ("--orthogonal", "L27", "--factor", "rho0_mm:150,200,250", "--factor",
       "tau0_deg:20,30,40", "--factor", "vm_kmh:3.6,5.4,7.2", "--factor",
       "omega_rad_s:42,52.5,63")


def _one_line(res):
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    return lines[0]


def test_ccd_folder_is_read_by_the_experiment_reader(vidtrack_cli, tmp_path):
    from vidtrack.scene import load_experiment

    out = tmp_path / "exp2016"
    res = vidtrack_cli("design", *CHEN, "--alpha", "orthogonal", "--centre-points", "18",
                       "--seed", "1", out)
    assert res.returncode == 0, res.stderr
    assert "alpha = 2, 18 centre points" in res.stdout
    sheet = pd.read_csv(out / "design.csv", dtype={"run": str})
    assert list(sheet.columns) == ["run", "std_order", "run_order", "point", "A", "B", "C",
                                   "n_rpm", "blade_angle_deg", "speed_kmh"]
    assert list(sheet["run_order"]) == list(range(1, 33))

    exp = load_experiment(out)
    assert exp.design == "ccd" and exp.responses == ("k1", "k2", "k3", "k4")
    assert {k: f.to_dict() for k, f in exp.factors.items()} == {
        "A": {"name": "n_rpm", "centre": 550, "step": 100},
        "B": {"name": "blade_angle_deg", "centre": 0, "step": 5},
        "C": {"name": "speed_kmh", "centre": 7.2, "step": 1.8}}
    runs = exp.run_dirs()
    assert [p.name for p in runs] == list(sheet["run"])
    assert runs[0].name == "01" and len(runs) == 32
    for run, row in zip(runs, sheet.itertuples(index=False)):
        factors = tomllib.loads((run / "scene.toml").read_text())["factors"]
        assert factors == pytest.approx({"n_rpm": row.n_rpm, "blade_angle_deg":
                                         row.blade_angle_deg, "speed_kmh": row.speed_kmh})
        # coded as the experiment codes a run's factors, the sheet's coded levels
        for letter, f in exp.factors.items():
            assert f.code(factors[f.name]) == pytest.approx(getattr(row, letter))
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]   # no staging left


def test_a_filmed_run_is_completed_by_init_and_read_as_report_reads_it(vidtrack_cli,
                                                                       tmp_path):
    """Footage put into a planned run folder: `vidtrack init` adds the views and keeps the
    design's factors; filled in, the scene loads and passes the report's checks."""
    from vidtrack.experiment import check_runs
    from vidtrack.scene import load_experiment, load_scene

    out = tmp_path / "exp"
    assert vidtrack_cli("design", *CHEN, "--alpha", "2", "--seed", "3", out).returncode == 0
    run = out / "runs" / "05"
    planned = tomllib.loads((run / "scene.toml").read_text())["factors"]
    for name in ("front.avi", "top.avi"):
        shutil.copy(RUN42 / name, run / name)
    res = vidtrack_cli("init", run)
    assert res.returncode == 0, res.stderr
    text = (run / "scene.toml").read_text()
    assert tomllib.loads(text)["factors"] == planned
    original = tomllib.loads((RUN42 / "scene.toml").read_text())
    for section in ("physics", "straw"):
        for key, value in original[section].items():
            text = fill(text, section, key, value)
    for view, table in original["views"].items():
        for key in VIEW_KEYS:
            text = fill(text, f"views.{view}", key, table[key])
    (run / "scene.toml").write_text(text)
    scene = load_scene(run)
    assert scene.factors == planned and scene.run_name == "05"
    check_runs(load_experiment(out), [scene])
    # a second init now refuses: the file has views, it is the user's
    again = vidtrack_cli("init", run)
    assert again.returncode == 2 and "already exists" in _one_line(again)


def test_orthogonal_folder(vidtrack_cli, tmp_path):
    from vidtrack.scene import load_experiment

    out = tmp_path / "hou"
    out.mkdir()                                   # an empty folder is taken
    res = vidtrack_cli("design", *HOU, "--seed", "7", out)
    assert res.returncode == 0, res.stderr
    assert "columns rho0_mm 1, tau0_deg 2, vm_kmh 5, omega_rad_s 9" in res.stdout
    exp = load_experiment(out)
    assert exp.design == "orthogonal"
    assert [f.name for f in exp.factors.values()] == ["rho0_mm", "tau0_deg", "vm_kmh",
                                                      "omega_rad_s"]
    assert len(exp.run_dirs()) == 27
    sheet = pd.read_csv(out / "design.csv")
    table3 = pd.read_csv(REPO / "datasets" / "published" / "hou2019_table3_l27.csv")
    names = ["rho0_mm", "tau0_deg", "vm_kmh", "omega_rad_s"]
    key = lambda t: sorted(map(tuple, t[names].round(9).to_numpy().tolist()))  # noqa: E731
    assert key(sheet) == key(table3)
    assert set(sheet["A"]) == {1, 2, 3}


def test_seed_fixes_the_run_order(vidtrack_cli, tmp_path):
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    for out, seed in ((a, 11), (b, 11), (c, 12)):
        assert vidtrack_cli("design", *CHEN, "--seed", seed, out).returncode == 0
    assert (a / "design.csv").read_bytes() == (b / "design.csv").read_bytes()
    assert (a / "design.csv").read_bytes() != (c / "design.csv").read_bytes()
    for run in ("01", "07", "20"):
        assert (a / "runs" / run / "scene.toml").read_text() == \
            (b / "runs" / run / "scene.toml").read_text()


BAD = [
    (CHEN[:2] + ("--ccd", "B=blade_angle_deg:0"), "expected LETTER=NAME:CENTRE:STEP"),
    (CHEN[:2] + ("--ccd", "B=blade_angle_deg:zero:5"), "must be numbers"),
    (CHEN[:2] + ("--ccd", "B=blade_angle_deg:0:0"), "step must not be 0"),
    (CHEN[:2] + ("--ccd", "B=blade_angle_deg:0:-5"), "step must be > 0"),
    (CHEN[:2] + ("--ccd", "B=n_rpm:0:5"), "two factors have the name 'n_rpm'"),
    (CHEN[:2] + ("--ccd", "A=speed_kmh:7.2:1.8"), "two factors have the letter 'A'"),
    (CHEN + ("--alpha", "0"), "--alpha 0: must be > 0"),
    (CHEN + ("--alpha", "-1.5"), "--alpha -1.5: must be > 0"),
    (CHEN + ("--alpha", "star"), "expected a number > 0 or one of rotatable"),
    (CHEN + ("--centre-points", "-1"), "centre points must be a whole number"),
    (CHEN[:2], "needs 2 to 10 factors, got 1"),
    ((), "one of the two"),
    (CHEN + HOU[:2], "one of the two"),
    (CHEN + ("--factor", "rho0_mm:1,2,3"), "--factor gives an orthogonal array's levels"),
    (HOU[:2], "give its factors with --factor"),
    (HOU[:3] + ("rho0_mm:150,200",), "3 levels per column, got 2"),
    (HOU[:3] + ("rho0_mm:150,200,250@14",), "columns 1 to 13, got 14"),
    (HOU + ("--factor", "rho0_mm:1,2,3"), "two factors have the name 'rho0_mm'"),
    (("--orthogonal", "L12") + HOU[2:], "not one this builds"),
    (HOU + ("--alpha", "2"), "--alpha and --centre-points apply to a central composite"),
    (CHEN + ("--seed", "-1"), "--seed must be >= 0"),
]


@pytest.mark.parametrize("args, words", BAD, ids=[w for _, w in BAD])
def test_bad_input_exit_2_nothing_written(tmp_path, capsys, args, words):
    from vidtrack.cli import main

    out = tmp_path / "out"
    assert main(["design", *args, str(out)]) == 2
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("vidtrack design: error: "), err
    assert words in lines[0]
    assert list(tmp_path.iterdir()) == []          # no OUT, no staging folder


def test_out_that_is_not_empty_or_a_file_is_refused(vidtrack_cli, tmp_path):
    full = tmp_path / "exp"
    full.mkdir()
    (full / "notes.txt").write_text("mine\n")
    res = vidtrack_cli("design", *CHEN, "--seed", "1", full)
    assert res.returncode == 2
    assert "exists and is not empty" in _one_line(res)
    assert sorted(p.name for p in full.iterdir()) == ["notes.txt"]
    assert (full / "notes.txt").read_text() == "mine\n"
    afile = tmp_path / "plan.csv"
    afile.write_text("x\n")
    res = vidtrack_cli("design", *CHEN, afile)
    assert res.returncode == 2 and "is not a folder" in _one_line(res)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exp", "plan.csv"]


def test_a_failure_while_writing_leaves_nothing(tmp_path, monkeypatch):
    """Outputs whole or not at all: a run folder that cannot be written (here, the
    scene text failing half way through the runs) leaves no OUT and no staging folder."""
    import vidtrack.scene_template as st
    from fits.design import central_composite
    from fits.rsm import Factor
    from vidtrack.design import write_design

    calls = []
    real = st.plan_scene_text

    def failing(*a, **k):
        calls.append(1)
        if len(calls) == 10:
            raise OSError(28, "No space left on device")
        return real(*a, **k)

    monkeypatch.setattr(st, "plan_scene_text", failing)
    d = central_composite([Factor.parse("A=n_rpm:550:100"),
                           Factor.parse("B=speed_kmh:7.2:1.8")], rng=0)
    from vidtrack.errors import DiskFullError

    with pytest.raises(DiskFullError, match="no space left on device writing"):
        write_design(tmp_path / "exp", d)
    assert list(tmp_path.iterdir()) == []


def test_help_has_examples(vidtrack_cli):
    res = vidtrack_cli("design", "--help")
    assert res.returncode == 0
    assert "vidtrack design --ccd A=n_rpm:550:100" in res.stdout
    assert "--orthogonal L27" in res.stdout
