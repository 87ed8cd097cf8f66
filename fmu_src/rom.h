/*
 * sphrom model core: the frozen-coefficient reduced model of the paper's
 * eqs. 2.19-2.24 (POD-accelerated SPH of a 1D mass-spring-damper system), and
 * the exact linear reduced model in the specific volume J = rho0/rho
 * (harness/rom/exact_linear.py), advanced over each communication step by the
 * matrix exponential of its augmented matrix.
 *
 * No FMI types appear here: the version-neutral instance layer (instance.h)
 * and the FMI 2.0 and 3.0 co-simulation adapters (fmi2_cs.c, fmi3_cs.c) sit on
 * top of these functions.  There are no globals; every object is owned by the
 * caller, so many instances can run in one process and in several threads (one
 * thread per instance at a time).
 *
 * The core's sources (rom_internal.h draws how they call each other):
 *   rom.c           the state API, dispatched through the model kind's table of operations
 *   rom_frozen.c/h  kind 1, the frozen-coefficient model: its data, load, state, step, outputs
 *   rom_exact.c/h   kind 2, the exact linear model (every linear model): the same, by the matrix exponential
 *   rom_numerics.c/h the matrix exponential (the exact model's step maps, the error bounds' plane maps)
 *   rom_resources.c resources/model.bin: the header, the tagged sections, the kind's body through its table
 *   rom_state_io.c  the serialized FMU state
 *   rom_envelope.c  the training envelope
 *   rom_bound.c     the certified error bounds: the shadow of the full linear SPH, stepped with the model
 *   rom_port.c      the port channel: the full linear SPH's response to the port forces, superposed on the kind's
 *   rom_bytes.c     little-endian numbers, CRC-32, the check both formats share, aligned arrays
 *   rom_fail.c      messages
 *   rom_layout.h    generated from harness/fmu/layout.py: every number of the two binary formats
 * What they share privately (the table of operations per model kind) is in rom_internal.h.
 *
 * The scene's numbers come from resources/model.bin, written by the harness (harness/fmu/resources.py, for every
 * model kind of harness/fmu/kinds/).  Its layout and that of the serialized FMU state are written once, in
 * harness/fmu/layout.py, from which rom_layout.h (included below) is generated: every size, byte offset,
 * version, flag, kind number and named section column, and both formats in words in its opening comment.  In
 * short: a shared header (magic, version, model kind, k_v, k_rho, n_probes, flags, runaway bound, L), the
 * kind's body (the frozen kind's own header: integrator, n_pairs, the default n_freeze, dt; then its arrays),
 * tagged sections, the token and a CRC-32; the state: a header (magic, version, mode tag, sizes, token, step
 * count, time, f), then a^v, a^rho, the kind's block (the frozen kind's starts with its parameters n_freeze and
 * dt), elapsed, df/dt, the error bounds' shadow, the parameters (initial_state_scale, c, d), the ports, a CRC-32.
 * Units: time [s], velocity [m s^-1], density [kg m^-3], force per mass [m s^-2].
 *
 * Versions: this binary reads model.bin format ROM_FORMAT_VERSION and serialized states of ROM_STATE_VERSION and
 * ROM_STATE_OLDEST_VERSION (format 4, of the same model.bin format: it held the start time t0 where format 5 holds
 * the time since the start, read as time - t0).  A state restores only into the FMU whose token it carries, and
 * the token hashes the model.bin bytes: a state of a format older than that was written by an FMU of an older
 * model.bin format, which no FMU of this binary has, so it could never be restored here; such a state is refused
 * naming its version and saying so.
 *
 * Both are read through one envelope check (rom_bytes.c): size, magic, version,
 * sizes, token, checksum.
 */
#ifndef SPHROM_ROM_H
#define SPHROM_ROM_H

#include <stddef.h>
#include <stdint.h>

#include "rom_layout.h"      /* the formats: generated from harness/fmu/layout.py */

/* The printf dialect the message functions below are checked against: a MinGW-w64 build uses MinGW's C99 printf
 * (CMakeLists.txt defines __USE_MINGW_ANSI_STDIO: %zu, %lld, %a as on Linux), which its <stdio.h> names
 * __MINGW_PRINTF_FORMAT; GCC's "printf" there would mean the Microsoft runtime's. */
