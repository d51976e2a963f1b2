"""The API reference, written from the docstrings: ``python3 -m grubler.apidoc -o docs/api``.

The public API is the names in the ``__all__`` of each module of
:data:`PUBLIC_MODULES`; everything else is the package's inside and may change.
Each public module becomes one Markdown page (its docstring, then every public
name's signature and docstring, a class's public methods and properties under
it) and ``index.md`` lists them all with their one-line summaries. Nothing but
the standard library: :mod:`inspect` reads the signatures, and the numpydoc
sections (``Parameters``, ``Returns``, ``Examples``, ...) become Markdown
headings, their ``>>>`` lines code blocks. The pages depend only on the
docstrings and signatures, so two builds of the same sources are the same bytes.

Examples
--------
>>> import tempfile, pathlib
>>> from grubler.apidoc import build
>>> with tempfile.TemporaryDirectory() as d:
...     pages = build(d, modules=["grubler.studies.sizing"])
...     text = (pathlib.Path(d) / "grubler.studies.sizing.md").read_text()
>>> [p.name for p in pages]
['grubler.studies.sizing.md', 'index.md']
>>> "### `required_drive(model: Mechanism, cycle: DutyCycle) -> DriveDemand`" in text
True
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import re
import sys
from pathlib import Path

# the modules whose __all__ is the public API, in the order the index lists them
PUBLIC_MODULES = [
    "grubler",
    "grubler.mechanism.scene",
    "grubler.mechanism.inverse",
    "grubler.mechanism.instant",
    "grubler.mechanism.spatial",
    "grubler.mechanism.spatial_scene",
    "grubler.studies.sizing",
    "grubler.studies.cylinder_sizing",
    "grubler.studies.sweep",
    "grubler.system.ssp",
    "grubler.system.cosim",
    "grubler.system.container",
    "grubler.system.native",
    "grubler.system.servo",
    "grubler.system.cylinder_servo",
    "grubler.system.fmu_state",
    "grubler.views.plotting",
    "grubler.views.report",
    "grubler.views.animation",
    "grubler.views.runs",
    "grubler.views.perspective",
    "grubler.fmi.build",
    "grubler.fmi.mechanism",
    "grubler.fmi.motor",
    "grubler.motors",
    "grubler.motors.hydraulic",
    "grubler.motors.pneumatic",
    "grubler.controllers",
    "grubler.controllers.law",
    "grubler.controllers.fmu",
]

# numpydoc's section titles: a title underlined by dashes becomes a heading
_UNDERLINE = re.compile(r"^\s*-{3,}\s*$")
# the sections that list names, each ``name : type`` over its indented description
_LISTS = {"Parameters", "Returns", "Yields", "Raises", "Attributes", "Other Parameters", "Warns"}
# a default value printed as an object's address differs between runs
_ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+")


def public_names(module) -> list[str]:
    """The public names of ``module``: its ``__all__``, in that order.

    Examples
    --------
    >>> import grubler
    >>> from grubler.apidoc import public_names
    >>> "simulate" in public_names(grubler)
    True
    """
    names = getattr(module, "__all__", None)
    if names is None:
        raise ValueError(f"{module.__name__} is a public module but declares no __all__")
    return list(names)


def signature(obj, name: str) -> str:
    """``name(parameters) -> return``, as :func:`inspect.signature` reads it (``name`` alone if it cannot).

    Examples
    --------
    >>> from grubler.apidoc import signature
    >>> def f(x, n=3) -> int: ...
    >>> signature(f, "f")
    'f(x, n=3) -> int'
    """
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return name
    # under `from __future__ import annotations` the annotations are strings: shown as written, unquoted
    def written(a):
        return a if a is inspect.Parameter.empty else _Written(a)

    sig = sig.replace(parameters=[p.replace(annotation=written(p.annotation)) for p in sig.parameters.values()],
                      return_annotation=written(sig.return_annotation))
    return name + _ADDRESS.sub("", str(sig))


class _Written:
    """An annotation that prints as its source text (a string one without quotes)."""

    def __init__(self, annotation):
        self.annotation = annotation

    def __repr__(self):
        a = self.annotation
        if isinstance(a, str):  # a forward reference written as a string: 'DutyCycle'
            return a[1:-1] if len(a) > 1 and a[0] == a[-1] and a[0] in "'\"" else a
        return inspect.formatannotation(a)


def summary(obj) -> str:
    """The first line of an object's docstring ('' without one).

    Examples
    --------
    >>> from grubler.apidoc import summary
    >>> summary(summary)
    "The first line of an object's docstring ('' without one)."
    """
    doc = inspect.getdoc(obj) or ""
    return doc.strip().splitlines()[0] if doc.strip() else ""


def markdown(doc: str, level: int = 4) -> str:
    """A numpydoc docstring as Markdown: section titles as headings, ``>>>`` blocks fenced.

    Examples
    --------
    >>> from grubler.apidoc import markdown
    >>> markdown("Add one.\\n\\nExamples\\n--------\\n>>> 1 + 1\\n2").splitlines()
    ['Add one.', '', '#### Examples', '', '```python', '>>> 1 + 1', '2', '```']
    """
    lines = doc.splitlines()
    out, k, section = [], 0, ""
    while k < len(lines):
        line = lines[k]
        if k + 1 < len(lines) and line.strip() and _UNDERLINE.match(lines[k + 1]):
            section = line.strip()
            out += ["#" * level + " " + section, ""]
            k += 2
            continue
        if section in _LISTS and line.strip():
            # ``name : type`` as a list item, its description under it
            out.append(f"- `{line.strip()}`" if not line[0].isspace() else "  " + line.strip())
            k += 1
            continue
        if line.lstrip().startswith(">>>"):
            block = []
            while k < len(lines) and lines[k].strip():  # a doctest runs to the next blank line
                block.append(lines[k])
                k += 1
            out += ["```python", *block, "```"]
            continue
        out.append(line)
        k += 1
    return "\n".join(out).strip() + "\n"


def _members(cls) -> list[tuple[str, object]]:
    """A class's own public methods and properties, in the order it defines them."""
    found = []
    for name, value in vars(cls).items():
        if name.startswith("_"):
            continue
        if isinstance(value, (staticmethod, classmethod)):
            value = value.__func__
        if inspect.isfunction(value) or isinstance(value, property):
            found.append((name, value))
    return found


