"""benchmarks/time_integrator.py, issue 56's measure: its report takes, for each error target,
the cheapest run of each integrator that meets it, and sets the default's error estimate beside
the errors it estimates, and the default beside the one before."""
import importlib.util

from helpers import ROOT

spec = importlib.util.spec_from_file_location("time_integrator", ROOT / "benchmarks" / "time_integrator.py")
time_integrator = importlib.util.module_from_spec(spec)
spec.loader.exec_module(time_integrator)


def _row(integrator, knob, error, time, **more):
    return dict(dict(case="c", integrator=integrator, knob=knob, time=time, steps=10, rejected=1, error=error,
                     time_error=error, status="ok", estimate_time="", estimate_quadrature="", onset_error=2e-6),
                **more)


def test_the_report_takes_the_cheapest_run_that_meets_each_target():
    rows = [_row("etd34", 1e-6, 3e-5, 0.01), _row("etd34", 1e-8, 4e-7, 0.03), _row("etd34", 1e-10, 5e-8, 0.09),
            _row("rk4", 0.2, 2e-6, 1.0), _row("rk4", 0.05, 8e-8, 4.0),
            dict(_row("default", 3e-7, 1e-6, 0.05), estimate_time=2e-6, estimate_quadrature=1e-6),
            dict(_row("previous default", 1e-9, 2e-6, 0.1), estimate_time=1e-6, estimate_quadrature=0.0)]
    assert time_integrator._cheapest(rows, "etd34", 1e-6, "error")["knob"] == 1e-8
    assert time_integrator._cheapest(rows, "etd34", 1e-8, "error") is None
    text = time_integrator.report(["- c: a note"], rows)
    assert "| c | default | 1.00e-06 | 1.00e-06 | 0.0500 | 10 (1) | 2.00 | 3.00 | 0.50 |" in text
    assert "| c | previous default | 2.00e-06 | 2.00e-06 | 0.1000 | 10 (1) | 0.50 | 0.50 | 1.00 |" in text
    assert "| c | 1e-05 | 1e-08 | 0.0300 | 0.2 | 1.0000 |" in text
    assert "| c | 1e-06 | 1e-08 | 0.0300 | 0.05 | 4.0000 |" in text
    assert "| c | 1e-07 | 1e-10 | 0.0900 | 0.05 | 4.0000 |" in text
    assert "| c | 0.0001 | 1e-06 | 0.0100 | 0.2 | 1.0000 |" in text


def test_each_control_is_timed_at_each_target_on_its_work_precision_line():
    """time_at: the lower envelope of (error, time) (a run both worse and dearer is left out),
    log-linear between the runs around the target; the report sets the controls side by side."""
    rows = [_row("etd34", 1e-4, 1e-4, 1.0), _row("etd34", 1e-6, 1e-5, 2.0), _row("etd34", 1e-5, 2e-5, 3.0),
            _row("etd34 smoothness", 1e-5, 1e-5, 1.0), _row("etd34 smoothness", 1e-7, 1e-7, 4.0),
            dict(_row("default", 3e-7, 1e-5, 2.0), estimate_time=1e-5, estimate_quadrature=0.0),
            dict(_row("previous default", 1e-9, 1e-5, 2.0), estimate_time=1e-5, estimate_quadrature=0.0),
            dict(_row("estimated smoothness", 1e-7, 1e-7, 4.0), estimate_time=2e-7, estimate_quadrature=0.0)]
    assert time_integrator.time_at(rows, "etd34", 1e-4) == 1.0
    assert abs(time_integrator.time_at(rows, "etd34", 10 ** -4.5) - 2 ** 0.5) < 1e-12
    assert time_integrator.time_at(rows, "etd34", 1e-6) is None
    assert time_integrator.time_at(rows, "etd34", 1e-3) == 1.0
    assert abs(time_integrator.time_at(rows, "etd34 smoothness", 1e-6) - 2.0) < 1e-12
    text = time_integrator.report(["- c: a note"], rows)
    assert "| c | 1e-05 | 2.0000 | 1.0000 | 0.50 |" in text
    assert "| c | 1e-06 | - | 2.0000 | - |" in text
    assert "| c | - | - | 1.00e-07 | 2.00 |" in text
    assert "| c | smoothness | - | - | 2.0e-06 | - | - |" in text      # the onsets at 1e-6, 3e-7 .. 1e-9