#if defined(__MINGW32__)
#include <stdio.h>
#endif
#if defined(__MINGW_PRINTF_FORMAT)
#define ROM_PRINTF_FORMAT __MINGW_PRINTF_FORMAT
#else
#define ROM_PRINTF_FORMAT printf
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* The core library (libsphrom_core, for ctypes and the benchmark) exports the
 * rom_* functions; inside the FMU binaries they stay hidden. */
#if defined(ROM_EXPORT_API)
#  if defined(_WIN32)
#    define ROM_API __declspec(dllexport)
#  else
#    define ROM_API __attribute__((visibility("default")))
#  endif
#else
#  define ROM_API
#endif

#define ROM_MESSAGE_SIZE 1024
#define ROM_RESOURCE_FILE "model.bin"

/* doStep's rules (harness/fmu/kinds/__init__.py step_error and same_step, harness/fmu/kinds/frozen.py split_step
 * repeat them).  Time is exact at any start: every comparison of a step is relative to the step, never to |t|.
 * currentCommunicationPoint must equal the FMU's time to the time's own rounding: within ROM_TIME_ULPS units in the
 * last place of the larger |t| (an importer's t = n H against the FMU's t + H) plus ROM_TIME_STEP_TOLERANCE x h;
 * t + h must be finite and later than t (a step below the time's resolution would leave the time where it is). */
#define ROM_TIME_ULPS 16.0
#define ROM_TIME_STEP_TOLERANCE 1e-9  /* relative to the step h */
#define ROM_SAME_STEP 1e-9            /* relative to the step: two step lengths this close are one (the cached maps) */
#define ROM_STEP_ROUNDING 1e-9        /* relative: h/dt within this of an integer is that many whole steps */
#define ROM_SHORT_STEP_MIN 1e-12      /* a remainder below this x dt is no step */
/* The work of one doStep is bounded (a model with internal steps, the frozen one): its internal step dt is
 * never below rom_dt_floor (the model's own dt x ROM_DT_FLOOR_RATIO, and never below ROM_DT_MIN: a resource
 * file whose dt is below it is refused), and one doStep takes at most rom_max_steps_per_call internal steps
 * (ROM_MAX_WORK_PER_CALL multiply-adds over the cost of one step at the state's k_v, k_rho, n_freeze and
 * ports; about 0.3 s on one core of this project's 2-core machine, idle). */
#define ROM_DT_MIN 1e-9               /* [s] the smallest internal step of a model's resources */
#define ROM_DT_FLOOR_RATIO 1e-3       /* the parameter dt (and a state's) is at least this x the model's dt */
#define ROM_MAX_WORK_PER_CALL 2e9     /* multiply-adds of the internal steps of one doStep */
#define ROM_STEP_OVERHEAD 32.0        /* multiply-adds one internal step costs beyond its arithmetic (loop, check) */

/* The FMU's value references and start values are not the core's: fmu_src/fmu_variables.h, generated from the
 * variable table harness/fmu/variables.py. */
/* |initial_state_scale| at most (harness/defaults.py MAX_INITIAL_STATE_SCALE, the variable table's min and max): the
 * reduced models are built on the scene's own deviation from rest (scale 1); 1e308 overflowed the outputs */
#define ROM_MAX_INITIAL_STATE_SCALE 1e3
#define ROM_MAX_PARTICLES 1000000u   /* particles of a frozen model's particle refresh (sections PART*) */

typedef enum { ROM_OK = 0, ROM_FAIL = 1 } RomStatus;

/* One tagged section of the resources: a rows x cols matrix (row-major) */
typedef struct {
    char tag[ROM_SECTION_TAG_SIZE + 1];  /* NUL terminated */
    uint32_t rows, cols;
    double *data;
} RomSection;

/* Writes the message (printf format) into message[message_size] when given; returns ROM_FAIL
 * (rom_fail.c: the core, the instance layer and sph.c report failures through it; never exported) */
RomStatus rom_fail(char *message, size_t message_size, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(ROM_PRINTF_FORMAT, 3, 4)))
#endif
    ;

/* A model kind's table of operations (rom_internal.h): what the frozen and the linear models do differently */
typedef struct RomKindOps RomKindOps;

/* The certified error bounds' shadow (rom_bound.c; sections SHSCAL, SHLAM, SHB, SHC, SHW0, SHROW, SHRATE, SHPROBE,
 * SHTAB and SHTERR with an initial state outside the shadow (SHCONT: its modes continued past the table), SHPIECE,
 * SHPARAM, SHCPL of a parametric model, written by harness/rom/bounds.py): the full linear SPH's lowest `planes`
 * invariant planes, stepped exactly, and per output row r the shadow's value (with the complement's quasi-static
 * feedthrough and its tabulated free response) and the certified bound of the rest (docs/science/error-bounds.md).
 * Rows: v at each probe, e at the two particles of each probe (P + 2 j + m), each port's velocity (3 P + j).
 * Inputs: f [m s^-2], then F_j / area [N m^-2] (f alone with a port channel).  order 0: the model has no bounds. */
