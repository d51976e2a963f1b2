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
    ("assembly's damped Newton: the largest fraction of the step that lowers the violation",
     "for (double frac = 1.0; frac >= 0.0625; frac *= 0.5)", "project.h"),
    ("the assembly scratch's layout in S", "s.b = s.phi + m;", "project.h"),
    ("the batch calls' loop over states", "grb_chain(md, yi, yi + n, &w);", "chain.c"),
]


@pytest.mark.parametrize("what, statement, home", SHARED, ids=[s[0] for s in SHARED])
def test_a_shared_solve_is_written_once(what, statement, home):
    assert places(statement) == [home], what


@pytest.mark.parametrize("kernel_file, function, calls", [
    ("closure.c", "grb_branch_point", "grb_branch_point_rows("),
    ("spatial/sp_closure.c", "grs_branch_point", "grb_branch_point_rows("),
    ("closure.c", "grb_assemble", "grb_assemble_rows("),
    ("spatial/sp_closure.c", "grs_assemble", "grb_assemble_rows("),
    ("closure.c", "grb_assemble", "grb_held_rates_rows("),
    ("spatial/sp_closure.c", "grs_assemble", "grb_held_rates_rows("),
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


# -- the guard the shared assembly keeps: a held index that is not a coordinate (grb_free_columns) ---------------
@pytest.mark.parametrize("held", [[3], [-1], [0, 7]])
def test_the_planar_assembly_refuses_a_held_index_outside_the_coordinates_and_leaves_z(held):
    import ctypes

    import numpy as np

    import grubler
    from grubler import binding

    m = grubler.load_scene("thesis-fourbar").mechanism  # three coordinates
    z, zd = np.array([0.5, 0.9, 2.0]), np.zeros(3)
    before = z.copy()
    h, closest = np.array(held, dtype=np.int32), ctypes.c_double(-1.0)
    work = binding.work(m.n_links, len(m.closures))  # held here: the kernel gets only its address
    status = binding.library().grb_assemble(m.arrays.c, len(h), binding.address(h), 1.0, binding.address(z),
                                            binding.address(zd), ctypes.byref(closest), binding.address(work))
    assert status == binding.BAD_ARGUMENT
    assert z.tobytes() == before.tobytes()


@pytest.mark.parametrize("held", [(3,), (-1,), (0, 7)])
def test_the_spatial_assembly_refuses_a_held_index_outside_the_coordinates_naming_the_field(held):
    from grubler.errors import InputError
    from grubler.mechanism import spatial as sp

    m = sp.planar_fourbar()  # three coordinates
    with pytest.raises(InputError) as info:
        m.assemble(m.assembled_start()[:3], held=held)
    assert info.value.field == "held"
