"""Each result table declared once: the files analyze and compare write are their schemas'
(columns in order, keys unique); one typing whether a table was computed, read by compare
or by the API; any table written and read back holds its values to the last bit."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

import evtribo
from evtribo.cli import main
from evtribo.documents.tables import (
    ANALYSIS_TABLES,
    SCHEMAS,
    TEXT_COLUMNS,
    TableSchema,
)
from evtribo.fit.tables import read_results

REFERENCE = Path(__file__).parents[2] / "data" / "reference-study"


@pytest.fixture(scope="module")
def compared(tmp_path_factory) -> Path:
    """The recorded study of data/ analysed and compared (with two candidate models)."""
    base = tmp_path_factory.mktemp("tables")
    study, out, cache = base / "study", base / "out", base / "cache"
    shutil.copytree(REFERENCE, study)
    assert main(["analyze", str(study), "--out", str(out), "--jobs", "1", "--cache-dir",
                 str(cache)]) == 0
    assert main(["compare", str(out), "--models", "paper,hertz", "--jobs", "1",
                 "--no-trial-checks", "--dpi", "20", "--cache-dir", str(cache)]) == 0
    return out


def test_every_file_written_is_its_schemas(compared):
    """Every CSV analyze and compare wrote has its schema's columns in order, and each
    key once."""
    written = sorted(p.name for p in compared.glob("*.csv"))
    assert written == sorted(SCHEMAS)
    for name, schema in SCHEMAS.items():
        table = schema.read(compared / name, complete=True)
        assert tuple(table.columns) == schema.names(), name
        assert len(table) > 0, name
        assert not table.duplicated(list(schema.key)).any(), name


def test_compare_and_the_api_read_one_typing(compared):
    """The tables compare reads (``read_results``) are those ``load_results`` gives, types
    and all: counts as Int64, names as str, floats to the last bit."""
    ours, api = read_results(compared), evtribo.load_results(compared)
    for name in ("trials", "windows", "electrostatic", "exponents", "bootstrap",
                 "sine_trace"):
        pd.testing.assert_frame_equal(getattr(ours, name), getattr(api, name),
                                      check_exact=True, obj=name)
    assert str(ours.electrostatic["n_on"].dtype) == "Int64"
    assert ours.electrostatic["subject"].dtype == object


def test_units_follow_the_names():
    """A column's unit is the one its name spells (``_N``: N, ``_V``: V, ``_Hz``: Hz, ``_s``:
    s, ``_pct``: %); names and counts have none; every column is described."""
    suffixes = {"_N": "N", "_V": "V", "_Hz": "Hz", "_s": "s", "_pct": "%", "_N2": "N^2"}
    for schema in SCHEMAS.values():
        assert set(schema.key) <= set(schema.names()), schema.file
        assert set(schema.required) <= set(schema.names()), schema.file
        for column in schema.columns:
            assert column.doc, (schema.file, column.name)
            unit = next((u for s, u in suffixes.items() if column.name.endswith(s)), None)
            if unit is not None:
                assert column.unit == unit, (schema.file, column.name)
            if column.kind != "float":
                assert column.unit == "", (schema.file, column.name)


def test_the_writer_writes_the_schemas_columns_in_order():
    schema = SCHEMAS["exponents.csv"]
    df = pd.DataFrame({"exponent": [2.0], "subject": ["P01"], "extra": [1]})
    text = schema.text(df)
    assert text.splitlines()[0] == ",".join(schema.names())
    assert text.splitlines()[1] == "P01,,,2.0,,,"


_TEXT = st.text(st.characters(codec="utf-8", exclude_categories=("Cs",)), min_size=1,
                max_size=8).filter(lambda s: s.strip() == s and s != "")
_FLOAT = st.floats(allow_nan=True, allow_infinity=False, width=64)


@st.composite
def _tables(draw, schema: TableSchema) -> pd.DataFrame:
    n = draw(st.integers(1, 5))
    columns = {}
    for c in schema.columns:
        if c.kind == "text":
            values = draw(st.lists(st.one_of(st.none(), _TEXT, st.sampled_from(
                ["NA", "nan", "None", "N/A", "null", "1e3", "a,b", 'say "x"'])),
                min_size=n, max_size=n))
        elif c.kind == "count":
            values = draw(st.lists(st.one_of(st.none(), st.integers(-2**53, 2**53)),
                                   min_size=n, max_size=n))
        elif c.kind == "flag":
            values = draw(st.lists(st.booleans(), min_size=n, max_size=n))
        else:
            values = draw(st.lists(_FLOAT, min_size=n, max_size=n))
        columns[c.name] = values
    return schema.typed(pd.DataFrame(columns))


@given(st.sampled_from(list(SCHEMAS.values())).flatmap(
    lambda schema: st.tuples(st.just(schema), _tables(schema))))
def test_a_table_written_and_read_back_is_the_same(drawn):
    """Whatever a table holds (names such as ``NA``, ``nan`` or ``None``, commas and quotes,
    counts to 2^53, any float), written by its schema and read back it is the same table:
    the same types, every float equal to the last bit, a missing cell missing."""
    schema, table = drawn
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / schema.file
        path.write_text(schema.text(table), encoding="utf-8")
        back = schema.read(path, complete=True)
    pd.testing.assert_frame_equal(back, table, check_exact=True)


def test_the_analysis_tables_names_are_their_text_columns():
    assert set(TEXT_COLUMNS) == {c.name for s in ANALYSIS_TABLES for c in s.columns
                                 if c.kind == "text"}