typedef struct {
    uint32_t order, planes, inputs, rows;  /* k_s = 2 planes, m, 3 P + ports */
    uint32_t groups;           /* G: decay-rate groups of the complement's transient */
    uint32_t nodes, q, blocks; /* the free response table: nodes (0: none), intervals per error block, blocks */
    uint32_t row_len;          /* 1 + 2 m + m G + G: |c_r|, D_r, static gains, transient gains, tail */
    uint32_t n_cpl;            /* a parametric shadow's complement planes */
    double h_tab;              /* [s] the table's node spacing */
    double t_end;              /* [s] the table's end, h_tab (nodes - 1) (0: no table; set with them, read per step) */
    double inv_q;              /* 1 / q (0: no table): the block of an interval without an integer division per step */
    double x0_norm;            /* the whole initial state's norm */
    double e_norm, b_norm;     /* the planes' residual norm (round-off), the shadow's input norm */
    double mu;                 /* the largest growth rate of a plane's symmetric part (0 at least) */
    double growth;             /* [s^-1] the truth's e^{At} grows by at most e^{growth t}: the residual's drift term
                                  carries it (harness/rom/lti.py skew_growth; 0: a contraction) */
    double tolerance;          /* error_tolerance's default [m s^-1] */
    const double *lam;         /* [planes][4] each plane's 2 x 2 block */
    const double *B;           /* [order][inputs] */
    const double *C;           /* [rows][order] */
    const double *w0;          /* [order] the shadow's initial state (initial_state_scale 1) */
    const double *row;         /* [rows][row_len] */
    const double *rates;       /* [groups] [s^-1] */
    const double *tab;         /* [2 rows][nodes]: g_r at the nodes, then g_r' */
    const double *terr;        /* [rows][blocks] */
    uint32_t n_cont;           /* the modes continued past the table's end (section SHCONT; 0: none) */
    const double *cont;        /* [1 + rows][2 n_cont]: their exponents mu_M (Re, Im) [s^-1], then per row the
                                  amplitudes P_rM exp(mu_M t_end) (Re, Im) */
    const double *probe;       /* [n_probes][4] the probe's weights and rho0 at its two particles */
    /* a parametric shadow (sections SHPIECE, SHPARAM, SHCPL, with PARAMS; NULL piece: none): lam = SHLAM + c
     * piece[0:4] + d piece[4:8] per plane, and the rows' terms and rates computed from the complement planes, at the
     * state's c and d (rom_model_assemble) into storage_, with mu, e_norm and e_scale = sqrt(c_ref / c), the
     * factor of |c_r| of the e rows (rows P .. 3P - 1) */
    const double *piece;       /* [planes][8] */
    const double *cpl;         /* [n_cpl][2 + 2 rows + inputs]: sigma, eta, c_hat (rows x 2), b (inputs) */
    double c_ref;              /* [kg m^-1 s^-2] the c of the shadow's energy coordinates */
    double e_piece[6];         /* |E_p| of the pieces (const, c, d), their v rows and e rows */
    double e_scale;            /* 1 without pieces */
    uint64_t generation;       /* the rows' terms' version: 1 once prepared, + 1 at each assembly (a state's copies
                                  of them, rom_bound.c check_terms, are of one version) */
    double *storage_;          /* [planes][4] planes, [rows][row_len] row terms, [groups] rates; owned by the model */
} RomBoundModel;

/* The port channel (rom_port.c; sections PCSCAL, PCLAM, PCB, PCC, PCD, PCPROBE, written by
 * harness/rom/port_channel.py): the full linear SPH's response to the port forces alone, in the singular planes of
 * its coupling that the ports excite, exact in time; superposed on the kind's outputs (the kind then takes no port
 * input: no section PORTB).  Rows in the order of the error bounds' shadow: v at each probe (over p), e at the two
 * particles of each probe (over q), v at each port (over p).  planes 0: no channel. */
