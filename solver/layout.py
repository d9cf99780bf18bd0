"""The layouts the kernels and their adapters share, declared once: status and failure codes,
the integrator codes, the diagnostics vector (D_*), the per-output-time series (S_*) and the
tension record's columns (R_*), each generated from its table in solver.outputs (which gives
each its name, units and meaning) into the literal block below (``make layout-slots`` writes
it, a test checks it), and the body's state (B_*). The meaning of every status is docs/model.md,
"Statuses". Plain integers: numba folds them into the kernels as constants.
"""
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

FAIL_NONE = 0
FAIL_MAX_STEPS = 1         # max_steps attempted
FAIL_STEP_UNDERFLOW = 2    # error control drove the step below h_min
FAIL_BOTTOMED = 3          # every retry down to h_min had a stage with delta >= 1
FAIL_FIXED_STEP = 4        # a fixed-step run met delta >= 1 or a non-finite state
FAIL_NONFINITE = 5         # non-finite state with the adaptive step at h_min
FAIL_LOCATED = 6           # the gap closed to bottom_gap: located bottoming event
FAIL_ENERGY_JUMP = 7       # the energy identity jumped and no smaller step mended it
FAIL_ENERGY_BOUND = 8      # the run ended with its energy residual above ENERGY_BOUND

# the diagnostics vector filled by :func:`integrate` (D_<slot>: the index of each slot of the
# table solver.outputs.DIAGNOSTICS, with its name, units and meaning, in the table's order), the
# columns of a tension record row (observe.tension; R_<slot>, solver.outputs.TENSION_RECORD) and
# of integrate's per-output-time series ``out_series`` (S_<slot>, solver.outputs.SERIES)
# -- generated from solver.outputs (make layout-slots; tests/test_architecture.py checks it) --
D_MAX_UPPER = 0
D_MAX_UPPER_X = 1
D_MAX_UPPER_T = 2
D_MAX_LOWER = 3
D_MAX_LOWER_X = 4
D_MAX_LOWER_T = 5
D_MAX_ABS = 6
D_MAX_ABS_X = 7
D_MAX_ABS_T = 8
D_ZONE_UPPER = 9
D_ZONE_UPPER_X = 10
D_ZONE_UPPER_T = 11
D_ZONE_LOWER = 12
D_ZONE_LOWER_X = 13
D_ZONE_LOWER_T = 14
D_ZONE_UPPER_EDGE = 15
D_ZONE_LOWER_EDGE = 16
D_CONTACT_EXTENT = 17
D_MAX_CONTACTS = 18
D_MAX_FORCE = 19
D_MAX_FORCE_T = 20
D_MAX_DELTA = 21
D_MAX_DELTA_T = 22
D_BOTTOM_T = 23
D_BOTTOM_X = 24
D_BOTTOM_SPEED = 25
D_ENERGY_JUMPS = 26
D_ENERGY_RESIDUAL = 27
D_WORK = 28
D_DISSIPATED = 29
D_STOP_T = 30
D_MAX_PENETRATION = 31
D_SEPARATION_T = 32
D_SEPARATION_SPEED = 33
D_BODY_RESIDUAL = 34
D_T_REACHED = 35
D_STEPS = 36
D_REJECTED = 37
D_H_MIN = 38
D_H_MAX = 39
D_RHS = 40
D_FAIL_T = 41
D_FAIL_KIND = 42
D_ANSWERED_T = 43
D_BREAK_T = 44
D_BREAK_X = 45
D_BREAK_SURFACE = 46
D_ENERGY_SCALE = 47
N_DIAG = 48
R_T = 0
R_VALUE = 1
R_RATE = 2
R_X = 3
R_JOIN = 4
N_REC = 5
S_CONTACTS = 0
S_FORCE = 1
S_E_PLATE = 2
S_E_LAYER = 3
S_WORK = 4
S_ERR = 5
S_BODY_POSITION = 6
S_BODY_SPEED = 7
S_DISSIPATED = 8
N_SERIES = 9
# -- end of the generated slots --
# the body's state: deficits against the prescribed motion, d = V t - s and u = V - U
B_D, B_U = 0, 1

