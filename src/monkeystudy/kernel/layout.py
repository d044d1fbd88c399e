"""Index constants shared by the kernels and the API (plain ints: numba freezes them).

Everything the compiled kernels exchange is a float64 array; these names say what each slot
holds, so no Python object ever crosses into the kernel layer.
"""

# --- robot parameter vector (one row per frame: row 0 normal, row 1 flipped) -----------------
P_M1, P_M2, P_L1, P_L2, P_R1, P_R2, P_I1, P_I2, P_G = 0, 1, 2, 3, 4, 5, 6, 7, 8
P_B_PIVOT, P_C_PIVOT, P_B_JOINT, P_C_JOINT = 9, 10, 11, 12  # viscous [N m s], Coulomb [N m]
# derived, precomputed once (docs/model.md section 2 shorthand)
P_A = 13        # a = m1 r1 + m2 L1                      [kg m]
P_H = 14        # h = m2 r2 L1                           [kg m^2]
P_M2R2 = 15     # m2 r2                                  [kg m]
P_K11 = 16      # I1 + I2 + m1 r1^2 + m2 L1^2 + m2 r2^2  [kg m^2]
P_K22 = 17      # I2 + m2 r2^2                           [kg m^2]
P_MTOT = 18     # m1 + m2                                [kg]
# a link's CG off the line between its joints (docs/model.md section 1): its offset across the
# line, counter-clockwise positive [m], and the derived terms it adds; zero for in-line links,
# where every term they enter is an exact zero and leaves the in-line values bit for bit
P_S1, P_S2 = 19, 20    # sigma1, sigma2
P_AS = 21       # m1 sigma1                              [kg m]
P_HS = 22       # m2 sigma2 L1                           [kg m^2]
P_M2S2 = 23     # m2 sigma2                              [kg m]
# the joint motor's rotor (docs/model.md section 2, "The motor's rotor"): its inertia about its
# axis [kg m^2], the gear ratio (rotor turns per turn of the joint) [1], 1.0 when its housing
# is fixed to link 1 of the frame and 0.0 when to link 2, and the constant inertia it adds to
# the (theta1, theta2) block of the mass matrix, J11, J12, J22 [kg m^2]; all zero without a
# rotor, where the terms they enter are exact zeros, as for the CG offsets above
P_ROTOR, P_GEAR, P_HOUSING1 = 24, 25, 26
P_J11, P_J12, P_J22 = 27, 28, 29
N_PARAMS = 30

# --- full state in the current frame (flight coordinates, docs/model.md section 1) --------------
# [x, y, theta1, theta2, dx, dy, dtheta1, dtheta2]; (x, y) is the "attached" end of the frame.
# The room (kernel/dynamics.py: pack, unpack) maps it to and from each phase's packed vector.
X, Y, TH1, TH2, DX, DY, DTH1, DTH2 = 0, 1, 2, 3, 4, 5, 6, 7
N_STATE = 8

# --- sines and cosines of a state's angles, as a step leaves them for the guards (theta1,
# theta2, theta1 + theta2)
T_S1, T_C1, T_S2, T_C2, T_S12, T_C12 = 0, 1, 2, 3, 4, 5
N_TRIG = 6

# --- phases ------------------------------------------------------------------------------------
PHASE_SWING = 0    # the (x, y) end is attached, 2-DOF
PHASE_FLIGHT = 1   # nothing attached, 4-DOF
PHASE_FIXED = 2    # both ends attached, no motion

#: True in every kernel; False in the copies that runs which never fly compile
#: (:func:`.hybrid.without_flight`), where numba drops the flight branches unread
FLIES = True

# --- integrator methods ----------------------------------------------------------------------
METHOD_RK45 = 0
METHOD_DOP853 = 1
METHOD_VERN9 = 2

# --- guard kinds (docs/model.md sections 4 and 6) ----------------------------------------------
G_NONE = -1             # segment ends only by its horizon
G_TIME = 0              # t - (clock origin + value)                            [s]
G_FREE_END_HEIGHT = 1   # free end's height above the attached end - value: -(L1 c1 + L2 c12) - value [m]
G_ENERGY_RESTORED = 2   # E - E_ref - value, E_ref latched on entering a SET_EREF segment [J]
G_COORD = 3             # state[index] - value (index into the 8-state above)
G_ENERGY = 4            # E - value                                             [J]
G_FREE_END_Y = 5        # world height of the free end - value                  [m]
G_BAR = 6               # a catch on a bar: free end's height above the attached end - value (the
#                         bar's rise dy) [m], falling, a catch only within S_BAR_WINDOW of the
#                         bar horizontally; the new attached end is then snapped onto the bar
G_SLIP_STOP = 10        # internal: a slipping Coulomb DOF reaches zero speed
G_STICK_BREAK = 11      # internal: a stuck DOF's holding torque exceeds the Coulomb limit

