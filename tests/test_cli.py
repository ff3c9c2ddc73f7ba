"""The command line frame: every subcommand listed, with help and an example; exit codes."""

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


def test_version(vidtrack_cli):
    import vidtrack

    out = vidtrack_cli("--version")
    assert out.returncode == 0 and vidtrack.__version__ in out.stdout
