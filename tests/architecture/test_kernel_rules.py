"""The two rules that keep numba's parallel loops correct with bundles (docs/architecture.md,
"Kernels and bundles"), checked on the source: a `prange` loop body reads no bundle member
directly and calls no `inline="always"` function that takes a bundle. Each rule was found
by the bit-level fingerprint test as a wrong result, not as an error, so a slip would not
announce itself."""

from __future__ import annotations

import ast

import pytest

from ..conftest import ROOT

pytestmark = pytest.mark.architecture

ARRAY_ATTRS = {"shape", "size", "ndim", "dtype"}
MODULE_NAMES = {"np", "numba"}


def functions():
    for path in sorted((ROOT / "mpmsim").rglob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef):
                yield path.relative_to(ROOT), node


def is_inline(fn: ast.FunctionDef) -> bool:
    return any("inline" in ast.unparse(d) and "always" in ast.unparse(d) for d in fn.decorator_list)


def member_reads(node) -> set[str]:
    """name.attr reads in node, other than array attributes and module functions."""
    out = set()
    for sub in ast.walk(node):
        if (isinstance(sub, ast.Attribute) and isinstance(sub.value, ast.Name) and sub.value.id not in MODULE_NAMES
                and sub.attr not in ARRAY_ATTRS):
            out.add(f"{sub.value.id}.{sub.attr}")
    return out


def bundle_takers() -> set[str]:
    """inline="always" functions that read members of a parameter (take a bundle)."""
    out = set()
    for _, fn in functions():
        if is_inline(fn):
            params = {a.arg for a in fn.args.args}
            if any(read.split(".")[0] in params for read in member_reads(fn)):
                out.add(fn.name)
    return out


def prange_bodies():
    for path, fn in functions():
        for node in ast.walk(fn):
            if (isinstance(node, ast.For) and isinstance(node.iter, ast.Call)
                    and getattr(node.iter.func, "id", "") == "prange"):
                yield f"{path}:{node.lineno} ({fn.name})", node


def test_parallel_loop_bodies_read_no_bundle_members():
    bad = {where: sorted(member_reads(ast.Module(body=loop.body, type_ignores=[])))
           for where, loop in prange_bodies()}
    bad = {k: v for k, v in bad.items() if v}
    assert not bad, f"prange bodies reading bundle members (bind them to locals before the loop): {bad}"


def test_parallel_loop_bodies_call_no_inlined_bundle_takers():
    takers = bundle_takers()
    assert "target_law" in takers  # the check sees the helpers it is about (contact/plan.py)
    bad = {}
    for where, loop in prange_bodies():
        calls = {sub.func.id for sub in ast.walk(loop) if isinstance(sub, ast.Call) and isinstance(sub.func, ast.Name)}
        if calls & takers:
            bad[where] = sorted(calls & takers)
    assert not bad, f"prange bodies calling inline='always' functions that take bundles: {bad}"
