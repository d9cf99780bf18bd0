"""The layouts the kernels and their adapters share, declared once: status and failure codes,
the integrator codes, the diagnostics vector (D_*), the per-output-time series (S_*) and the
tension record's columns (R_*), each generated from its table in solver.outputs (which gives
each its name, units and meaning), and the body's state (B_*). The meaning of every status is docs/model.md,
"Statuses". Plain integers: numba folds them into the kernels as constants.
"""
from .outputs import RECORD_SLOTS as _RECORD_SLOTS, SERIES_SLOTS as _SERIES_SLOTS, SLOTS as _SLOTS

# status codes returned by :func:`integrate`
OK = 0
LAYER_BOTTOMED_OUT = 1
NONFINITE = 2
STEP_LIMIT = 3
ENERGY_VIOLATION = 4
SEPARATED = 5               # a free body left the ice, moving up (run asked to end there)
STOPPED = 6                 # a free body stopped and had not separated at the end of the window
STATUS_NAMES = ("ok", "layer_bottomed_out", "nonfinite", "step_limit", "energy_violation",
                "separated", "stopped")

# integrator codes
ETD34 = 0
RK4 = 1

# the diagnostics vector filled by :func:`integrate`: D_<slot> is the index of each slot of the
# table solver.outputs.DIAGNOSTICS (with its name, units and meaning), in the table's order
globals().update({f"D_{slot}": index for index, slot in enumerate(_SLOTS)})
N_DIAG = len(_SLOTS)

FAIL_NONE = 0
FAIL_MAX_STEPS = 1         # max_steps attempted
FAIL_STEP_UNDERFLOW = 2    # error control drove the step below h_min
FAIL_BOTTOMED = 3          # every retry down to h_min had a stage with delta >= 1
FAIL_FIXED_STEP = 4        # a fixed-step run met delta >= 1 or a non-finite state
FAIL_NONFINITE = 5         # non-finite state with the adaptive step at h_min
FAIL_LOCATED = 6           # the gap closed to bottom_gap: located bottoming event
FAIL_ENERGY_JUMP = 7       # the energy identity jumped and no smaller step mended it
FAIL_ENERGY_BOUND = 8      # the run ended with its energy residual above ENERGY_BOUND

# columns of a tension record row (observe.tension): R_<slot>, from solver.outputs.TENSION_RECORD
globals().update({f"R_{slot}": index for index, slot in enumerate(_RECORD_SLOTS)})
N_REC = len(_RECORD_SLOTS)

# columns of integrate's per-output-time series ``out_series``: S_<slot>, from solver.outputs.SERIES
globals().update({f"S_{slot}": index for index, slot in enumerate(_SERIES_SLOTS)})
N_SERIES = len(_SERIES_SLOTS)
# the body's state: deficits against the prescribed motion, d = V t - s and u = V - U
B_D, B_U = 0, 1