typedef struct {
    uint32_t planes, ports, rows;  /* kept planes n, ports P, rows R = 3 n_probes + P */
    uint32_t pad;              /* planes rounded up to 16: the length of the state's and the maps' arrays */
    int truncated;             /* 1: excited planes were left out (the static correction and the gains apply) */
    double dx;                 /* [m] the particle spacing (the energy: 1/2 |w|^2 dx area) */
    const double *lam;         /* [planes][4] each plane's block [s^-1] */
    const double *beta;        /* [planes][ports] the input gains per unit F_j / area */
    const double *C;           /* [rows][planes] */
    const double *D;           /* [rows][4 ports + 1]: the static correction per unit u, then the remainder's gains,
                                * then the decomposition's drift gains per unit of int |u_j| dt, of int tv_j dt and
                                * of int |w| dt (harness/rom/port_channel.py PortChannel.drift) */
    double beta_norm;          /* the Frobenius norm of beta (the drift's bound of |w| over a step) */
    double growth;             /* [s^-1] the truth's e^{At} grows by at most e^{growth t}: the drift carries it */
    const double *probe;       /* [n_probes][4] the probe's weights and rho0 at its two particles */
    void *storage_;            /* beta^T [ports][pad], C [rows][pad] zero-padded, the row norms [rows] */
    const double *beta_t, *C_pad, *row_norm;
} RomChannelModel;

/* The reduced model of one scene (immutable once loaded, but for rom_model_assemble).  What every kind has
 * is here; what one kind has is in its own struct behind body (rom_frozen.h RomFrozenModel, rom_exact.h
 * RomExactModel), reached through the kind's operations ops. */
typedef struct {
    uint32_t kind;             /* ROM_MODEL_FROZEN or ROM_MODEL_EXACT_LINEAR (the header's model_kind) */
    const RomKindOps *ops;     /* the kind's operations, chosen from kind when the resources are read */
    void *body;                /* the kind's own data (operators, probe rows; the frozen kind's integrator, n_pairs,
                                * default n_freeze and dt), owned by the kind */
    uint32_t k_v, k_rho, n_probes, flags;
    uint32_t kv_pad, kr_pad;   /* k_v, k_rho rounded up to a multiple of 4: the lengths of a state's av, ar */
    uint32_t input_width;      /* entries of one input row (port_B): k_v (frozen), k = k_v + k_rho (linear) */
    double runaway_bound;      /* |a| above this is a runaway */
    double L;                  /* period [m] */
    const double *probe_x;     /* [n_probes] probe positions in units of L (in the kind's storage) */
    uint32_t n_sections;       /* the tagged sections, in file order (rom_model_section) */
    RomSection sections[ROM_MAX_SECTIONS];
    char token[ROM_TOKEN_SIZE + 1];
    void *sections_storage_;   /* one allocation behind the sections' data */
    /* mechanical ports (sections PORTX, PORTB, PORTC; harness/sph/ports.py): a point force F_j [N] at x_j
     * enters as u_j = F_j / area over the input row port_B[j] (input_width entries, for area 1);
     * v_port_j = port_C[j] . a^v (k_v entries) */
    uint32_t n_ports;          /* 0: no ports */
    const double *port_x;      /* [n_ports] positions x/L */
    const double *port_B;      /* [n_ports][input_width] */
    const double *port_C;      /* [n_ports][k_v] */
    RomBoundModel bound;       /* the certified error bounds (order 0: none) */
    RomChannelModel channel;   /* the port channel (planes 0: none) */
} RomModel;

/* The mutable state of one instance: what every kind has, and the kind's own state behind body
 * (rom_frozen.h RomFrozenState, rom_exact.h RomExactState). */