# --- program (controller) table: one row per segment --------------------------------------------
S_MAG_A = 0        # magnet of physical end A on entry: -1 unchanged, 0 off, 1 on
S_MAG_B = 1        # magnet of physical end B on entry: -1 unchanged, 0 off, 1 on
S_SWAP = 2         # 1: attach the free end and release the attached one (overrides S_MAG_*)
S_TORQUE = 3       # motor torque on entry, on theta2 of the frame after entry actions [N m]
S_SET_EREF = 4     # 1: latch the total energy on entry as E_ref
S_GUARD = 5        # guard kind ending the segment (G_*)
S_GINDEX = 6       # guard index (state index for G_COORD)
S_GVALUE = 7       # guard value
S_GDIR = 8         # +1 rising, -1 falling, 0 either
S_TICKED = 9       # 1: act at the first controller tick at/after the crossing (if still true)
S_NEXT = 10        # next segment row, -1 to stop
S_CLOCK = 11       # on exit: 0 nothing, 1 clock origin = exit time, 2 clock origin += value
S_FAIL = 12        # status returned if the segment's horizon is reached
S_CYCLE = 13       # 1: leaving this segment completes one cycle
S_DELAY = 14       # the exit (and the next row's entry actions) comes this long after the
#                    guard fires [s]: a time guard's instant moves by it (either sign), a
#                    state guard's action waits for it (>= 0; an actuation latency)
S_BAR_DX = 15      # G_BAR: the bar's horizontal offset from the attached end, world x [m]
S_BAR_WINDOW = 16  # G_BAR: largest horizontal distance of the free end from the bar at a catch [m]
S_RISE = 17        # the route's planned height rises by this per completed cycle [m] (the
#                    gait's, on every row): in the run's cycle k (the hybrid state's count) a
#                    G_FREE_END_Y guard targets value + k * rise, and ST_FELL is measured from
#                    the start's height + k * rise
N_SEG_COLS = 18

# --- observer table: non-terminal guards whose crossings are logged -----------------------------
O_GUARD, O_GINDEX, O_GVALUE, O_GDIR = 0, 1, 2, 3
O_SEGMENT = 4      # watch only while in this program row (-1: always)
N_OBS_COLS = 5

# --- settings vector -----------------------------------------------------------------------------
C_METHOD = 0       # METHOD_*
C_RTOL = 1
C_ATOL = 2
C_MAX_SEGMENT_TIME = 3   # horizon of one segment [s]
C_T_END = 4              # absolute end of the run [s] (inf: none)
C_MAX_CYCLES = 5         # stop after this many cycles (0: no limit)
C_TICK = 6               # controller tick [s] (0: exact)
C_TICK_PHASE = 7         # tick grid offset [s]: ticks at phase + k * tick
C_SAMPLE_DT = 8          # trajectory sampling interval [s] (0: no trajectory)
C_MAX_STEPS = 9          # step budget for the whole run
C_MAX_STEP = 10          # largest step [s]
C_MAX_DROP = 11          # stop with FELL when the attached end sinks this far below its
#                          planned height (the start's, plus S_RISE per completed cycle) [m]
C_ZERO_BAND = 12         # relative band treated as "already zero" at a segment start
C_CONTROLLER = 13        # step-size controller: CONTROLLER_*
N_SETTINGS = 14

# --- step-size controllers ------------------------------------------------------------------------
CONTROLLER_SCIPY = 0     # scipy's: factor SAFETY * err^(-1/k); steps equal solve_ivp's
CONTROLLER_PI = 1        # Gustafsson's PI: SAFETY * err^(-0.7/k) * err_prev^(0.4/k)

# --- status codes (also the dataset's flag_values) ---------------------------------------------
ST_OK = 0
ST_NO_SWITCH = 1            # the free end never reached the attached end's height
ST_ENERGY_NOT_RESTORED = 2  # motor never restored the gait-start energy
ST_NO_RETURN = 3            # never returned to the vertical
ST_NONFINITE = 4
ST_UNREACHABLE = 5          # provably cannot reach the swap (energy bound); not integrated
ST_STEP_FAILURE = 6         # step size underflow or step budget exhausted
ST_BUFFER_FULL = 7          # log/sample buffer too small (the API grows it and reruns)
ST_END_TIME = 8             # ran to C_T_END (normal end of a fixed-duration run)
ST_HORIZON = 9              # a segment without a specific failure status hit its horizon
ST_FELL = 10                # the attached end sank more than C_MAX_DROP

