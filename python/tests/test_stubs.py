"""The type stubs (_lec6.pyi) describe the module as it is: the same classes,
the same public members, the same parameters; every public call has a
docstring. Editors complete and show help from these."""

import ast
import inspect
import os

import lec6
from lec6 import _lec6

STUB = os.path.join(os.path.dirname(lec6.__file__), "_lec6.pyi")


def stub_tree():
    with open(STUB) as f:
        return ast.parse(f.read())


def stub_classes():
    out = {}
    for node in stub_tree().body:
        if isinstance(node, ast.ClassDef):
            members = set()
            for item in node.body:
                if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    members.add(item.name)
                elif isinstance(item, ast.AnnAssign):
                    members.add(item.target.id)
            out[node.name] = members
    return out


def public(names):
    return {n for n in names if not n.startswith("_")}


def test_the_stub_has_every_class_and_no_other():
    runtime = {n for n, v in vars(_lec6).items() if inspect.isclass(v)}
    assert set(stub_classes()) == runtime


def test_every_public_member_is_in_the_stub():
    errors = {"args", "with_traceback", "add_note"}  # BaseException's own
    for name, members in stub_classes().items():
        cls = getattr(_lec6, name)
        if issubclass(cls, BaseException):
            runtime = public(vars(cls)) - errors
        else:
            runtime = public(n for n in dir(cls) if n not in dir(object))
        assert public(members) >= runtime, (name, runtime - public(members))
        assert public(members) <= runtime | {"kind", "code", "codes", "alarms", "result",
                                             "errors", "report", "file", "line", "column",
                                             "field", "rule"}, (name, public(members) - runtime)


def test_functions_and_parameters_match():
    functions = {n.name: n for n in stub_tree().body if isinstance(n, ast.FunctionDef)}
    assert set(functions) == {"open_bus"}
    for cls in stub_tree().body:
        if not isinstance(cls, ast.ClassDef) or issubclass(getattr(_lec6, cls.name), BaseException):
            continue
        for fn in cls.body:
            if not isinstance(fn, ast.FunctionDef) or fn.name.startswith("_"):
                continue
            if any(isinstance(d, ast.Name) and d.id == "property" for d in fn.decorator_list):
                continue
            stub_params = [a.arg for a in fn.args.args + fn.args.kwonlyargs if a.arg != "self"]
            doc = getattr(getattr(_lec6, cls.name), fn.name).__doc__
            # pybind11 puts the signature first in the docstring: name(self, a: T, b: T = ...)
            signature = doc.splitlines()[0]
            for p in stub_params:
                assert f"{p}:" in signature or f"{p} :" in signature, (cls.name, fn.name, p, signature)


def test_public_calls_have_docstrings():
    missing = []
    for name in ("Axis", "Bus", "Twin", "StepTable", "Step"):
        cls = getattr(_lec6, name)
        for member in public(vars(cls)):
            obj = getattr(cls, member)
            if callable(obj) and not isinstance(obj, type):
                doc = (obj.__doc__ or "").splitlines()
                if len([line for line in doc if line.strip()]) < 2:  # more than the signature
                    missing.append(f"{name}.{member}")
    assert missing == []
