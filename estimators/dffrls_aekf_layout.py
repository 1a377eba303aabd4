"""Index layout of the ``dffrls-aekf`` / ``fused`` kernel's arrays (:mod:`estimators.dffrls_aekf_kernel`).

``C`` holds the settings (written by :meth:`estimators.dffrls_aekf.DFFRLSAEKFConfig.settings`), ``S`` the state,
``H`` the slope history (``N_HIST_MAX`` entries) and the fixed-lag smoother's ring (``N_H`` in all). Plain integer constants: numba compiles them in.
"""

REFERENCE_DT_S = 0.005
"""The sample step (200 Hz) every per-sample setting was tuned at; a trace at another rate scales them (RATE_R)."""

# --- settings C ---------------------------------------------------------------------------------------------------
GAP_S = 0
DT_NOM = 1
RADIUS = 2
M_ROT = 3
M_REF = 4
M_RIGID = 5
C_MIN = 6
C_MAX = 7
MU0 = 8
MU_MAX = 9
CUT_HZ = 10
FAST_HZ = 11
CHAIN_L = 12
SWAY_DAMP = 13
SWAY_H = 14
MIN_SPEED = 15
MIN_FORCE = 16
SETTLE_S = 17
T_MAX = 18
T_RATE = 19
T_BAND = 20
V_MAX = 21
V_RATE = 22
V_BAND = 23
F_MAX = 24
F_RATE = 25
F_BAND = 26
RELOCK = 27
GATES = 28
R0 = 29
R_MIN = 30
R_MAX = 31
FADING = 32
ADAPT_R = 33
ACC_VAR = 34
MODEL_ACC_VAR = 35
GRADE_VAR_M = 36
P0_TH = 37
GATE2 = 38
MAX_SLOPE = 39
USE_ACCEL = 40
HIST_DS = 41
N_HIST = 42
R_M = 43
DELTA = 44
SIGMA = 45
MASS_FORGET = 46
P0_C = 47
P0_CD = 48
P0_D = 49
EST_MU = 50
MAX_SPREAD = 51
READY_VAR = 52
Q_C = 53
C0 = 54
MIN_ACC = 55
OFF_FORGET = 56
FUSED = 57
P0_B = 58
BIAS_VAR = 59
CORR_N = 60
N_BUF = 61  # history entries kept (>= N_HIST): the spread gate's reach
MAX_AMBIG = 62  # the geometry bank's ambiguity gate (AMBIG above it: no mass update)
EARLY_CAP = 63  # the geometry bank: most the early evidence (SCORE_EARLY) may tell the members apart
PROJECT_CLAMP = 64  # a clamped mass moves the correlated parameters with it (estimate projection)
ACC_REG = 65  # the regressor's gravity term from the accelerometer (f - dv/dt) rather than the slope estimate
N_CHAIN = 66  # members of the chain-length bank (0: one pendulum, CHAIN_L)
CURV_VAR_M = 67  # variance per metre of the random walk of the grade's curvature (0: no curvature state)
P0_KAP = 68  # prior variance of the curvature (rad/m)^2
KAP_MAX = 69  # bound of the curvature (rad/m)
WEAK_ACC = 70  # below this load acceleration (and above MIN_ACC) a mass update counts the sample WEAK_R times noisier
WEAK_R = 71
BRAKING = 72  # 1: samples of measured electric braking (drive force below -MIN_FORCE) are usable too
STUCK_N = 73  # the accelerometer repeating one value this many times in a row is stuck (0: no detector)
T_JUMP = 74  # a torque sample jumping by more than this (N m) is held back until the next confirms it (0: off)
F_JUMP = 75  # the same for the accelerometer (m/s^2); both thresholds grow with the channel's noise (JUMP_NOISE)
JUMP_NOISE = 76
FILL_SPEED = 77  # 1: a missing speed sample enters the regression's filters as the slope layer's predicted speed
FUSED_SPREAD = 78  # fused: 1 = the mass (not the offset or blend) is a considered parameter while SPREAD > MAX_SPREAD
BLEND_EARLY = 79  # fused: 1 = the blend learns from the first metre moved (0: once the window holds measured slopes)
EARLY_KEPT = 80  # fused with BLEND_EARLY: the share of alpha's early deviation from its prior kept once the window
#   first holds measured slopes only (its variance then back to the prior: the early evidence leans, the later decides)
SMOOTH_L = 81  # fixed-lag smoothing: the regression runs this many samples behind the slope layer (0: at once)
SMOOTH_NB = 82  # ... one backward pass per this many new samples (estimators.fixed_lag_kernel)
ACC_PER_NOISE = 83  # > 0: the slope layer's accelerometer std is this times the accelerometer noise read online
EVID_MIN = 84  # the geometry bank's evidence counts only while its members' slopes differ by at least this (rad)
RATE_R = 85  # the sample step the settings are for over REFERENCE_DT_S (1 at 200 Hz): per-sample rates scale by it
RES_GATE2 = 86  # > 0: the mass holds on a sample whose residual squared exceeds this times (RES_VAR + h P h)
RES_PERSIST = 87  # ... unless the gate has held it this long (s) in a row: then the residual is the new scale
WIT_THR = 88  # > 0: the gyro witness (fused): the slope layer's grade this far (rad) from the gyro's pitch holds the
#   regression, since a grade change the gyro does not see is an accelerometer fault, not the track
WIT_TAU = 89  # ... the time constant (s) of the pull of the gyro's integrated pitch towards the slope layer's grade
WIT_HOLD = 90  # ... how long (s) the hold lasts after the last disagreement; a disagreement that lasts WIT_PERSIST (s)
WIT_PERSIST = 91  #   is a lasting change, not a fault: the witness re-locks to the grade
WIT_SETTLE = 92  # ... and after a (re)lock it follows the grade this long (s) before it may disagree
WEAK_RW = 93  # 1: on a weak sample the offset's forgetting adds variance to the offset alone (a random walk)
MASS_STD_SCALE = 94  # the reported mass sigma's data part (never above the prior) times this (calibration)
WIN_WEAK = 95  # > 0: a window member's sample below MIN_ACC is a weak one (WEAK_R) while SPREAD is under this (rad)
SLOPE_VAR_W = 96  # the slope layer's grade variance enters the mass regression's per-sample noise this many times
#   (as c² g² P22: the regressor's error from the grade, correlated over many samples)
CHAIN_SET = 97  # member k's settings at CHAIN_SET + CHAIN_SET_W k: chain length, damping, integration step, prior
#   score (negative log prior weight, nats, relative to the most probable member's)
CHAIN_SET_W = 4
MAX_CHAINS = 8
N_C = CHAIN_SET + CHAIN_SET_W * MAX_CHAINS
# --- state S ------------------------------------------------------------------------------------------------------
V = 0
TH = 1
P11 = 2
P12 = 3
P22 = 4
R = 5
K = 6
BK = 7
F_IN = 8
F_OK = 9
REJ = 10
FORCE_IN = 11
GT_LAST = 12
GT_REJ = 13
GV_LAST = 14
GV_REJ = 15
GF_LAST = 16
GF_REJ = 17
LF1 = 18
LF2 = 19
LF_OK = 20
LV1 = 21
LV2 = 22
LV_OK = 23
LQ1 = 24
LQ2 = 25
LQ_OK = 26
LA1 = 27
LA2 = 28
LA_OK = 29
LS1 = 30
LS2 = 31
LS_OK = 32
LC1 = 33
LC2 = 34
LC_OK = 35
PREV_VF = 36
PREV_VQ = 37
SWAY = 38
SWAY_RATE = 39
T_VALID = 40
T_MISSING = 41
ACC_F = 42
A_LOAD = 43
MC = 44
MD = 45
PC = 46
PCD = 47
PD = 48
RES_VAR = 49
LAMBDA = 50
N_MASS = 51
DIST = 52
NEXT_S = 53
HEAD = 54
HSUM = 55
MOVED = 56
TH_TRAIN = 57
SPREAD = 58
N_GAPS = 59
TH_WIN = 60
LL1 = 61
LL2 = 62
LL_OK = 63
MB = 64
PB = 65
PCB = 66
PDB = 67
DIST0 = 68
NIS = 69  # normalised innovation squared of the last accepted speed correction (held; 1 before the first)
SCORE = 70  # accumulated negative log-likelihood of the force balance (the geometry bank's evidence)
AMBIG = 71  # written by the geometry bank: how much its members disagree on the slope gravity acts on (rad)
SCORE_EARLY = 72  # as SCORE, while the slope window still holds the start-up guess (the bank caps its weight)
LG1 = 73  # low-pass of the accelerometer's specific force (3 slots; ACC_REG)
LG2 = 74
LG_OK = 75
G_SHIFT = 76  # ACC_REG: the accelerometer's gravity term minus the slope layer's, per g (held through dropouts)
KAP = 77  # the grade's curvature d(theta)/ds (rad/m): third state of the slope layer when CURV_VAR_M > 0
P13 = 78  # its covariances with v, theta and itself
P23 = 79
P33 = 80
STUCK_ST = 81  # the accelerometer's stuck detector (estimators.input_faults.stuck_step; STUCK_STATE = 4 slots)
T_JUMP_ST = 85  # the torque's and the accelerometer's jump gates (estimators.input_faults.jump_step; 3 slots each)
F_JUMP_ST = 88
B_MEASURED = 91  # fused: 1 once the slope window has held measured slopes only (EARLY_KEPT applied)
RING_HEAD = 92  # fixed-lag smoothing: the ring's oldest record's slot, and how many records it holds
RING_N = 93
F_PREV = 94  # the last valid accelerometer sample, and the running mean of half the squared sample-to-sample change
NOISE_F = 95  #   (the accelerometer's noise variance, read online; ACC_PER_NOISE)
DISAGREE = 96  # written by the geometry bank before each step: the spread (max - min, unweighted) of its members'
#   slopes gravity acts on (rad); outside a bank it stays at DISAGREE_ALONE
RES_SKIP = 97  # how long (s) the residual gate has held the mass in a row
TH_G = 98  # the gyro witness: the gyro's integrated pitch (rad), pulled towards the slope layer's grade while they agree
G_OK = 99  # ... how long (s) TH_G has followed a valid gyro since it (re)locked (0: re-lock on the next valid sample)
WIT_LEFT = 100  # ... how long (s) the regression still holds for
WIT_T = 101  # ... how long (s) the two have disagreed in a row
CHAIN_ST = 102  # chain-length bank member k's state at CHAIN_ST + CHAIN_ST_W k: swing angle, its rate, the
#   low-pass of its load acceleration (3 slots), that acceleration, its force-balance evidence (negative log-lik.)
CHAIN_ST_W = 7
N_S = CHAIN_ST + CHAIN_ST_W * MAX_CHAINS
N_HIST_MAX = 512
# --- H: the slope history (N_HIST_MAX entries), then the fixed-lag smoother's ring (estimators.fixed_lag_kernel) ---
RING_W = 28  # floats per ring record
RING_MAX = 384  # records the ring holds: the lag plus one block, at most
RING0 = N_HIST_MAX
N_H = RING0 + RING_W * RING_MAX
# --- estimate row: what estimate() writes (mass, slope, their stds, mu, mu_std, alpha, nis, score) -------------
N_EST = 9
EST_SCORE = 8  # the estimate row's column of the force-balance score (the geometry bank weighs its members by it)
