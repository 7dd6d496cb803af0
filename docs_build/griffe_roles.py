"""A griffe extension for the API page: Sphinx roles as cross-references, no private bases.

The package's numpy-style docstrings name other objects with Sphinx roles
(``:func:`simulate```, ``:class:`~granular_chain.result.Result```). mkdocstrings
renders Markdown, where a role would show as raw text, so each role becomes the
target as inline code wrapped in an *optional* autorefs cross-reference: a link
where the target is documented on the site, plain inline code where it is not
(never a broken link, never a strict-build warning). The target's last
component is shown for ``~a.b.c`` (Sphinx's convention), the whole name
otherwise.

Classes whose bases are private (``Scene(_Strict)``) list only their public
bases: a private helper class is not part of the interface the page documents.

Loaded by mkdocs.yml (``extensions: [docs_build/griffe_roles.py:SphinxRoles]``);
the docstrings themselves are left as they are.
"""

from __future__ import annotations

import html
import re

import griffe

#: ``:role:`target``` with the roles the package uses (``py:`` domain prefix allowed).
ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|data|attr|exc|obj|const):`(?P<target>[^`]+)`")


def rewrite(text: str, module: str, scope: str | None = None) -> str:
    """``text`` with every Sphinx role replaced by an optional cross-reference.

    Parameters
    ----------
    text : str
        A docstring.
    module : str
        Dotted path of the module the docstring belongs to: a relative target
        (``simulate``, ``.result.Result``) is looked up from there.
    scope : str, optional
        Dotted path of the class the docstring belongs to (its own or its
        member's): an ``:attr:`` or ``:meth:`` without a dot names a member of it.

    Returns
    -------
    str
        The docstring with ``<autoref identifier="ID" optional><code>NAME</code></autoref>``
        (resolved by mkdocs-autorefs) where each role was.
    """
    def replace(match: re.Match) -> str:
        target = match.group("target").strip()
        # Sphinx's "title <target>" form
        explicit = re.fullmatch(r"(?P<title>.+?)\s*<(?P<to>[^>]+)>", target)
        title, target = (explicit["title"], explicit["to"]) if explicit else (None, target)
        short = target.startswith("~")
        target = target.lstrip("~").rstrip("()")
        if title is None:
            title = target.rsplit(".", 1)[-1] if short else target
            if match.group(0).startswith((":func:", ":meth:", ":py:func:", ":py:meth:")):
                title += "()"
        identifier = target.lstrip(".")
        member = match.group(0).startswith((":attr:", ":meth:", ":py:attr:", ":py:meth:"))
        if scope and member and "." not in identifier:
            identifier = f"{scope}.{identifier}"
        elif not identifier.startswith("granular_chain"):
            identifier = f"{module}.{identifier}"
        return (f'<autoref identifier="{html.escape(identifier, quote=True)}" optional>'
                f"<code>{html.escape(title)}</code></autoref>")
    return ROLE.sub(replace, text)


def _module_of(obj) -> str:
    while obj is not None and not obj.is_module:
        obj = obj.parent
    return obj.path if obj is not None else ""


def _class_of(obj) -> str | None:
    """The class ``obj`` is or belongs to, else None."""
    if obj.is_class:
        return obj.path
    return obj.parent.path if obj.parent is not None and obj.parent.is_class else None


class SphinxRoles(griffe.Extension):
    """Rewrite Sphinx roles in every docstring; drop private base classes."""

    def on_instance(self, *, obj, **kwargs) -> None:  # noqa: D102 (griffe hook)
        if obj.docstring is not None and ":" in obj.docstring.value:
            obj.docstring.value = rewrite(obj.docstring.value, _module_of(obj),
                                          _class_of(obj))
        if obj.is_class:
            obj.bases = [base for base in obj.bases
                         if not str(base).rsplit(".", 1)[-1].startswith("_")]