typedef struct {
    const RomModel *model;
    void *body;             /* the kind's own state (the frozen M^T and F and its parameters n_freeze and dt; the
                             * exact model's forced part and exponentials), owned by the kind */
    double *av, *ar;        /* reduced coordinates a^v [kv_pad], a^rho (linear: b = e coordinates) [kr_pad] */
    double *v_kept;         /* [n_probes] the kind's v_probe of this state, once read (NaN: not read since the state
                             * last moved; rom.c rom_outputs_moved): doStep's error check and the importer's reads
                             * share one sum (NULL without the error bounds: one read per state) */
    int64_t n;              /* internal steps since reset (shortened ones too) */
    double time;            /* time of the state [s] */
    double f;               /* input, held over a communication step [m s^-2] */
    double initial_state_scale;  /* the initial velocity coordinates (frozen) or z (linear) are this times the
                                  * model's; the density coordinates of the frozen model stay (rho0 is rest) */
    double elapsed;         /* the time since the start [s]: the sum of the steps taken, exact at any start time
                             * (the exact model's free response, the error bounds' table) */
    double f_rate;          /* the input rate df/dt over a step [m s^-3] (0: input held) */
    void *storage_;         /* one allocation behind av, ar */
    /* parametric models (section PARAMS): the chosen stiffness c [kg m^-1 s^-2] and damping d [s^-1],
     * the start values after a reset; the operators are assembled from them by rom_model_assemble */
    double c, d;
    /* ports: the cross-section area [m^2] (parameter, > 0), the force F_j [N] at port j (input) and its
     * rate dF_j/dt [N s^-1] over a step (linear model; 0: held) */
    double area;
    double port_force[ROM_MAX_PORTS];
    double port_rate[ROM_MAX_PORTS];
    /* 1 once a step was taken with a nonzero port force or rate (since reset), else 0: from then on the
     * state holds a response the training run (without port forces) never saw, and the training
     * envelope checks only |f| and the failure strain (rom_envelope.c) */
    double port_driven;
    /* the certified error bounds (rom_bound.c): the shadow's state (NULL without bounds), and the parameter
     * error_tolerance [m s^-1] (0: no warning) */
    void *bound;
    double error_tolerance;
    /* the port channel's state (rom_port.c; NULL without it): its planes, maps, the wave form's waves */
    void *channel;
} RomState;

/* ---- resources ---------------------------------------------------------- */
ROM_API RomStatus rom_model_load_memory(const void *data, size_t size, RomModel **out,
                                        char *message, size_t message_size);
ROM_API RomStatus rom_model_load_file(const char *path, RomModel **out,
                                      char *message, size_t message_size);
ROM_API void rom_model_free(RomModel *model);
/* The section with this tag, NULL when the model has none */
ROM_API const RomSection *rom_model_section(const RomModel *model, const char *tag);
ROM_API uint32_t rom_crc32(const void *data, size_t size);

/* ---- state -------------------------------------------------------------- */
ROM_API RomState *rom_state_new(const RomModel *model);
ROM_API void rom_state_free(RomState *state);
/* a = a0, n = 0, time = t_start, f = 0, parameters to their defaults (initial_state_scale 1: the model's own
 * initial state; the FMU instance then applies its start value ROM_INITIAL_STATE_SCALE_START) */
ROM_API void rom_state_reset(RomState *state, double t_start);
ROM_API RomStatus rom_set_start_time(RomState *state, double t_start, char *message, size_t message_size);
ROM_API RomStatus rom_set_input(RomState *state, double f, char *message, size_t message_size);
/* The parameters of a model with internal steps (the frozen kind's; the linear models have neither: ROM_FAIL
 * naming the parameter): the internal step dt [s] (finite, >= rom_dt_floor) and the refresh period n_freeze */
ROM_API RomStatus rom_set_dt(RomState *state, double dt, char *message, size_t message_size);
ROM_API RomStatus rom_set_n_freeze(RomState *state, int64_t n_freeze, char *message, size_t message_size);
/* their values: dt [s] (NaN without internal steps or for NULL), n_freeze (0 likewise) */
ROM_API double rom_dt(const RomState *state);
ROM_API int32_t rom_n_freeze(const RomState *state);
/* Any real in [-ROM_MAX_INITIAL_STATE_SCALE, ROM_MAX_INITIAL_STATE_SCALE], before the first step: the initial
 * state becomes scale x the model's deviation from rest
 * (frozen: a^v(0) = scale a_v0, a^rho(0) = a_rho0; linear: z(0) = scale z0, z = 0 being rest) */
ROM_API RomStatus rom_set_initial_state_scale(RomState *state, double scale, char *message, size_t message_size);

/* Advance from t_comm by h > 0, reaching t_comm + h exactly: whole internal
 * steps of dt and one shortened last step.  Fails (message names the time) on
 * a time mismatch (ROM_TIME_ULPS), a bad h (not finite and > 0, t_comm + h not
 * finite or not later than t_comm), a non-finite or runaway state, or a
 * density <= 0 at a probe. */
ROM_API RomStatus rom_do_step(RomState *state, double t_comm, double h, char *message, size_t message_size);
/* 1 when the frozen model's internal step dt exceeds the communication step h (beyond
 * ROM_STEP_ROUNDING): rom_do_step then takes one internal step of length h */
