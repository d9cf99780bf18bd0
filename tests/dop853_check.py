"""The independent-integrator check the physics tests share: etd34 against scipy's DOP853 on
the same equations, both at a tight tolerance."""
import numpy as np

from solver import Settings, solve


def against_dop853(p, t_end, count=7, tolerance=1e-11, bound=1e-6, **settings):
    """Solve p with etd34 and with DOP853 over [0, t_end] at count output times (other settings,
    such as the quadrature, as given); assert that both end ok and that their strains agree to
    ``bound`` of the largest; return both results."""
    kw = dict(times=np.linspace(0.0, t_end, count), t_end=t_end, fields=("strain",))
    a = solve(p, Settings(tolerance=tolerance, error_estimate=False, **settings), **kw)
    b = solve(p, Settings(integrator="dop853", tolerance=tolerance, error_estimate=False, **settings), **kw)
    assert a.status == b.status == "ok", (a.message, b.message)
    worst = np.abs(a.fields["strain"] - b.fields["strain"]).max() / np.abs(b.fields["strain"]).max()
    assert worst <= bound, f"strain differs from DOP853 by {worst:.2e} of its largest value"
    return a, b
