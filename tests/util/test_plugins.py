"""Plug-ins are found through their entry points once per process; one that fails to import
is said and skipped, never stopping evtribo."""

from __future__ import annotations

import logging

import pytest

from _plugins import install
from evtribo.util import plugins

GROUP = "evtribo.test_things"


@pytest.fixture(autouse=True)
def _forget():
    plugins.forget()
    yield
    plugins.forget()


def test_a_plug_in_s_object_is_found_through_its_entry_point(tmp_path, monkeypatch):
    install(tmp_path, monkeypatch, "mylab_things", "THING = {'name': 'mylab'}\n",
            entry_points={GROUP: {"mylab": "mylab_things:THING"}})
    assert plugins.load(GROUP) == [("mylab", {"name": "mylab"})]
    assert plugins.load("evtribo.no_such_group") == []


def test_entry_points_are_read_once_per_process(tmp_path, monkeypatch):
    assert plugins.load(GROUP) == []
    install(tmp_path, monkeypatch, "mylab_late", "THING = 1\n",
            entry_points={GROUP: {"late": "mylab_late:THING"}})
    assert plugins.load(GROUP) == [("late", 1)]  # install() forgot what was read
    (tmp_path / "site" / "mylab_late.py").write_text("THING = 2\n", encoding="utf-8")
    assert plugins.load(GROUP) == [("late", 1)]  # not imported again


def test_a_plug_in_that_fails_to_import_is_said_and_skipped(tmp_path, monkeypatch, caplog):
    install(tmp_path, monkeypatch, "mylab_broken", "raise RuntimeError('no licence file')\n",
            entry_points={GROUP: {"broken": "mylab_broken:THING", "fine": "json:dumps"}})
    with caplog.at_level(logging.WARNING, logger="evtribo.util.plugins"):
        found = plugins.load(GROUP)
    import json

    assert found == [("fine", json.dumps)]
    [record] = caplog.records
    assert "broken = mylab_broken:THING" in record.getMessage()
    assert "RuntimeError: no licence file" in record.getMessage()


def _registry():
    things = plugins.Registry(GROUP, "thing", check=lambda o: o if isinstance(o, int) else None,
                              key=lambda entry, thing: entry)
    things.register("one", 1)
    return things


def test_a_registry_reads_its_plug_ins_only_for_a_name_its_builtins_lack(tmp_path, monkeypatch):
    things = _registry()
    read = []
    real = plugins.load
    monkeypatch.setattr(plugins, "load", lambda group: read.append(group) or real(group))
    assert things["one"] == 1 and "one" in things and not read  # a builtin: no scan
    install(tmp_path, monkeypatch, "mylab_more", "TWO = 2\nWORD = 'two'\n",
            entry_points={GROUP: {"two": "mylab_more:TWO", "word": "mylab_more:WORD"}})
    assert things["two"] == 2 and read == [GROUP]
    assert list(things) == ["one", "two"] and read == [GROUP]  # read once
    assert things.is_plugin("two") and not things.is_plugin("one")
    with pytest.raises(KeyError):
        things["three"]
    with pytest.raises(ValueError, match="thing 'one' is registered already"):
        things.register("one", 1)
    with pytest.raises(ValueError, match="'x' is not a thing"):
        things.register("x", "x")
    plugins.forget()  # the plug-ins read again at the next look; the builtins stay
    assert "two" not in things._things and dict(things) == {"one": 1, "two": 2}
    things.unregister("two")
    assert "two" not in things._things
