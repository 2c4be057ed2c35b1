"""A Griffe extension for the API reference: Sphinx roles in docstrings rendered as code.

liebridge's numpydoc docstrings cross-reference with Sphinx roles (``:func:`read_kalibr```,
``:class:`~liebridge.frames.Transform```, ``:meth:`Transform.inverse```, ``:data:``,
``:mod:``, ``:attr:``). mkdocstrings-python renders Markdown and has no such roles: without this
extension the reference shows them raw. mkdocs.yml loads it
(``plugins: mkdocstrings: handlers: python: options: extensions``); each role becomes inline
code as Sphinx displays it: the target, ``~`` keeping its last component, a leading ``.`` or
``!`` dropped, ``()`` after functions and methods. ``tests/test_real_files_calib.py`` checks
that no docstring of the package keeps a raw role once converted.
"""

from __future__ import annotations

import re
from typing import Any

#: ``:role:`target``` and ``:py:role:`target``` (roles that Sphinx's Python domain defines).
ROLE = re.compile(
    r":(?:py:)?(func|meth|class|mod|attr|data|exc|obj|const|type)"
    r":`(?P<text>[^`<]*?)(?:\s*<(?P<target>[^`>]*)>)?`"
)
#: Anything still shaped like a role after conversion (the test's definition of "raw").
RAW_ROLE = re.compile(r":(?:py:)?[a-z]+:`")


def convert_roles(text: str) -> str:
    """Return ``text`` with each Sphinx role replaced by the inline code Sphinx would show."""

    def one(m: re.Match[str]) -> str:
        role, shown, target = m.group(1), m.group("text").strip(), m.group("target")
        if target is not None and shown:  # :role:`title <target>`: Sphinx shows the title
            return f"`{shown}`"
        name = (target or shown).lstrip("!")
        if name.startswith("~"):
            name = name[1:].rsplit(".", 1)[-1]
        name = name.lstrip(".")
        if role in ("func", "meth") and not name.endswith(")"):
            name += "()"
        return f"`{name}`"

    return ROLE.sub(one, text)


try:
    import griffe
except ImportError:  # the docs extra is not installed: convert_roles alone (for the tests)
    griffe = None

if griffe is not None:

    class SphinxRoles(griffe.Extension):  # type: ignore[misc,name-defined]
        """Convert the Sphinx roles of every docstring as Griffe loads the package."""

        def on_instance(self, *, obj: Any, **kwargs: Any) -> None:
            """Rewrite ``obj``'s docstring in place (before the handler parses its sections)."""
            doc = getattr(obj, "docstring", None)
            if doc is not None and ":" in doc.value:
                doc.value = convert_roles(doc.value)