def module_page(module_name: str) -> str:
    """One module's page: its docstring, then each public name's signature and docstring.

    Examples
    --------
    >>> from grubler.apidoc import module_page
    >>> page = module_page("grubler.mechanism.inverse")
    >>> page.splitlines()[0]
    '# `grubler.mechanism.inverse`'
    >>> "## drive_demand" in page
    True
    """
    module = importlib.import_module(module_name)
    parts = [f"# `{module_name}`", "", markdown(inspect.getdoc(module) or "", level=3)]
    for name in public_names(module):
        obj = getattr(module, name)
        kind = "class" if inspect.isclass(obj) else "function" if callable(obj) else "data"
        parts += [f"## {name}", "", f"*{kind}*" + (f", defined in `{obj.__module__}`"
                                                    if getattr(obj, "__module__", module_name) != module_name else ""), ""]
        if kind == "data":
            parts += ["```python", f"{name} = {_ADDRESS.sub('', repr(obj))}", "```", ""]
            continue
        parts += [f"### `{signature(obj, name)}`", "", markdown(inspect.getdoc(obj) or "", level=4)]
        if kind == "class":
            for member, value in _members(obj):
                if isinstance(value, property):
                    head = f"{name}.{member}` *(property)*"
                else:
                    head = signature(value, f"{name}.{member}") + "`"
                parts += [f"#### `{head}", "", markdown(inspect.getdoc(value) or "", level=5)]
    return "\n".join(parts)


def anchor(name: str, seen: dict[str, int]) -> str:
    """The anchor a Markdown renderer gives heading ``## name``: lower case, ``-1`` on from the second alike.

    Examples
    --------
    >>> from grubler.apidoc import anchor
    >>> seen = {}
    >>> anchor("Grashof", seen), anchor("grashof", seen)     # a class and a function on one page
    ('grashof', 'grashof-1')
    """
    key = name.lower()
    n = seen.get(key, 0)
    seen[key] = n + 1
    return key if n == 0 else f"{key}-{n}"


def index_page(modules) -> str:
    """``index.md``: every public module and name, each with its one-line summary.

    Examples
    --------
    >>> from grubler.apidoc import index_page
    >>> page = index_page(["grubler.mechanism.inverse"])
    >>> [line.split("]")[0] for line in page.splitlines() if line.startswith(("#", "-"))]
    ['# grubler API reference', '## [`grubler.mechanism.inverse`', '- [`DriveDemand`', '- [`drive_demand`']
    """
    parts = ["# grubler API reference", "",
             "The public names: each module's `__all__`. Built from the docstrings by "
             "`python3 -m grubler.apidoc -o docs/api`.", ""]
    for module_name in modules:
        module = importlib.import_module(module_name)
        parts += [f"## [`{module_name}`]({module_name}.md)", "", summary(module), ""]
        seen: dict[str, int] = {}
        for name in public_names(module):
            obj = getattr(module, name)
            parts.append(f"- [`{name}`]({module_name}.md#{anchor(name, seen)}): "
                         f"{summary(obj) if callable(obj) else ''}".rstrip())
        parts.append("")
    return "\n".join(parts)


def build(out_dir, modules=None) -> list[Path]:
    """Write one page per public module and ``index.md`` into ``out_dir``; the paths written.

    Examples
    --------
    >>> import tempfile
    >>> from grubler.apidoc import build
    >>> with tempfile.TemporaryDirectory() as d:
    ...     [p.name for p in build(d, modules=["grubler.motors"])]
    ['grubler.motors.md', 'index.md']
    """
    modules = list(PUBLIC_MODULES if modules is None else modules)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name in modules:
        path = out / f"{name}.md"
        path.write_text(module_page(name), encoding="utf-8")
        written.append(path)
    index = out / "index.md"
    index.write_text(index_page(modules), encoding="utf-8")
    return written + [index]


def main(argv=None) -> int:
    """``python3 -m grubler.apidoc -o DIR``: build the reference, print where.

    Examples
    --------
    >>> import tempfile
    >>> from grubler.apidoc import main
    >>> with tempfile.TemporaryDirectory() as d:
    ...     main(["-o", d, "--module", "grubler.motors"])  # doctest: +ELLIPSIS
    wrote 2 pages to .../index.md
    0
    """
    parser = argparse.ArgumentParser(prog="python3 -m grubler.apidoc", description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--out", default="docs/api", help="folder to write the pages into (default docs/api)")
    parser.add_argument("--module", action="append", help="only this public module (repeatable)")
    args = parser.parse_args(argv)
    pages = build(args.out, args.module)
    print(f"wrote {len(pages)} pages to {pages[-1]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