ROM_API int rom_step_exceeds(const RomState *state, double h);
/* 1 when the model advances by internal steps of dt (and has the parameters dt and n_freeze: the frozen
 * model), 0 when it advances over any step exactly (the linear models) or for NULL */
ROM_API int rom_has_internal_step(const RomModel *model);
/* One line describing the model (sizes and the kind's settings) into out[size] (empty for NULL) */
ROM_API void rom_describe(const RomModel *model, char *out, size_t size);
/* The smallest internal step dt the state accepts (parameter, serialized state) [s]: max(ROM_DT_MIN, model dt x
 * ROM_DT_FLOOR_RATIO) for a model with internal steps, 0 for the linear models (one exact step over any h) */
ROM_API double rom_dt_floor(const RomModel *model);
/* The most internal steps one doStep takes at the state's settings (ROM_MAX_WORK_PER_CALL over the cost of one
 * internal step, rom_step_work); a longer communication step is refused naming it.  0 for NULL. */
ROM_API double rom_max_steps_per_call(const RomState *state);
/* The multiply-adds of one internal step at the state's k_v, k_rho, n_freeze and ports, ROM_STEP_OVERHEAD
 * included (0 for a model without internal steps) */
ROM_API double rom_step_work(const RomState *state);
/* n_steps whole internal steps of dt with the runaway check (benchmark, tests; a model with internal steps:
 * the linear models, exact over any step, refuse it) */
ROM_API RomStatus rom_advance(RomState *state, int64_t n_steps, char *message, size_t message_size);
/* The input goes linearly over each step, f(t_comm + tau) = f + rate tau (rate 0, the
 * default, holds it), and after the step f = f + rate h, so that the input continues linearly
 * until it is set again.  The exact model integrates it exactly; the frozen model evaluates it
 * at each refresh of its force term, at the internal step's time tau = j dt (as
 * harness/rom/frozen.py and harness/fmu/check/python_cosim.py do, bit for bit). */
ROM_API RomStatus rom_set_input_rate(RomState *state, double rate, char *message, size_t message_size);
/* The reduced state: a^v (k_v values) then a^rho (frozen) or b = e coordinates (exact) into out[n];
 * returns the count written (0 on a bad argument) */
ROM_API size_t rom_reduced_state(const RomState *state, double *out, size_t n);
/* exponentials computed by this state (the exact model caches them per step length) */
ROM_API int64_t rom_expm_count(const RomState *state);
/* kind of a loaded model (ROM_MODEL_*), 0 for NULL */
ROM_API uint32_t rom_model_kind(const RomModel *model);
/* The frozen model's refresh (rom_frozen.c): *path 0 the tensor, 1 the tensor stored by its symmetry (the same
 * bits; chosen at load by measured cost when the tensor has the symmetry); *skip 1: a refresh whose inputs equal
 * the last one's is skipped (the same bits).  rom_frozen_set_refresh sets them (-1: unchanged), for tests and
 * benchmarks; ROM_FAIL for another kind, or path 1 without the symmetry. */
ROM_API RomStatus rom_frozen_refresh(const RomModel *model, int *path, int *skip);
ROM_API RomStatus rom_frozen_set_refresh(RomModel *model, int path, int skip, char *message, size_t message_size);
/* Probe outputs.  Frozen: v_j = sum_q Pv[j][q] a^v_q, rho_j = sum_q Prho[j][q] a^rho_q.
 * Linear: v_j = Pv[j] . z, rho_j = sum_m pw[j][m] prho0[j][m] / (1 + Pe[j][m] . z) (NaN when a J <= 0) */
ROM_API double rom_v_probe(const RomState *state, uint32_t j);
/* Linear models: the name of the linear model (section LINMODEL: "exact POD", "balanced"; "linear" when the
 * resources do not say), for messages; NULL for the frozen model.  The core never branches on it. */
ROM_API const char *rom_linear_model_name(const RomModel *model);
ROM_API double rom_rho_probe(const RomState *state, uint32_t j);
/* The highest order of output derivatives the model gives exactly: 1 for the linear models, 0 for the
 * frozen model (a discrete map of internal steps, not a differentiable function of time) */
ROM_API int rom_max_output_derivative_order(const RomModel *model);
/* Linear models: the first time derivative of a probe output at the state's time, exact:
 * dz/dt = A z + B f with f the input now (after a step with an input rate: f + rate h),
 * dv_j/dt = Pv[j] . (dz/dt)_a, drho_j/dt = -sum_m pw[j][m] prho0[j][m] (Pe[j][m] . (dz/dt)_b) / J_m^2.
 * Fails (message) for the frozen model or a bad probe index. */
