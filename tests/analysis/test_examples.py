"""The examples in the docstrings of microg.analysis run and print what they say. Their numbers are
R's for the same data (afex, emmeans, car, rstatix, effectsize, geepack, stats; see
tests/analysis/r/reference.R) or follow by hand from the few values shown."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import microg.analysis
import microg.instruments
import microg.schema

MODULES = [microg.schema, microg.instruments] + [
    importlib.import_module(f"microg.analysis.{info.name}") for info in pkgutil.iter_modules(microg.analysis.__path__)
]


@pytest.mark.parametrize("module", MODULES, ids=lambda module: module.__name__)
def test_docstring_examples(module):
    flags = doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS
    result = doctest.testmod(module, optionflags=flags, verbose=False)
    assert result.failed == 0


def test_every_public_function_has_a_numpy_docstring_with_an_example():
    sections = ("Parameters\n    ----------", "Returns\n    -------", "Examples\n    --------\n    >>> ")
    for name in microg.analysis.__all__:
        item = getattr(microg.analysis, name)
        if callable(item) and not isinstance(item, type):
            for section in sections:
                assert section in (item.__doc__ or ""), (name, section)
