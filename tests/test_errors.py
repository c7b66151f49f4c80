import pickle

import pytest

from evtribo import errors


def test_location_comes_first():
    err = errors.ConfigError("file not found", path="study.toml", key="rig.dbc")
    assert str(err) == "study.toml: key 'rig.dbc': file not found"
    err = errors.LogFormatError("bad hex", path="P01/run-01.log", line=12)
    assert str(err) == "P01/run-01.log:12: bad hex"


@pytest.mark.parametrize(
    ("cls", "builtin", "code"),
    [
        (errors.ConfigError, ValueError, 2),
        (errors.RigConfigError, ValueError, 2),
        (errors.LogFormatError, ValueError, 2),
        (errors.SidecarError, ValueError, 2),
        (errors.StudyError, ValueError, 2),
        (errors.OutputExistsError, FileExistsError, 2),
        (errors.AcquisitionError, OSError, 1),
        (errors.AnalysisError, RuntimeError, 1),
    ],
)
def test_tree(cls, builtin, code):
    err = cls("x", path="f", line=3, key="k")
    assert isinstance(err, errors.EvtriboError)
    assert isinstance(err, builtin)
    assert err.exit_code == code
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is cls and str(back) == str(err)


def test_an_override_is_named_as_python_or_the_command_line_spells_it(tmp_path, capsys):
    """A refusal names ``force=True`` to Python code and ``--force`` on the command line."""
    from evtribo.cli import main
    from evtribo.errors import OutputExistsError
    from evtribo.study import write_sidecar

    path = tmp_path / "run-01.json"
    write_sidecar(path, {"subject": "P01"})
    with pytest.raises(OutputExistsError) as exc:
        write_sidecar(path, {"subject": "P01"})
    assert "use force=True to overwrite" in str(exc.value) and "--force" not in str(exc.value)
    assert "use --force to overwrite" in exc.value.cli_text()
    figures = tmp_path / "figs"
    assert main(["model", "--figures", str(figures)]) == 0
    assert main(["model", "--figures", str(figures)]) == 2
    assert "use --force to overwrite" in capsys.readouterr().err
