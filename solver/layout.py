"""The layouts the kernels and their adapters share, declared once: status and failure codes,
the integrator codes, the diagnostics vector (D_*), the per-output-time series (S_*), the
tension record's columns (R_*) and the body's state (B_*). The meaning of every diagnostic,
with its units, is solver.core.DIAGNOSTIC_INFO; of every status, docs/model.md, "Statuses".
Plain integers: numba folds them into the kernels as constants.
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

# layout of the diagnostics vector filled by :func:`integrate`
D_MAX_UPPER, D_MAX_UPPER_X, D_MAX_UPPER_T = 0, 1, 2      # max eps (tension, upper surface)
D_MAX_LOWER, D_MAX_LOWER_X, D_MAX_LOWER_T = 3, 4, 5      # max -eps (tension, lower surface)
D_MAX_ABS, D_MAX_ABS_X, D_MAX_ABS_T = 6, 7, 8            # max |eps|
D_BOTTOM_T, D_BOTTOM_X, D_BOTTOM_SPEED = 9, 10, 11       # located bottoming event
D_ENERGY_JUMPS = 12        # steps rejected because the energy identity jumped
D_MAX_CONTACTS = 13        # max number of contact intervals (events inside steps counted)
D_MAX_FORCE, D_MAX_FORCE_T = 14, 15
D_MAX_DELTA, D_MAX_DELTA_T = 16, 17
D_ENERGY_RESIDUAL = 18     # max_t |E_plate + E_layer - W| / max_t W (= W(t_reached) for the paper's body)
D_WORK = 19                # W(t_reached) [J m-1]
D_T_REACHED = 20
D_STEPS = 21               # accepted steps
D_REJECTED = 22            # rejected steps
D_H_MIN = 23               # smallest accepted step [s]
D_H_MAX = 24               # largest accepted step [s]
D_RHS = 25                 # forcing evaluations
D_FAIL_T = 26              # time of the step that failed (NaN if none)
D_FAIL_KIND = 27           # why the run stopped early: one of the FAIL_* codes
# a body of finite mass (NaN for the prescribed motion)
D_STOP_T = 28              # first time the body's speed reached zero
D_MAX_PENETRATION = 29     # largest penetration s of the body [m] (at a zero of its speed)
D_SEPARATION_T = 30        # time the body left the ice moving up (after it had stopped)
D_SEPARATION_SPEED = 31    # the body's upward speed then [m s-1]
D_BODY_RESIDUAL = 32       # max_t |M (U^2 - V^2)/2 - M g_b s + W| / max_t W
D_DISSIPATED = 33          # energy dissipated in the viscoelastic ice up to the time reached [J m-1]
# the impact zone's maxima (solver.observe.zone): upper and lower surface, each (value, x, t)
D_ZONE_UPPER, D_ZONE_UPPER_X, D_ZONE_UPPER_T = 34, 35, 36
D_ZONE_LOWER, D_ZONE_LOWER_X, D_ZONE_LOWER_T = 37, 38, 39
D_CONTACT_EXTENT = 40      # largest distance from the body's centre of a point in contact [m]
D_ZONE_UPPER_EDGE, D_ZONE_LOWER_EDGE = 41, 42   # 1: that maximum sits at the zone's edge, 0: a peak inside
N_DIAG = 43

FAIL_NONE = 0
FAIL_MAX_STEPS = 1         # max_steps attempted
FAIL_STEP_UNDERFLOW = 2    # error control drove the step below h_min
FAIL_BOTTOMED = 3          # every retry down to h_min had a stage with delta >= 1
FAIL_FIXED_STEP = 4        # a fixed-step run met delta >= 1 or a non-finite state
FAIL_NONFINITE = 5         # non-finite state with the adaptive step at h_min
FAIL_LOCATED = 6           # the gap closed to bottom_gap: located bottoming event
FAIL_ENERGY_JUMP = 7       # the energy identity jumped and no smaller step mended it
FAIL_ENERGY_BOUND = 8      # the run ended with its energy residual above ENERGY_BOUND

# columns of a tension record row (see observe_tension)
R_T, R_VALUE, R_RATE, R_X, R_JOIN = 0, 1, 2, 3, 4
N_REC = 5

# columns of integrate's per-output-time series ``out_series``
(S_CONTACTS, S_FORCE, S_E_PLATE, S_E_LAYER, S_WORK, S_ERR, S_BODY_POSITION, S_BODY_SPEED,
 S_DISSIPATED) = range(9)
N_SERIES = 9
# the body's state: deficits against the prescribed motion, d = V t - s and u = V - U
B_D, B_U = 0, 1

