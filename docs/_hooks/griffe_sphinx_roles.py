"""Griffe extension: Sphinx cross-reference roles in numpydoc docstrings become mkdocs cross-references.

The docstrings write references as numpydoc (and Sphinx) do, e.g. ``:data:`~pytdcr.statics.MODELS```. The API
reference is built by mkdocstrings-python, which does not read those roles, so this extension rewrites each one,
once a package is loaded, into an *optional* autorefs cross-reference::

    <autoref identifier="pytdcr.statics.MODELS" optional>`MODELS`</autoref>

The identifier is the object's full, canonical path, resolved by griffe from the docstring's own scope (the
object, its class, its module and the modules above, and the names each imports). mkdocs-autorefs turns it into a
link when the object is rendered on the site, and into plain code (no warning, so ``mkdocs --strict`` holds)
when it is not, e.g. a private helper. A target griffe cannot resolve (``numpy.ndarray``, a builtin, a typo)
becomes plain code.

Rules, as in Sphinx: ``~a.b.c`` shows ``c``; ``!name`` is never linked; ``title <target>`` shows ``title``; a
leading dot (``.sibling.Name``) is looked up relative to the enclosing module, then to the modules above.

Loaded by the mkdocstrings handler (``options: extensions: [docs/_hooks/griffe_sphinx_roles.py:SphinxRoles]``
in mkdocs.yml), and by ``tests/test_docs_reference.py``.
"""

from __future__ import annotations

import html
import re
from collections.abc import Iterator
from typing import Any

import griffe

#: A Sphinx role of the Python domain (``:func:``, ``:py:class:`` ...) with its target in backquotes.
ROLE = re.compile(
    r":(?:py:)?(?P<role>func|class|data|meth|attr|mod|exc|obj|const|type|ref):`(?P<target>[^`]+)`"
)

#: Any role left over in a text, of any domain: what must not reach the site.
RAW_ROLE = re.compile(r":[a-z]+(?::[a-z]+)?:`[^`]*`")


def _lookup(collection: Any, path: str) -> griffe.Object | None:
    """The object at ``path`` (aliases followed to their final target), or None when there is none."""
    try:
        found = collection.get_member(path)
    except (KeyError, ValueError, AttributeError, griffe.AliasResolutionError, griffe.CyclicAliasError):
        return None
    if found is None:
        return None
    if found.is_alias:
        try:
            found = found.final_target
        except (griffe.AliasResolutionError, griffe.CyclicAliasError):
            return None
    return found


def _scopes(obj: griffe.Object) -> Iterator[griffe.Object]:
    """``obj`` and its parents, innermost first."""
    scope: griffe.Object | None = obj
    while scope is not None:
        yield scope
        scope = scope.parent


def resolve_target(target: str, obj: griffe.Object, collection: Any) -> str | None:
    """The canonical path of the object ``target`` names in ``obj``'s docstring, or None.

    Parameters
    ----------
    target
        The role's target, without ``~``/``!`` or a title: ``solve``, ``Robot.from_json``,
        ``pytdcr.statics.MODELS``, ``._guard.Guard``.
    obj
        The object whose docstring holds the reference (names resolve from its scope outwards).
    collection
        The modules collection the package was loaded into (for absolute paths and aliases).

    Returns
    -------
    str or None
        The full path of the object where it is defined, or None when griffe cannot find it.
    """
    candidates: list[str] = []
    if target.startswith("."):
        rest = target.lstrip(".")
        module = obj if obj.is_module else obj.module
        candidates += [f"{scope.path}.{rest}" for scope in _scopes(module)]
    else:
        head, _, tail = target.partition(".")
        for scope in _scopes(obj):
            try:
                base = scope.resolve(head)
            except (griffe.NameResolutionError, griffe.AliasResolutionError):
                continue
            candidates.append(f"{base}.{tail}" if tail else base)
            break
        candidates.append(target)
        candidates += [f"{scope.path}.{target}" for scope in _scopes(obj) if not scope.is_function]
    for path in candidates:
        found = _lookup(collection, path)
        if found is not None:
            return found.path
    return None


def convert(text: str, obj: griffe.Object, collection: Any) -> str:
    """``text`` with every Sphinx role replaced by a cross-reference or by plain code.

    Parameters
    ----------
    text
        A docstring.
    obj
        The object the docstring belongs to.
    collection
        The modules collection the package was loaded into.

    Returns
    -------
    str
        The docstring, each ``:role:`target``` now ``<autoref identifier="full.path" optional>`shown`</autoref>``
        when griffe resolves the target, or ``` `shown` ``` when it does not.
    """

    def replace(match: re.Match[str]) -> str:
        target = " ".join(match["target"].split())  # a target wrapped across lines
        shown = None
        titled = re.fullmatch(r"(?P<title>.+?)\s*<(?P<target>[^<>]+)>", target)
        if titled:
            shown, target = titled["title"], titled["target"]
        target = target.replace(" ", "")
        link = not target.startswith("!")
        target = target.lstrip("!")
        if target.startswith("~"):
            target = target[1:]
            shown = shown or target.rpartition(".")[2]
        shown = shown or target
        code = f"`{shown}`"
        path = resolve_target(target, obj, collection) if link else None
        if path is None:
            return code
        return f'<autoref identifier="{html.escape(path)}" optional>{code}</autoref>'

    return ROLE.sub(replace, text)


def _objects(obj: griffe.Object) -> Iterator[griffe.Object]:
    """``obj`` and every object defined under it (aliases skipped: their target is visited where defined)."""
    yield obj
    for member in list(obj.members.values()):
        if not member.is_alias:
            yield from _objects(member)


class SphinxRoles(griffe.Extension):
    """Rewrite the Sphinx roles of every docstring of a loaded package into cross-references."""

    def on_package(self, *, pkg: griffe.Module, loader: griffe.GriffeLoader, **kwargs: Any) -> None:
        """Convert the docstrings of ``pkg`` once all its modules are loaded (so any name can be resolved)."""
        for obj in _objects(pkg):
            docstring = obj.docstring
            if docstring is None or not ROLE.search(docstring.value):
                continue
            docstring.value = convert(docstring.value, obj, loader.modules_collection)
            docstring.__dict__.pop("parsed", None)  # parsed lazily: drop any parse of the old text
