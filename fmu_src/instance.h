/*
 * The FMU instance, version-neutral: what fmi2_cs.c and fmi3_cs.c share, with
 * no FMI types (after the Reference-FMUs' split of model, instance and FMI
 * functions).
 *
 * An instance holds the model (rom.h), its state, the mode of the FMI state
 * machine, the instance name, the enabled log categories and the core's last
 * message.  This layer does the instantiate sequence (resource location ->
 * resources/model.bin, load, token check), the state machine's checks and the
 * Error state, logging (through a small adapter each FMI version supplies),
 * the variables by value reference (one table maps value references to the
 * core's getters and setters), doStep and the FMU state snapshots.
 *
 * Each FMI adapter keeps its function table (the modes in which each function
 * is allowed) and converts types and statuses.  There are no globals.
 */
#ifndef SPHROM_INSTANCE_H
#define SPHROM_INSTANCE_H

#include <stddef.h>
#include <stdint.h>

#include "rom.h"
#include "fmu_variables.h"   /* value references and the variable table's rows (generated) */

/* Numbered as FMI 2 and FMI 3 number their statuses (OK, Warning, Discard, Error), so
 * that an adapter converts a status with a cast. */
typedef enum { INSTANCE_OK = 0, INSTANCE_WARNING = 1, INSTANCE_ERROR = 3 } InstanceStatus;

/* An adapter checks that numbering when it compiles (a negative array size otherwise) */
#define INSTANCE_STATUS_NUMBERING(ok, warning, error) \
    typedef char instance_status_numbering[((ok) == (int)INSTANCE_OK && (warning) == (int)INSTANCE_WARNING && \
                                            (error) == (int)INSTANCE_ERROR) ? 1 : -1]

/* Modes of the state machine, as bits so that a set of modes is one mask.
 * MODE_STEP is FMI 2's StepComplete and FMI 3's StepMode. */
typedef enum {
    MODE_INSTANTIATED = 1 << 0,
    MODE_INITIALIZATION = 1 << 1,
    MODE_STEP = 1 << 2,
    MODE_TERMINATED = 1 << 3,
    MODE_ERROR = 1 << 4
} InstanceMode;

#define MODES_ANY (MODE_INSTANTIATED | MODE_INITIALIZATION | MODE_STEP | MODE_TERMINATED | MODE_ERROR)
#define MODES_NOT_ERROR (MODE_INSTANTIATED | MODE_INITIALIZATION | MODE_STEP | MODE_TERMINATED)
#define MODES_READABLE (MODE_INITIALIZATION | MODE_STEP | MODE_TERMINATED)
#define MODES_SETTABLE (MODE_INSTANTIATED | MODE_INITIALIZATION | MODE_STEP)

/* log categories (bits); names as declared in modelDescription.xml */
#define INSTANCE_LOG_EVENTS 1u       /* logEvents */
#define INSTANCE_LOG_WARNING 2u      /* logStatusWarning */
#define INSTANCE_LOG_ERROR 4u        /* logStatusError */
#define INSTANCE_LOG_ALL (INSTANCE_LOG_EVENTS | INSTANCE_LOG_WARNING | INSTANCE_LOG_ERROR)

#define INSTANCE_LOOKUP_BITS 6
#define INSTANCE_LOOKUP_SLOTS (1u << INSTANCE_LOOKUP_BITS)   /* value references remembered (Instance.lookup_ref) */

/* The importer's logger, stored untyped; the version's adapter casts it back. */
typedef void (*InstanceCallback)(void);

/* A version's logging adapter: hand one message to the importer's logger
 * (nothing when it is NULL). */
typedef void (*InstanceEmit)(InstanceCallback logger, void *environment, const char *name, InstanceStatus status,
                             const char *category, const char *text);

/* What differs between the FMI versions, as data (one static const per adapter). */
typedef struct {
    const char *step_mode;             /* MODE_STEP's name in messages */
    const char *error_exits;           /* the calls that lead out of the Error state */
    const char *exit_initialization;   /* the call after which fixed parameters are fixed */
    const char *token_name;            /* the instantiate argument holding the token */
    int resource_uri;                  /* resource location: a file URI (1) or a folder path (0) */
    int has_time;                      /* the independent variable time has a value reference */
    InstanceEmit emit;
} InstanceVersion;

typedef struct {
    RomModel *model;
    RomState *state;
    InstanceMode mode;
    char *name;
    const InstanceVersion *version;
    InstanceCallback logger;
    void *environment;
    uint32_t log_mask;                 /* enabled INSTANCE_LOG_* categories */
    int warned_long_dt;                /* the warning on dt > h was logged */
    int warned_envelope;               /* the warning on leaving the training envelope was logged (reset re-arms) */
    int assembled;                     /* parametric models: the model's operators were assembled at */
    double assembled_c, assembled_d;   /* these c [kg m^-1 s^-2] and d [s^-1] (rom_model_assemble) */
    /* the value references found so far, direct mapped by a hash of the reference (instance.c lookup): slot s holds
     * reference lookup_ref[s], the table's row lookup_row[s] - 1 (0: empty), its member lookup_member[s] */
    uint32_t lookup_ref[INSTANCE_LOOKUP_SLOTS];
    uint16_t lookup_row[INSTANCE_LOOKUP_SLOTS];
    uint16_t lookup_member[INSTANCE_LOOKUP_SLOTS];
    char message[ROM_MESSAGE_SIZE];    /* the core's last message */
} Instance;

/* ---- an adapter's function table ------------------------------------------- */

/* An adapter lists its functions with the modes in which each may be called,
 * CALLS(X) expanding to X(call, modes) X(call, modes) ..., and declares with
 * INSTANCE_CALL_TABLE(CALLS) the ids CALL_<call> and their masks CALL_MODES[]. */
