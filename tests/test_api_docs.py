"""The public API's docstrings (what the docs' API page renders, numpydoc): every function of
``pipeline`` and ``solver`` has its Parameters (when it takes any), Returns and Examples
sections, and the examples written as doctests run and give what they say."""
import doctest
import inspect

import pytest

import pipeline
import solver

PUBLIC = [(module, name) for module in (pipeline, solver) for name in module.__all__
          if inspect.isfunction(getattr(module, name))]


def _sections(doc: str) -> set:
    lines = doc.splitlines()
    return {line.strip() for line, under in zip(lines, lines[1:]) if under.strip() and set(under.strip()) == {"-"}}


@pytest.mark.parametrize("module, name", PUBLIC, ids=[f"{m.__name__}.{n}" for m, n in PUBLIC])
def test_every_public_function_has_its_numpydoc_sections(module, name):
    function = getattr(module, name)
    sections = _sections(inspect.getdoc(function) or "")
    wanted = {"Returns", "Examples"} | ({"Parameters"} if inspect.signature(function).parameters else set())
    assert wanted <= sections, f"{module.__name__}.{name} lacks {sorted(wanted - sections)}"


@pytest.mark.parametrize("function", [pipeline.study_text, solver.solve, solver.crack_onset, solver.default_eps_Y],
                         ids=lambda f: f.__name__)
def test_the_doctest_examples_run(function):
    finder, runner = doctest.DocTestFinder(), doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE)
    tests = finder.find(function, function.__name__, globs={})
    assert tests and tests[0].examples
    for test in tests:
        runner.run(test)
    assert runner.failures == 0


def test_the_section_reader():
    assert _sections("Run it.\n\nParameters\n----------\nx : int\n\nReturns\n-------\nint") == {"Parameters", "Returns"}