STATUS_NAMES = ("ok", "no_switch", "energy_not_restored", "no_return_to_vertical",
                "non_finite", "unreachable", "step_failure", "buffer_full", "end_time",
                "horizon", "fell")

# --- counters -------------------------------------------------------------------------------------
K_STEPS, K_REJECTED, K_NFEV, K_EVENTS, K_CYCLES, K_SAMPLES, K_LOG = 0, 1, 2, 3, 4, 5, 6
K_STATUS = 7       # the run's status (ST_*), set at its end
N_COUNTS = 8

# --- event log row ----------------------------------------------------------------------------------
# [t, kind (0 segment exit, 1 observer, 2 friction mode change), id, cycle, phase, flipped,
#  energy before, energy after, state after (8 values)]
L_T, L_KIND, L_ID, L_CYCLE, L_PHASE, L_FLIPPED, L_E_BEFORE, L_E_AFTER, L_STATE = 0, 1, 2, 3, 4, 5, 6, 7, 8
N_LOG_COLS = 16
LOG_SEGMENT, LOG_OBSERVER, LOG_FRICTION = 0, 1, 2

# --- sample row mode columns: [phase, flipped, torque, segment] ------------------------------------
M_PHASE, M_FLIPPED, M_TORQUE, M_SEGMENT = 0, 1, 2, 3
N_MODE_COLS = 4

# --- hybrid state vector: everything needed to continue a run (in and out of simulate) ----------
# [0:8] full state in the current frame, then:
H_T = 8            # time [s]
H_PHASE = 9        # PHASE_*
H_FLIPPED = 10     # 0: (x, y) is physical end A; 1: it is end B (parameters flipped)
H_SEG = 11         # program row (on input: the row to enter)
H_TORQUE = 12      # motor torque in force [N m]
H_EREF = 13        # latched reference energy [J]
H_CLOCK = 14       # controller clock origin [s]
H_FMODE0 = 15      # pivot friction mode: +1/-1 slip sign, 0 stuck
H_FMODE1 = 16      # joint friction mode
H_CYCLES = 17      # completed cycles
H_Y_REF = 18       # reference height of the attached end for ST_FELL [m] (NaN: set at start)
N_HYB = 19

# --- survival runs (kernel.survival) ---------------------------------------------------------------
ST_ERROR_BOUND = 11      # a survival run's cycle ended farther than the error bound from the gait
ST_STALLED = 12          # a survival run's cycle advanced less than the minimum advance
# noise vector: the scale of each source (0: off)
NZ_UNIFORM = 0      # 1: uniform on [-scale, scale); 0: Gaussian with standard deviation scale
NZ_TIMING = 1       # actuation timing jitter [s]
NZ_ANGLE = 2        # sensed angle of an angle guard [rad]
NZ_RATE = 3         # sensed rate of a rate guard [rad s-1]
NZ_HEIGHT = 4       # sensed height of a height guard [m]
NZ_ENERGY = 5       # sensed energy of an energy guard [J]
NZ_TORQUE = 6       # relative error of a motor pulse's torque [1]
NZ_THETA2 = 7       # initial theta2 [rad]
NZ_DTHETA1 = 8      # initial dtheta1 [rad s-1]
NZ_DTHETA2 = 9      # initial dtheta2 [rad s-1]
NZ_LATENCY = 10     # actuation latency [s]: one draw per run, uniform on [0, scale), added to
                    # the delay of every actuation (whatever the distribution of the others)
NZ_BAR_SPACING = 11  # the ladder's spacing error [m]: one draw per run, added to the distance of
                     # every bar from the bar before it (S_BAR_DX, away from the attached end)
N_NOISE = 12
# noise role of each program row
RL_JITTER = 0       # JITTER_*: how timing jitter moves the row's exit
RL_SENSOR = 1       # the NZ_* source read by the row's guard (0: none)
RL_PULSE = 2        # 1: the row's torque is a motor pulse, scaled by (1 + torque error)
N_ROLE_COLS = 3
JITTER_NONE, JITTER_SHIFT, JITTER_LATENCY = 0, 1, 2
# one survival run's outcome
SV_CYCLES = 0       # cycles completed within the bounds
SV_FAILURE = 1      # ST_OK: ran max_cycles (censored); else the failing cycle's ST_*
SV_DISTANCE = 2     # attached end's x at the last completed cycle's end - at the start [m]
SV_TIME = 3         # time of the last completed cycle's end [s]
SV_ERROR = 4        # error at the last completed cycle's end [rad2 + rad2 s-2]
SV_NFEV = 5         # right-hand-side evaluations of the run
SV_HEIGHT = 6       # attached end's height at the last completed cycle's end - the planned
#                     height there (the start's plus S_RISE per completed cycle) [m]
N_SV_COLS = 7