ROM_API RomStatus rom_v_probe_rate(const RomState *state, uint32_t j, double *rate, char *message,
                                   size_t message_size);
ROM_API RomStatus rom_rho_probe_rate(const RomState *state, uint32_t j, double *rate, char *message,
                                     size_t message_size);
/* Check the probe densities (> 0 and finite) at the current time */
ROM_API RomStatus rom_check_outputs(const RomState *state, char *message, size_t message_size);

/* ---- serialized state (magic, version, sizes, token, crc) ------------------ */
/* the size of a serialized state (ROM_STATE_VERSION) of this model; 0 for NULL */
ROM_API size_t rom_state_serialized_size(const RomModel *model);
ROM_API void rom_state_serialize(const RomState *state, uint32_t tag, unsigned char *buffer);
/* Checks a blob against this model (magic, version, sizes, token, crc), then the parameters it carries, each
 * named when refused: the kind's (frozen: n_freeze an integer >= 1, dt at least its floor), initial_state_scale
 * finite, c and d within the trained range of a varied parameter, equal to the model's value of a fixed one, 0
 * without section PARAMS; area finite and > 0. */
ROM_API RomStatus rom_state_check(const RomModel *model, const unsigned char *buffer, size_t size,
                                  char *message, size_t message_size);
/* Restores the state (a checked blob) with its parameters; a parametric model then needs its operators
 * re-assembled at the restored c and d (rom_model_assemble; the instance layer does it) */
ROM_API RomStatus rom_state_deserialize(RomState *state, const unsigned char *buffer, size_t size,
                                        uint32_t *tag, char *message, size_t message_size);

/* ---- the training envelope (rom_envelope.c; sections ENVELOPE, ENVRANGE, ENVPROBE) ---- */
/* (the columns of ENVELOPE and its check bits ROM_ENVELOPE_CHECK_*: rom_layout.h) */
/* 1 when the state or the input is outside the model's training envelope widened by its margin (the
 * message, when given, names the quantity, its value, the trained range and the time); 0 inside it, for
 * a model without an envelope, and for a linear model (no run-time checks) */
ROM_API int rom_envelope_check(const RomState *state, char *message, size_t message_size);

/* ---- parametric models (sections PARAMS and KC, BC, DD or A0, AC, AD) ------------
 * The operators are affine in c and d: frozen K = c K_c, b = c b_c, D = d D_d; linear
 * A = A_0 + c A_c + d A_d (harness/rom/parametric.py).  PARAMS row 0 is c, row 1 is d:
 * (varied 0/1, start, min, max). */
#define ROM_PARAM_C ROM_PARAMS_ROW_C
#define ROM_PARAM_D ROM_PARAMS_ROW_D
/* 1 when the model exposes parameter which (ROM_PARAM_C or ROM_PARAM_D), else 0 */
ROM_API int rom_varies(const RomModel *model, int which);
/* Set c or d of a parametric model; fails, naming the value and the trained range, outside it */
ROM_API RomStatus rom_set_param(RomState *state, int which, double value, char *message, size_t message_size);
ROM_API double rom_get_param(const RomState *state, int which);
/* Assemble the operators of the state's (c, d) into the model (O(k^2)) and empty the state's
 * exponential cache; a model without PARAMS is left as it is.  Called once the parameters are
 * fixed (ExitInitializationMode). */
ROM_API RomStatus rom_model_assemble(RomModel *model, RomState *state, char *message, size_t message_size);

/* ---- mechanical ports ----------------------------------------------------- */
/* the number of ports of a model (0 without ports or for NULL) */
ROM_API uint32_t rom_n_ports(const RomModel *model);
/* the point force F_j [N] at port j (0-based), held over a communication step; finite */
ROM_API RomStatus rom_set_port_force(RomState *state, uint32_t j, double force, char *message, size_t message_size);
ROM_API double rom_port_force(const RomState *state, uint32_t j);
/* the cross-section area [m^2] (> 0, finite): the port inputs are F_j / area */
ROM_API RomStatus rom_set_area(RomState *state, double area, char *message, size_t message_size);
/* As rom_set_input_rate for f: F_j goes linearly over each step at this rate [N s^-1] and continues
 * after it; setting F_j through rom_set_port_force keeps the rate (the instance layer resets it).  The
 * linear model integrates it exactly; the frozen model takes F_j + rate tau at each refresh, as f. */
