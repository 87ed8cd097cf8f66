/*
 * sphrom model core: the state API of rom.h, the same for every model kind.
 * What a kind does differently (its data, layout, reset, step, outputs and
 * their rates, checks, parameters) is asked of the model's table of
 * operations, model->ops (rom_internal.h; rom_frozen.c, rom_exact.c): this
 * file never asks which kind a model is.  Resources are read in
 * rom_resources.c, states serialized in rom_state_io.c.
 */
#include "rom_internal.h"

#include <stdlib.h>

#define ROM_VERSION_STRING "sphrom-core 2"

const char *rom_version(void) {
    return ROM_VERSION_STRING;
}

uint32_t rom_model_kind(const RomModel *m) {
    return m ? m->kind : 0u;
}

const char *rom_linear_model_name(const RomModel *m) {
    if (!m || !m->ops || !m->ops->linear_name) return NULL;
    return m->ops->linear_name(m);
}

/* ------------------------------------------------------------------------ */
/* state                                                                     */
/* ------------------------------------------------------------------------ */

RomState *rom_state_new(const RomModel *model) {
    if (!model || !model->ops) return NULL;
    RomState *s = (RomState *)calloc(1, sizeof(RomState));
    if (!s) return NULL;
    s->model = model;
    /* a^v, a^rho (never NULL: a linear state with k_e = 0 gets one slot), the kept v_probe (with the error bounds,
     * whose check reads it before the importer does); then the kind's own arrays */
    const size_t counts[3] = {model->kv_pad, model->kr_pad ? model->kr_pad : 1,
                              rom_has_bounds(model) ? model->n_probes : 0};
    double **ptrs[3] = {&s->av, &s->ar, &s->v_kept};
    s->storage_ = rom_alloc_arrays(counts, ptrs, 3);
    if (!s->storage_ || model->ops->state_new(s) != ROM_OK || rom_bound_state_new(s) != ROM_OK ||
        rom_channel_state_new(s) != ROM_OK) {
        rom_state_free(s);
        return NULL;
    }
    rom_state_reset(s, 0.0);
    return s;
}

void rom_state_free(RomState *state) {
    if (!state) return;
    if (state->body && state->model->ops->state_free) state->model->ops->state_free(state);
    rom_bound_state_free(state);
    rom_channel_state_free(state);
    free(state->storage_);
    free(state);
}

/* the kind's state moved (a step, a reset, initial_state_scale, rom_advance, a new parameter, a state read): its
 * outputs are read anew, the kept v_probe and the port channel's kept v_port alike (rom_internal.h) */
void rom_outputs_moved(RomState *s) {
    if (!s) return;
    if (s->v_kept) {
        for (uint32_t j = 0; j < s->model->n_probes; j++) s->v_kept[j] = NAN;
    }
    rom_channel_kind_moved(s);
}

/* The initial reduced state from the model's and initial_state_scale (the kind's initial_state; rom.h's
 * rom_set_initial_state_scale says what it is). */
static void apply_initial_state(RomState *s) {
    const RomModel *m = s->model;
    memset(s->av, 0, m->kv_pad * sizeof(double));
    memset(s->ar, 0, m->kr_pad * sizeof(double));
    m->ops->initial_state(s);
    rom_outputs_moved(s);
}

void rom_state_reset(RomState *s, double t_start) {
    if (!s || !s->body) return;
    const RomModel *m = s->model;
    s->initial_state_scale = 1.0;
    apply_initial_state(s);
    m->ops->reset(s);
    s->elapsed = 0.0;         /* the time since the start and the input rate (0: f held) */
    s->f_rate = 0.0;
    s->n = 0;
    s->time = t_start;
    s->f = 0.0;
    const RomSection *params = rom_section(m, "PARAMS");       /* rows c, d: their start values */
    s->c = params ? params->data[ROM_PARAMS_COLUMNS * ROM_PARAMS_ROW_C + ROM_PARAMS_START] : 0.0;
    s->d = params ? params->data[ROM_PARAMS_COLUMNS * ROM_PARAMS_ROW_D + ROM_PARAMS_START] : 0.0;
    for (size_t j = 0; j < ROM_MAX_PORTS; j++) s->port_force[j] = s->port_rate[j] = 0.0;
    s->port_driven = 0.0;
    s->area = 1.0;                                             /* [m^2] */
    rom_bound_reset(s);                                        /* the bounds' shadow, error_tolerance */
    rom_channel_reset(s);                                      /* the port channel at rest, the force form */
    rom_outputs_moved(s);                                      /* (after the kind's reset too) */
}

