"""A Griffe extension for the API reference (``mkdocs.yml``: the python handler's
``extensions``): the Sphinx roles of the numpydoc docstrings become links.

The docstrings cross-reference in Sphinx's way, as numpy's and scipy's do
(``:func:`open_source```, ``:class:`~vidtrack.footage.video.VideoSource```,
``:attr:`Track.release_t_s```); mkdocstrings reads Markdown and would print the role as
text. When a package is loaded, each role in a docstring becomes an autorefs
cross-reference to the object it names, resolved as Python would from where the
docstring is (its module's imports and names, the class's members); the text is the
name as written (``~`` keeps the last part, Sphinx's rule), in code. A name that the
site does not document (a private module, numpy) stays that text, without a link.
``.ci/run`` fails when a role is left in the built pages.
"""

import html
import re

import griffe

#: ``:role:`target```, ``:role:`~target```, ``:role:`text <target>```, ``:py:role:`...```
ROLE = re.compile(r":(?:py:)?(?P<role>class|func|meth|mod|attr|data|exc|obj):"
                  r"`(?P<body>[^`]+)`")
#: Packages whose names are written out in full (not resolved from the scope).
ROOTS = ("vidtrack", "fits", "calibration")
#: Roles whose text Sphinx ends with "()".
CALLS = ("func", "meth")


def _target(obj, name, defined):
    """The full path of ``name`` as seen from ``obj``: resolved in its scope, else the one
    object of that name the package defines (a package's docstring names what it
    exports lazily); ``name`` as it is when unknown."""
    head, _, rest = name.partition(".")
    if head in ROOTS:
        return name
    try:
        path = obj.resolve(head)
    except (griffe.NameResolutionError, KeyError, AttributeError):
        paths = defined.get(head, ())
        if len(paths) != 1:
            return name
        path = paths[0]
    return f"{path}.{rest}" if rest else path


def _link(obj, match, defined):
    role, body = match["role"], match["body"].strip()
    explicit = re.fullmatch(r"(?P<text>.+?)\s*<(?P<target>[^<>]+)>", body)
    if explicit:
        text, name = explicit["text"], explicit["target"]
    else:
        name = body.lstrip("~!")
        text = name.rsplit(".", 1)[-1] if body.startswith("~") else name
        if role in CALLS and not text.endswith(")"):
            text += "()"
    if body.startswith("!"):            # Sphinx: no link wanted
        return f"<code>{html.escape(text)}</code>"
    path = _target(obj, name, defined)
    return (f'<autoref identifier="{html.escape(path, quote=True)}" optional>'
            f"<code>{html.escape(text)}</code></autoref>")


def _objects(obj):
    yield obj
    for member in obj.members.values():
        if not member.is_alias:
            yield from _objects(member)


def _rewrite(pkg):
    defined = {}
    for obj in _objects(pkg):
        if obj.parent is not None and obj.parent.is_module:     # a module's own names
            defined.setdefault(obj.name, []).append(obj.path)
    for obj in _objects(pkg):
        if obj.docstring is not None and ":" in obj.docstring.value:
            obj.docstring.value = ROLE.sub(lambda m, o=obj: _link(o, m, defined),
                                           obj.docstring.value)


class SphinxRoles(griffe.Extension):
    """Sphinx roles in docstrings to autorefs cross-references (module docstring)."""

    def on_package(self, *, pkg, loader, **kwargs):
        _rewrite(pkg)
