"""How to cite evtribo and the model it implements, as text and as BibTeX.

Two works: the software (this version of evtribo) and the seed paper whose model
:mod:`evtribo.model` implements and ``evtribo compare`` fits (F. Forsbach and M. Heß,
*Voltage-Induced Friction with Application to Electrovibration*, Lubricants 2019). What
``evtribo cite`` prints and the report's provenance section shows; ``CITATION.cff`` at the
repository's root says the same (the test suite holds the two together).
"""

from __future__ import annotations

from dataclasses import dataclass

from evtribo import __version__

__all__ = ["PAPER", "RELEASED", "SOFTWARE", "Work", "bibtex", "text"]

#: The day this version was released (ISO 8601), as CHANGELOG.md and CITATION.cff give it.
RELEASED = "2026-11-26"


@dataclass(frozen=True)
class Work:
    """A work to cite.

    Parameters
    ----------
    key : str
        Its BibTeX key.
    entry : str
        Its BibTeX entry type (``misc`` for the software, which every BibTeX style knows).
    authors : tuple of (str, str)
        Each author as (family names, given names); an author that is a body of people has
        no given names.
    title : str
        The title.
    year : int
        The year of publication (of the release, for the software).
    fields : tuple of (str, str)
        Further BibTeX fields, in order (journal, volume, number, pages, doi, version,
        note, url).
    """

    key: str
    entry: str
    authors: tuple[tuple[str, str], ...]
    title: str
    year: int
    fields: tuple[tuple[str, str], ...] = ()

    def field(self, name: str) -> str | None:
        """One of :attr:`fields` by name.

        Parameters
        ----------
        name : str
            The field's BibTeX name.

        Returns
        -------
        str or None
            Its value, None when the work has no such field.
        """
        return dict(self.fields).get(name)


#: evtribo itself, at this version.
SOFTWARE = Work(
    key="evtribo", entry="misc", authors=(("The evtribo developers", ""),),
    title="evtribo: tribometer experiments on electrovibration", year=int(RELEASED[:4]),
    fields=(("version", __version__), ("note", f"Python package, version {__version__}"),
            ("url", "https://pypi.org/project/evtribo/")))

#: The seed paper: the model evtribo implements (equations 1-13, Table 1).
PAPER = Work(
    key="forsbach2019", entry="article",
    authors=(("Forsbach", "Fabian"), ("Heß", "Markus")),
    title="Voltage-Induced Friction with Application to Electrovibration", year=2019,
    fields=(("journal", "Lubricants"), ("volume", "7"), ("number", "12"), ("pages", "102"),
            ("doi", "10.3390/lubricants7120102"),
            ("url", "https://doi.org/10.3390/lubricants7120102")))


def _initials(given: str) -> str:
    return " ".join(f"{part[0]}." for part in given.split())


def _names(work: Work) -> str:
    names = [f"{family}, {_initials(given)}" if given else family
             for family, given in work.authors]
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + ", & " + names[-1]


def text(work: Work) -> str:
    """A work's citation as one line of text (APA-like: authors, year, title, where).

    Parameters
    ----------
    work : Work
        :data:`SOFTWARE`, :data:`PAPER` or another work.

    Returns
    -------
    str
        The citation.
    """
    out = f"{_names(work)} ({work.year}). {work.title}"
    journal, doi = work.field("journal"), work.field("doi")
    if journal:
        out += f". {journal}, {work.field('volume')}({work.field('number')}), "
        out += f"{work.field('pages')}"
    elif work.field("version"):
        out += f" (version {work.field('version')}) [Computer software]"
    where = f"https://doi.org/{doi}" if doi else work.field("url")
    return out + (f". {where}" if where else ".")


#: Characters BibTeX needs written as commands (in names and titles).
_TEX = {"ß": r"{\ss}", "ä": r"{\"a}", "ö": r"{\"o}", "ü": r"{\"u}", "é": r"{\'e}",
        "&": r"\&", "%": r"\%", "_": r"\_", "#": r"\#"}


def _tex(value: str) -> str:
    return "".join(_TEX.get(c, c) for c in value)


def bibtex(work: Work) -> str:
    """A work's BibTeX entry.

    Parameters
    ----------
    work : Work
        :data:`SOFTWARE`, :data:`PAPER` or another work.

    Returns
    -------
    str
        The entry, ending in a newline. A body of people as author is braced, so that
        BibTeX does not take its last word for a family name.
    """
    authors = " and ".join(f"{_tex(family)}, {_tex(given)}" if given else f"{{{family}}}"
                           for family, given in work.authors)
    fields = [("author", authors), ("title", f"{{{_tex(work.title)}}}"),
              ("year", str(work.year))]
    fields += [(k, v if k in ("doi", "url") else _tex(v)) for k, v in work.fields]
    body = ",\n".join(f"  {k} = {{{v}}}" for k, v in fields)
    return f"@{work.entry}{{{work.key},\n{body}\n}}\n"