RomStatus rom_set_start_time(RomState *s, double t_start, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!isfinite(t_start)) {
        return rom_fail(message, message_size, "startTime = %g s is out of range (allowed: a finite number)", t_start);
    }
    if (s->n != 0) return rom_fail(message, message_size, "the start time can be set only before the first step");
    s->time = t_start;
    s->elapsed = 0.0;
    return ROM_OK;
}

RomStatus rom_set_input(RomState *s, double f, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!isfinite(f)) {
        return rom_fail(message, message_size, "input f = %g at t = %.9g s is not finite (allowed: a finite force "
                        "per mass in m s^-2)", f, s->time);
    }
    s->f = f;
    return ROM_OK;
}

RomStatus rom_set_input_rate(RomState *s, double rate, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!isfinite(rate)) {
        return rom_fail(message, message_size, "input rate df/dt = %g at t = %.9g s is not finite", rate, s->time);
    }
    s->f_rate = rate;
    return ROM_OK;
}

double rom_dt_floor(const RomModel *m) {
    if (!m || !m->ops || !m->ops->dt_floor) return 0.0;
    return m->ops->dt_floor(m);
}

double rom_step_work(const RomState *s) {
    if (!s || !s->model->ops->step_work) return 0.0;
    return s->model->ops->step_work(s) + ROM_STEP_OVERHEAD;
}

double rom_max_steps_per_call(const RomState *s) {
    return rom_steps_per_call(rom_step_work(s));
}

/* the parameters of the internal step (the kind's table; a kind without internal steps has neither) */
RomStatus rom_set_dt(RomState *s, double dt, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!s->model->ops->set_dt) {
        return rom_fail(message, message_size, "parameter dt: %s has no internal step (it is exact over any "
                        "communication step)", s->model->ops->name);
    }
    if (!(isfinite(dt) && dt > 0)) {
        return rom_fail(message, message_size, "parameter dt = %g s is out of range (allowed: a finite number > 0)",
                        dt);
    }
    rom_outputs_moved(s);
    return s->model->ops->set_dt(s, dt, message, message_size);     /* and its floor (the work of a doStep) */
}

RomStatus rom_set_n_freeze(RomState *s, int64_t n_freeze, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!s->model->ops->set_n_freeze) {
        return rom_fail(message, message_size, "parameter n_freeze: %s has no internal step (it is exact over any "
                        "communication step)", s->model->ops->name);
    }
    if (n_freeze < 1 || n_freeze > INT32_MAX) {
        return rom_fail(message, message_size, "parameter n_freeze = %lld is out of range (allowed: an integer >= 1)",
                        (long long)n_freeze);
    }
    rom_outputs_moved(s);
    return s->model->ops->set_n_freeze(s, (int32_t)n_freeze, message, message_size);
}

double rom_dt(const RomState *s) {
    return s && s->model->ops->dt ? s->model->ops->dt(s) : NAN;
}

int32_t rom_n_freeze(const RomState *s) {
    return s && s->model->ops->n_freeze ? s->model->ops->n_freeze(s) : 0;
}

RomStatus rom_set_initial_state_scale(RomState *s, double scale, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!(fabs(scale) <= ROM_MAX_INITIAL_STATE_SCALE)) {
        return rom_fail(message, message_size, "parameter initial_state_scale = %g is out of range (allowed: "
                        "[-%g, %g]; 1 the scene's initial state, 0 at rest)", scale, ROM_MAX_INITIAL_STATE_SCALE,
                        ROM_MAX_INITIAL_STATE_SCALE);
    }
    if (s->n != 0) {
        return rom_fail(message, message_size, "parameter initial_state_scale can be set only before the first step");
    }
    s->initial_state_scale = scale;
    apply_initial_state(s);
    return ROM_OK;
}

size_t rom_reduced_state(const RomState *s, double *out, size_t n) {
    if (!s || !out) return 0;
    const size_t kv = s->model->k_v, kr = s->model->k_rho;
    if (n < kv + kr) return 0;
    memcpy(out, s->av, kv * sizeof(double));
    memcpy(out + kv, s->ar, kr * sizeof(double));
    return kv + kr;
}

