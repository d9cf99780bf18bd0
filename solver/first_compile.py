"""What the first compile compiles (solver.compile.parallel_compile runs it on two cores): the
tiny case ``compile_kernels`` solves first, and the helper process's subtrees of ``integrate``
with the argument types ``integrate`` calls them at in that solve (docs/performance.md, "The
first compile"). If those types drift from ``integrate``'s, the helper's work is not used (the
results are the same, the compile is slower), and tests/test_parallel_compile.py fails."""
from __future__ import annotations

import numpy as np
from numba import typeof, types

from .compile.parallel_compile import claiming
from .control import make_control
from .diagnostics import Outputs, Records
from .fracture import compile_crack_onset
from .ending import break_inside_step, ending_event
from .loop import Energies, Observers, StepEnds, Trial, judge_step, new_state, new_workspace, observe_step
from .model.assemble import Tables
from .observe.tension import Dense
from .parameters import Parameters
from .settings import Settings
from .step import Carried, Coefficients, Start, take_step


def _field(named, name):
    """The numba type of field `name` of the named-tuple type `named`."""
    return named.types[named.fields.index(name)]


def _returns(function, *argtypes):
    """The return type of a kernel at these argument types (compiled for linking, cached)."""
    dispatcher = function.link_dispatcher
    dispatcher.compile(argtypes)
    return dispatcher.overloads[argtypes].signature.return_type


def tiny_case():
    """(Parameters, Settings, times) of the tiny case compile_kernels solves first."""
    p = Parameters(Nmod=2)
    return p, Settings(subintervals=16), np.array([0.0, p.stage_duration])


def helper_jobs():
    """The helper's subtrees, [(kernel, argument types)], in the order it compiles them (what
    ``integrate``, solver/loop.py, reaches after the initial state), with the types it calls
    them at in compile_kernels' first solve."""
    p, s, _ = tiny_case()
    model = typeof(Tables(p, s.subintervals, False, s.quadrature, s.quadrature_density).model)
    f8, i8, a1 = types.float64, types.int64, typeof(np.empty(1))
    control = typeof(make_control(0.0, 1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 1, 0.0))
    diag = _field(typeof(Outputs(*(np.empty((1, 1)),) * 3, np.empty(1), *(np.empty((1, 1)),) * 3)), "diag")
    ws = _returns(new_workspace, i8, model, i8, i8, f8)
    state = _returns(new_state, i8, i8)
    work = _field(ws, "work")
    dense = typeof(Dense(np.empty(1, np.complex128), np.empty(1), np.empty(1), np.empty(1)))
    carried = typeof(Carried(0.0, 0.0, 0.0, 0.0, 0))
    start = typeof(Start(np.empty(1, np.complex128), np.empty(1), np.empty(1)))
    records = typeof(Records(*(np.empty((1, 1)), 0) * 5))
    observers = types.NamedTuple([*(_field(ws, name) for name in ("tension", "contact", "peaks0", "zone", "dense")), i8],
                                 Observers)
    ends = types.NamedTuple((i8, i8, f8, dense), StepEnds)
    return [
        (observe_step, (model, observers, state, state, carried, f8, f8, ends, records, diag)),
        (take_step, (i8, model, typeof(Coefficients(np.empty((1, 1), np.complex128), np.empty((1, 1)))), work,
                     start, carried, f8, f8, f8, state)),
        (ending_event, (model, ws, control, start, carried, f8, f8, state, diag)),
        (break_inside_step, (model, ws, control, start, carried, f8, f8, state, diag)),
        (judge_step, (types.boolean, model, control, _field(state, "z"), state, a1, a1,
                      types.NamedTuple((i8, f8, i8, f8, f8, f8, f8), Trial), types.NamedUniTuple(f8, 3, Energies), diag)),
    ]


def run_helper() -> None:
    """The helper process (started by ``helper``, which made it die with its parent): its
    subtrees, then the crack-onset kernels."""
    with claiming():
        for function, argtypes in helper_jobs():
            function.link_dispatcher.compile(argtypes)
    compile_crack_onset()
