"""BLAS on one thread for a run that breaks (docs/model.md, "Cost"): a broken plate's tables and
carries work on matrices of about a hundred rows, where BLAS's threads cost more than they save,
and its idle threads spin on the cores the kernels need. One thread also makes a breaking run's
round-off independent of how many threads BLAS takes on the machine.
"""
import functools


def blas_alone(function):
    """``function`` with BLAS on one thread: a broken plate's matrices are small (a hundred rows),
    and BLAS's threads cost more than they save on them (with two threads the reference case's
    tables took twice as long: docs/model.md, "Cost")."""
    @functools.wraps(function)
    def call(*args, **kwargs):
        from threadpoolctl import threadpool_limits           # (scans the loaded libraries: 0.4 ms)
        with threadpool_limits(limits=1, user_api="blas"):
            return function(*args, **kwargs)
    return call