int64_t rom_expm_count(const RomState *s) {
    if (!s) return -1;
    return s->model->ops->expm_count ? s->model->ops->expm_count(s) : 0;
}

/* ------------------------------------------------------------------------ */
/* stepping, outputs                                                         */
/* ------------------------------------------------------------------------ */

/* doStep's rules on the time (rom.h ROM_TIME_ULPS; harness/fmu/kinds/__init__.py step_error repeats them): ROM_OK,
 * or ROM_FAIL with the message naming the rule.  Every tolerance is the time's own rounding or the step's, so the
 * rules are the same at any start time. */
static RomStatus check_step(const RomState *s, double t_comm, double h, char *message, size_t message_size) {
    if (!isfinite(t_comm)) {
        return rom_fail(message, message_size, "currentCommunicationPoint = %g is not finite", t_comm);
    }
    if (!(isfinite(h) && h > 0)) {
        return rom_fail(message, message_size,
                        "communicationStepSize = %g s at t = %.17g s is out of range (allowed: a finite number > 0)",
                        h, t_comm);
    }
    const double ulps = ROM_TIME_ULPS * 2.220446049250313e-16 * fmax(fabs(t_comm), fabs(s->time));
    if (!(fabs(t_comm - s->time) <= ulps + ROM_TIME_STEP_TOLERANCE * h)) {
        return rom_fail(message, message_size, "currentCommunicationPoint = %.17g s does not match the FMU's time "
                        "%.17g s (allowed: equal to within %.0f units in the last place, plus %g of the step)", t_comm,
                        s->time, ROM_TIME_ULPS, ROM_TIME_STEP_TOLERANCE);
    }
    const double t_new = t_comm + h;
    if (!isfinite(t_new) || !isfinite(s->elapsed + h)) {
        return rom_fail(message, message_size, "communicationStepSize = %g s at t = %.17g s takes the time beyond "
                        "the largest number (t + h is not finite)", h, t_comm);
    }
    if (!(t_new > t_comm)) {
        return rom_fail(message, message_size, "communicationStepSize = %g s at t = %.17g s is below the time's "
                        "resolution there (%g s): t + h would equal t", h, t_comm,
                        nextafter(fabs(t_comm), INFINITY) - fabs(t_comm));
    }
    return ROM_OK;
}

RomStatus rom_do_step(RomState *s, double t_comm, double h, char *message, size_t message_size) {
    if (!s || !s->body) return rom_fail(message, message_size, "no state");
    if (check_step(s, t_comm, h, message, message_size) != ROM_OK) return ROM_FAIL;
    for (uint32_t j = 0; j < rom_port_inputs(s->model); j++) {     /* a port force acts on the kind's state (never
                                                                     * with the port channel, which takes them) */
        if (s->port_force[j] != 0.0 || s->port_rate[j] != 0.0) s->port_driven = 1.0;
    }
    double v_own[ROM_MAX_PORTS], v_end[ROM_MAX_PORTS];              /* the kind's v_port at the step's two ends */
    const uint32_t own = s->channel ? s->model->n_ports : 0u;
    for (uint32_t j = 0; j < own; j++) v_own[j] = rom_channel_kind_velocity(s, j);   /* kept from the last step */
    rom_outputs_moved(s);
    RomStatus status = s->model->ops->step(s, t_comm, h, message, message_size);
    if (status != ROM_OK) return status;
    for (uint32_t j = 0; j < own; j++) {
        v_end[j] = rom_port_velocity(s, j);
        v_own[j] = 0.5 * (v_own[j] + v_end[j]);
    }
    status = rom_channel_step(s, h, v_own, v_end, message, message_size);   /* the port forces' response
                                                                              * (rom_port.c) */
    if (status != ROM_OK) return status;
    rom_bound_step(s, h);                                           /* the bounds' shadow over the same inputs */
    s->time = t_comm + h;
    s->elapsed = s->elapsed + h;                                    /* the steps' sum: exact at any start time */
    if (s->f_rate != 0.0) s->f = s->f + s->f_rate * h;              /* the input continues linearly */
    for (uint32_t j = 0; j < s->model->n_ports; j++) {              /* and the port forces */
        if (s->port_rate[j] != 0.0) s->port_force[j] = s->port_force[j] + s->port_rate[j] * h;
    }
    return rom_check_outputs(s, message, message_size);
}

