"""BLAS on one thread for a run that breaks (docs/model.md, "Cost"): a broken plate's tables and
carries work on matrices of about a hundred rows, where BLAS's threads cost more than they save,
and its idle threads spin on the cores the kernels need. One thread also makes a breaking run's
round-off independent of how many threads BLAS takes on the machine.
"""
import functools

#: the process's BLAS libraries, found once (threadpoolctl.ThreadpoolController: a scan of the
#: loaded libraries, 1 to 2 ms, too slow to repeat at every break)
_CONTROLLER = []


def _controller():
    """The process's ThreadpoolController, made at the first call, after scipy.linalg is loaded
    (scipy may bring a BLAS of its own, which a controller made before would not see)."""
    if not _CONTROLLER:
        import scipy.linalg  # noqa: F401   (its BLAS loaded before the scan)
        from threadpoolctl import ThreadpoolController
        _CONTROLLER.append(ThreadpoolController())
    return _CONTROLLER[0]


def blas_alone(function):
    """``function`` with BLAS on one thread: a broken plate's matrices are small (a hundred rows),
    and BLAS's threads cost more than they save on them (with two threads the reference case's
    tables took twice as long: docs/model.md, "Cost")."""
    @functools.wraps(function)
    def call(*args, **kwargs):
        with _controller().limit(limits=1, user_api="blas"):
            return function(*args, **kwargs)
    return call
