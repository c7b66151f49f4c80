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