int rom_has_internal_step(const RomModel *m) {
    return m && m->ops && m->ops->step_exceeds ? 1 : 0;
}

void rom_describe(const RomModel *m, char *out, size_t size) {
    if (!out || size == 0) return;
    out[0] = '\0';
    if (m && m->ops && m->ops->describe) m->ops->describe(m, out, size);
}

int rom_step_exceeds(const RomState *s, double h) {
    if (!s || !s->model->ops->step_exceeds || !(isfinite(h) && h > 0)) return 0;
    return s->model->ops->step_exceeds(s, h);
}

RomStatus rom_advance(RomState *s, int64_t n_steps, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (n_steps < 0) return rom_fail(message, message_size, "negative step count %lld", (long long)n_steps);
    if (!s->model->ops->advance) {
        return rom_fail(message, message_size, "%s has no internal step (rom_do_step advances it over any step)",
                        s->model->ops->name);
    }
    rom_outputs_moved(s);
    const RomStatus status = s->model->ops->advance(s, n_steps, message, message_size);
    if (status == ROM_OK) s->elapsed = s->elapsed + (double)n_steps * rom_dt(s);     /* as the kind's time */
    return status;
}

/* the kind's output (kept until the state moves: one sum per state for the error check and the importer's read)
 * plus the port channel's part (rom_internal.h rom_v_probe_kept) */
double rom_v_probe(const RomState *s, uint32_t j) {
    if (!s || j >= s->model->n_probes) return NAN;
    return rom_v_probe_kept(s, j);
}

/* the linear kinds superpose the channel's e in J themselves; to the frozen kind's density the linear SPH's
 * shift of the channel's e at the probe's two particles is added, sum_m pw_m rho0_m (1 / (1 + e_m) - 1) */
double rom_rho_probe(const RomState *s, uint32_t j) {
    if (!s || j >= s->model->n_probes) return NAN;
    const double rho = s->model->ops->rho_probe(s, j);
    if (!s->channel || s->model->ops->density_with_channel) return rho;
    return rho + rom_channel_density_shift(s, j);
}

int rom_max_output_derivative_order(const RomModel *m) {
    return m && m->ops && m->ops->v_rate ? 1 : 0;
}

/* the checks shared by the output rates: a kind that has them, a probe index, a finite result */
static RomStatus probe_rate(const RomState *s, uint32_t j, double *rate, double (*compute)(const RomState *, uint32_t),
                            const char *what, char *message, size_t message_size) {
    if (!s || !rate) return rom_fail(message, message_size, "no state or no result pointer");
    if (!compute) return rom_fail(message, message_size, "%s", s->model->ops->no_rates);
    if (j >= s->model->n_probes) {
        return rom_fail(message, message_size, "probe %u does not exist (allowed: 1 to %u)", j + 1,
                        s->model->n_probes);
    }
    *rate = compute(s, j);
    if (!isfinite(*rate)) {
        return rom_fail(message, message_size, "d%s_probe_%u/dt is not finite at t = %.9g s (J <= 0 at the probe: "
                        "compression beyond the model's range)", what, j + 1, s->time);
    }
    return ROM_OK;
}

RomStatus rom_v_probe_rate(const RomState *s, uint32_t j, double *rate, char *message, size_t message_size) {
    const RomStatus status = probe_rate(s, j, rate, s ? s->model->ops->v_rate : NULL, "v", message, message_size);
    if (status == ROM_OK && s->channel) *rate += rom_channel_row_rate(s, j);       /* the port channel's part */
    return status;
}

RomStatus rom_rho_probe_rate(const RomState *s, uint32_t j, double *rate, char *message, size_t message_size) {
    return probe_rate(s, j, rate, s ? s->model->ops->rho_rate : NULL, "rho", message, message_size);
}

RomStatus rom_check_outputs(const RomState *s, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    const RomKindOps *ops = s->model->ops;
    for (uint32_t j = 0; j < s->model->n_probes; j++) {
        const double rho = rom_rho_probe(s, j);
        if (rho > 0 && isfinite(rho)) continue;   /* a kind's density is NaN where its own check fails: the check
                                                   * (and its message) only then, not twice the rows every step */
        if (ops->check_probe && ops->check_probe(s, j, message, message_size) != ROM_OK) return ROM_FAIL;
        if (isnan(rho))                            /* "is nan" reads as a typo: say what it is */
            return rom_fail(message, message_size, "density at probe %u (x/L = %g) is not a number (must be > 0) "
                            "at t = %.9g s: the state ran away", j + 1, s->model->probe_x[j], s->time);
        return rom_fail(message, message_size, "density at probe %u (x/L = %g) is %g (must be > 0) at t = %.9g s",
                        j + 1, s->model->probe_x[j], rho, s->time);
    }
    return ROM_OK;
}