#define INSTANCE_CALL_ID(call, modes) CALL_##call,
#define INSTANCE_CALL_MODES(call, modes) (unsigned)(modes),
#define INSTANCE_CALL_TABLE(CALLS) \
    typedef enum { CALLS(INSTANCE_CALL_ID) CALL_COUNT } Call; \
    static const unsigned CALL_MODES[CALL_COUNT] = {CALLS(INSTANCE_CALL_MODES)}

/* The start of an adapter function: the instance behind the handle, the
 * function's name for the log (fn), the mode check against the table; an
 * illegal call returns error (the version's error status). */
#define INSTANCE_ENTER(handle, call, name, error) \
    Instance *const inst = (Instance *)(handle); \
    const char *const fn = (name); \
    if (!instance_allowed(inst, fn, CALL_MODES[CALL_##call])) return (error)

/* ---- life cycle --------------------------------------------------------- */

/* The instantiate sequence (fn names the FMI function in messages): name and
 * token present, resources/model.bin from the resource location, load, token
 * check, a fresh state.  On failure logs why and returns NULL. */
Instance *instance_new(const InstanceVersion *version, const char *fn, const char *name, const char *token,
                       const char *resource_location, int logging_on, InstanceCallback logger, void *environment);
void instance_free(Instance *inst);
/* An error before there is an instance (logged as logStatusError under name, or "sphrom") */
void instance_report(const InstanceVersion *version, InstanceCallback logger, void *environment, const char *name,
                     const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(ROM_PRINTF_FORMAT, 5, 6)))
#endif
    ;

/* ---- the state machine, errors and logging --------------------------------- */

/* 1 when inst exists and is in one of the modes; else the illegal call is
 * logged, the instance enters the Error state, and 0 */
int instance_allowed(Instance *inst, const char *fn, unsigned modes);
/* Log "fn: message" as an error, enter the Error state, return INSTANCE_ERROR */
InstanceStatus instance_error(Instance *inst, const char *fn, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(ROM_PRINTF_FORMAT, 3, 4)))
#endif
    ;
/* Log a message of a category when the category is enabled */
void instance_log(Instance *inst, InstanceStatus status, uint32_t category, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(ROM_PRINTF_FORMAT, 4, 5)))
#endif
    ;
InstanceStatus instance_set_debug_logging(Instance *inst, const char *fn, int logging_on, size_t n_categories,
                                          const char *const categories[]);

InstanceStatus instance_setup_experiment(Instance *inst, const char *fn, double start_time, int stop_time_defined,
                                         double stop_time);
InstanceStatus instance_enter_initialization(Instance *inst);
InstanceStatus instance_exit_initialization(Instance *inst, const char *fn);
InstanceStatus instance_terminate(Instance *inst);
InstanceStatus instance_reset(Instance *inst);

/* ---- variables by value reference ------------------------------------------ */

/* n_values must equal n_refs (every variable is a scalar; FMI 2 passes n_refs) */
InstanceStatus instance_get_float64(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                    double values[], size_t n_values);
InstanceStatus instance_set_float64(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                    const double values[], size_t n_values);
InstanceStatus instance_get_int32(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                  int32_t values[], size_t n_values);
InstanceStatus instance_set_int32(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                  const int32_t values[], size_t n_values);
/* First derivatives of inputs at the time of their last set value (FMI 2's fmi2SetRealInputDerivatives), on the
 * inputs the variable table gives a rate (f [m s^-3], F_port_j [N s^-1]): f(t_comm + tau) = f + rate tau over the
 * following communication steps, until f is set again (which resets the rate to 0).  Order 1 only. */
InstanceStatus instance_set_input_derivatives(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                             const int32_t orders[], const double values[]);
/* Time derivatives of outputs at the current time (fmi2GetRealOutputDerivatives,
 * fmi3GetOutputDerivatives): order 1 of v_probe_j and rho_probe_j in the linear models
 * (rom_max_output_derivative_order); the frozen model, another variable or another order is an
 * error naming what is allowed.  n_values must equal n_refs. */
InstanceStatus instance_get_output_derivatives(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                               const int32_t orders[], double values[], size_t n_values);
/* a type without variables: any value reference is unknown */
InstanceStatus instance_no_variables(Instance *inst, const char *fn, const uint32_t refs[], size_t n_refs,
                                     const void *values, size_t n_values);
/* the number of variables ref depends on (none is declared: the outputs depend on the state) */
InstanceStatus instance_dependencies(Instance *inst, const char *fn, uint32_t ref, size_t *count);

/* ---- stepping ------------------------------------------------------------ */

InstanceStatus instance_do_step(Instance *inst, const char *fn, double t_comm, double h);
/* the time reached (the last communication point, or the last good time after a failed step) */
double instance_time(const Instance *inst);

/* ---- FMU state snapshots (opaque to the importer) ------------------------------ */

InstanceStatus instance_get_state(Instance *inst, const char *fn, void **snapshot);
InstanceStatus instance_set_state(Instance *inst, const char *fn, const void *snapshot);
InstanceStatus instance_free_state(Instance *inst, const char *fn, void **snapshot);
InstanceStatus instance_state_size(Instance *inst, const char *fn, const void *snapshot, size_t *size);
InstanceStatus instance_serialize_state(Instance *inst, const char *fn, const void *snapshot, unsigned char bytes[],
                                        size_t size);
InstanceStatus instance_deserialize_state(Instance *inst, const char *fn, const unsigned char bytes[], size_t size,
                                          void **snapshot);

#endif /* SPHROM_INSTANCE_H */
