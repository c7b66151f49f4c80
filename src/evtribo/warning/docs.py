"""``docs/warnings.md`` written from the catalogue: every kind of warning, by area, with
what it does to the results, what it is said of, its wording and fields, and what to do.

``python scripts/warnings_doc.py`` writes the page (``--check``: exit 1 when it is out of
date); a test holds the page to :func:`page`.
"""

from __future__ import annotations

from collections.abc import Iterable

from evtribo.warning.catalogue import AREAS
from evtribo.warning.kind import Kind
from evtribo.warning.record import EFFECTS

__all__ = ["INTRO", "page"]

INTRO = """\
# Warnings

The kinds of warning evtribo says about a result, each with its id, what it does to the
reported numbers, what it is said of, its wording and what to do about it. The effect is
one of:

- **may change a reported number** (`number`): a number may be off by more than its
  interval says (an unknown zero, a trial left out, roles swapped);
- **widens an interval** (`interval`): the interval holds it (few windows, scattered
  friction);
- **for information** (`information`): corrected or harmless (offsets removed, drifts
  followed, frames lost).

The report and `evtribo analyze`'s console say each kind once, with the trials or cells it
concerns, the kinds that may change a number first.

A warning's text starts with what it was said of: `P01/run-03: ` (a trial), `P01 (square,
10000 Hz) at 60 V: ` (a cell), `P01 (square, 10000 Hz): ` (a drive), `P01: ` (a subject),
nothing for the study; a kind whose wording names its file starts with the file. In the
wordings, `{name}` is a value, `{name:.2f}` the value to two decimals, `{name!r}` quoted,
`{name:plural}` an *s* unless the value is 1, `{name:duration}` seconds said in hours,
minutes or seconds.

A lab's plug-in adds kinds of its own through the entry point group
`evtribo.warning_kinds` (a `Kind` of `evtribo.warning.catalogue`, or a list of them). This
page is written from the catalogue (`src/evtribo/warning/kinds_*.py`) by
`python scripts/warnings_doc.py`.
"""

#: What a kind is said of, in words, and its text's prefix there.
_OF = {"study": ("the study", ""), "subject": ("a subject", "P01: "),
       "drive": ("a subject's drive", "P01 (square, 10000 Hz): "),
       "cell": ("a cell (a subject's drive at one amplitude)",
                "P01 (square, 10000 Hz) at 60 V: "),
       "trial": ("a trial", "P01/run-03: ")}


def _kind(k: Kind) -> list[str]:
    of, prefix = _OF[k.scope]
    effect = EFFECTS[k.effect]
    lines = [f"### `{k.id}`: {k.title}", "",
             f"*{effect[0].upper()}{effect[1:]}* (`{k.effect}`); said of {of}.", ""]
    if k.earlier:
        lines += ["Only in results written by earlier versions of evtribo, which kept each "
                  "warning as a line of text: the line as it was."]
    else:
        after = f", after `{prefix}`," if k.prefixed and prefix else ""
        fields = ", ".join(f"`{f}`" for f in k.fields)
        lines += [f"Says{after} `{k.wording}`" + (f" (fields {fields})." if fields else ".")]
    if k.stands_for:
        named = ", ".join(f"`{s}`" for s in k.stands_for)
        lines += ["", f"It stands for what evtribo now says as {named}." if k.earlier else
                  f"In results of earlier versions it also stands for {named}."]
    return [*lines, "", f"What to do: {k.todo}", ""]


def page(areas: Iterable[tuple[str, Iterable[Kind]]] | None = None) -> str:
    """The page: the introduction, then each area's kinds.

    Parameters
    ----------
    areas : iterable of (str, iterable of Kind), optional
        The areas and their kinds (default: the builtin catalogue's,
        :data:`~evtribo.warning.catalogue.AREAS`).

    Returns
    -------
    str
        Markdown, ending with a newline.
    """
    lines = [INTRO]
    for title, kinds in (AREAS.items() if areas is None else areas):
        lines += [f"## {title}", ""]
        for k in kinds:
            lines += _kind(k)
    return "\n".join(lines).rstrip("\n") + "\n"