/* ------------------------------------------------------------------------ */
/* parametric models                                                         */
/* ------------------------------------------------------------------------ */

int rom_varies(const RomModel *m, int which) {
    const RomSection *params = m ? rom_section(m, "PARAMS") : NULL;
    if (!params || (which != ROM_PARAM_C && which != ROM_PARAM_D)) return 0;
    return params->data[ROM_PARAMS_COLUMNS * which + ROM_PARAMS_VARIED] != 0.0;
}

RomStatus rom_set_param(RomState *s, int which, double value, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!rom_varies(s->model, which)) return rom_fail(message, message_size, "the model has no parameter %d", which);
    const double *row = rom_section(s->model, "PARAMS")->data + ROM_PARAMS_COLUMNS * which;
    const char *name = which == ROM_PARAM_C ? "c" : "d";
    const double lo = row[ROM_PARAMS_MIN], hi = row[ROM_PARAMS_MAX];
    if (!(isfinite(value) && value >= lo && value <= hi)) {
        return rom_fail(message, message_size, "%s = %g is outside the trained range [%g, %g]", name, value, lo, hi);
    }
    if (which == ROM_PARAM_C) s->c = value;
    else s->d = value;
    return ROM_OK;
}

double rom_get_param(const RomState *s, int which) {
    if (!s) return NAN;
    return which == ROM_PARAM_C ? s->c : s->d;
}

RomStatus rom_model_assemble(RomModel *m, RomState *s, char *message, size_t message_size) {
    if (!m || !s || s->model != m) return rom_fail(message, message_size, "assemble: no model or a foreign state");
    if (!rom_section(m, "PARAMS")) return ROM_OK;
    m->ops->assemble(m, s);
    rom_outputs_moved(s);
    return rom_bound_assemble(m, s, message, message_size);      /* a parametric shadow's planes at (c, d) */
}

/* ------------------------------------------------------------------------ */
/* mechanical ports                                                          */
/* ------------------------------------------------------------------------ */

uint32_t rom_n_ports(const RomModel *m) {
    return m ? m->n_ports : 0u;
}

/* the checks shared by the port setters: a state, and a port j (0-based) of its model */
static RomStatus check_port(const RomState *s, uint32_t j, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (j >= s->model->n_ports) {
        return rom_fail(message, message_size, "port %u does not exist (allowed: 1 to %u)", j + 1, s->model->n_ports);
    }
    return ROM_OK;
}

RomStatus rom_set_port_force(RomState *s, uint32_t j, double force, char *message, size_t message_size) {
    if (check_port(s, j, message, message_size) != ROM_OK ||
        rom_check_port_input(s, "F_port", j, force, "force", message, message_size) != ROM_OK) return ROM_FAIL;
    s->port_force[j] = force;
    return ROM_OK;
}

double rom_port_force(const RomState *s, uint32_t j) {
    if (!s || j >= s->model->n_ports) return NAN;
    return s->port_force[j];
}

RomStatus rom_set_area(RomState *s, double area, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!(isfinite(area) && area > 0)) {
        return rom_fail(message, message_size, "parameter area = %g m^2 is out of range (allowed: a finite number "
                        "> 0)", area);
    }
    s->area = area;
    return ROM_OK;
}

RomStatus rom_set_port_rate(RomState *s, uint32_t j, double rate, char *message, size_t message_size) {
    if (check_port(s, j, message, message_size) != ROM_OK ||
        rom_check_port_input(s, "F_port", j, rate, NULL, message, message_size) != ROM_OK) return ROM_FAIL;
    s->port_rate[j] = rate;
    return ROM_OK;
}

/* the kind's part (kept per step with the port channel: rom_channel_kind_velocity) and the channel's; without the
 * channel the kind's alone (rom_port.c rom_channel_port_velocity, which rom_bound.c reads too) */
double rom_v_port(const RomState *s, uint32_t j) {
    if (!s || j >= s->model->n_ports) return NAN;
    return rom_channel_port_velocity(s, j);
}