ROM_API RomStatus rom_set_port_rate(RomState *state, uint32_t j, double rate, char *message, size_t message_size);
/* v_port_j = sum_q port_C[j][q] a^v_q [m s^-1], plus the port channel's part (NaN for a bad j) */
ROM_API double rom_v_port(const RomState *state, uint32_t j);

/* ---- the port channel (rom_port.c) ----------------------------------------------- */
/* 1 when the model carries the port channel (sections PC*), else 0 (NULL too) */
ROM_API int rom_has_channel(const RomModel *model);
/* The wave (transmission-line) form of the ports: the parameter port_impedance Z [N s m^-1] (finite, >= 0; 0, the
 * start: the force form, F_port_j are the inputs), and with Z > 0 the incident waves a_j [N] (inputs, held over a
 * step, or linear with a rate: rom_set_port_wave_rate): over each step the port force is held at F_j = 2 a_j - Z vbar_j, vbar_j the mean port velocity over the
 * step (solved exactly: the channel's mean is linear in F), and the reflected wave b_j = a_j - F_j = Z vbar_j - a_j
 * (output), which a master passes on, one step later, as the incident wave of the component at the line's other end
 * (the same form there).  The power over a step is F vbar = (a^2 - b^2) / Z: coupled through such lines the system's
 * energy (the components' and the waves' in the lines, h / Z per wave) never grows, at any communication step
 * (docs/fmu/coupling.md).  The model's own part of
 * vbar (its response to f and its initial state, which no port force moves) is the mean of its port velocity at the
 * step's two ends. */
ROM_API RomStatus rom_set_port_impedance(RomState *state, double impedance, char *message, size_t message_size);
ROM_API double rom_port_impedance(const RomState *state);
ROM_API RomStatus rom_set_port_wave(RomState *state, uint32_t j, double wave, char *message, size_t message_size);
ROM_API double rom_port_wave(const RomState *state, uint32_t j);
/* da_j/dt [N s^-1] (fmi2SetRealInputDerivatives, order 1; finite): a_j goes linearly over the step, a + adot tau, and
 * continues after it; the held force is the mean of 2 a(t) - Z v(t) over the step, F_j = 2 abar_j - Z vbar_j with
 * abar_j = a_j + adot_j h / 2, and b_j = abar_j - F_j.  0 (held) at the start; setting a_j holds it again (the
 * wrappers reset the rate, as for f and F_port_j) */
ROM_API RomStatus rom_set_port_wave_rate(RomState *state, uint32_t j, double rate, char *message, size_t message_size);
ROM_API double rom_port_wave_rate(const RomState *state, uint32_t j);
/* b_j [N] after the last step (0 before the first, and in the force form): abar_j - F_j */
ROM_API double rom_port_reflected(const RomState *state, uint32_t j);
/* the channel's energy 1/2 |w|^2 dx area [J] (0 without the channel) */
ROM_API double rom_channel_energy(const RomState *state);

/* ---- certified error bounds (rom_bound.c) ----------------------------------- */
/* 1 when the model carries the shadow of its error bounds (sections SH*), else 0 (NULL too) */
ROM_API int rom_has_bounds(const RomModel *model);
/* Certified upper bounds at the state's time of |output - truth|, the truth being the full linear SPH
 * (eqs. 2.10-2.11 in J) integrated exactly from the same initial state with the same inputs (held, or linear
 * with a rate): v_probe_j [m s^-1], rho_probe_j [kg m^-3] (INFINITY where the certified interval of J reaches 0),
 * v_port_j [m s^-1].  NaN for a bad index or a model without bounds. */
ROM_API double rom_v_probe_error_bound(const RomState *state, uint32_t j);
ROM_API double rom_rho_probe_error_bound(const RomState *state, uint32_t j);
ROM_API double rom_v_port_error_bound(const RomState *state, uint32_t j);
/* error_tolerance [m s^-1]: finite and >= 0 (0: no warning) */
ROM_API RomStatus rom_set_error_tolerance(RomState *state, double tolerance, char *message, size_t message_size);
/* 1 when error_tolerance > 0 and the bound of a velocity output (v_probe_j, v_port_j) exceeds it; the message,
 * when given, names the output, its bound, the tolerance and the time.  0 otherwise (no bounds too). */
ROM_API int rom_bound_exceeded(const RomState *state, char *message, size_t message_size);

ROM_API const char *rom_version(void);

#ifdef __cplusplus
}
#endif

#endif /* SPHROM_ROM_H */
