"""The command line's frame: registry, exit codes, error reporting."""

import pytest

from evtribo.cli import SUBCOMMANDS, build_parser, main


def test_every_subcommand_is_registered():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    assert set(SUBCOMMANDS) <= set(sub.choices)


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith("evtribo ")


def test_unknown_command_is_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["no-such-command"])
    assert exc.value.code == 2


def test_only_the_chosen_subcommand_is_imported():
    import subprocess
    import sys

    code = ("import sys; from evtribo.cli import main; main(['model', '--list']); "
            "print('evtribo.results.pipeline' in sys.modules, "
            "'evtribo.cli.results.model' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "False True"


def test_subcommand_help_lists_its_options(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["model", "--help"])
    assert exc.value.code == 0
    assert "--normal-force" in capsys.readouterr().out


@pytest.mark.parametrize("name", list(SUBCOMMANDS))
def test_help_is_plain_text_without_the_docstrings_markup(name, capsys):
    """--help shows `code` as the rest of the help writes it, never reStructuredText's
    double backticks or roles (the descriptions come from the modules' docstrings)."""
    with pytest.raises(SystemExit):
        main([name, "--help"])
    shown = capsys.readouterr().out
    assert shown.strip()
    for markup in ("``", ":func:", ":mod:", ":data:", ":class:", ":meth:"):
        assert markup not in shown, (name, markup)
