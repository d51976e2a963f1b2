"""The kernel's solves that the planar and the spatial kernels share are written once (STYLE.md: one rule, one
place), and both kernels call the one text.

What the shared text computes is held by the kernels' own tests and by benchmarks/bit_identity.py (the sharing
changed no bit); this file holds the sharing itself, so that a copy written back into one kernel is seen.
"""

import re
from pathlib import Path

import pytest

KERNEL = Path(__file__).resolve().parents[1] / "fmu_src" / "kernel"


def code(path: Path) -> str:
    """A C file's text without its comments, white space folded to one blank."""
    text = re.sub(r"/\*.*?\*/", " ", path.read_text(), flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    return re.sub(r"\s+", " ", text)


def kernel_sources() -> dict[str, str]:
    return {str(p.relative_to(KERNEL)): code(p) for p in sorted(KERNEL.rglob("*.[ch]"))}


def places(statement: str) -> list[str]:
    """The kernel files that hold `statement` (folded as code() folds), once per occurrence."""
    return [name for name, text in kernel_sources().items() for _ in range(text.count(statement))]


# (what is shared, a statement of its body no other solve has, the file that holds it)
SHARED = [
    ("the branch point's Newton: it stops where the violation no longer halves",
     "if (!(err < 0.5 * previous) || err == 0.0) break;", "project.h"),
    ("the assembly scratch's layout in S", "s.b = s.phi + m;", "project.h"),
    ("the batch calls' loop over states", "grb_chain(md, yi, yi + n, &w);", "chain.c"),
]


@pytest.mark.parametrize("what, statement, home", SHARED, ids=[s[0] for s in SHARED])
def test_a_shared_solve_is_written_once(what, statement, home):
    assert places(statement) == [home], what


@pytest.mark.parametrize("kernel_file, function, calls", [
    ("closure.c", "grb_branch_point", "grb_branch_point_rows("),
    ("spatial/sp_closure.c", "grs_branch_point", "grb_branch_point_rows("),
    ("closure.c", "solve_dependent", "grb_solve_columns("),
    ("spatial/sp_closure.c", "solve_dependent", "grb_solve_columns("),
    ("chain.c", "grb_actuator_lines", "each_state("),
    ("chain.c", "grb_force_rows", "each_state("),
])
def test_each_kernel_calls_the_shared_text(kernel_file, function, calls):
    text = kernel_sources()[kernel_file]
    start = re.search(r"\b" + function + r"\([^;{]*\)\s*\{", text)
    assert start, f"{kernel_file} defines {function}"
    depth, i = 1, start.end()
    while depth:  # the function's body, to its closing brace
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        i += 1
    assert calls in text[start.end():i], f"{kernel_file}'s {function} calls {calls[:-1]}"
