/*
 * sphrom model core: the state API and the dispatch by model kind (rom.h).
 * The steps themselves are in rom_frozen.c and rom_exact.c, the bytes in and
 * out in rom_io.c.
 */
#include "rom_internal.h"

#include <stdlib.h>

#define ROM_VERSION_STRING "sphrom-core 2"

const char *rom_version(void) {
    return ROM_VERSION_STRING;
}

void *rom_alloc_arrays(const size_t *counts, double **ptrs[], int n) {
    size_t total = 8;   /* slack for aligning the start */
    for (int i = 0; i < n; i++) total += rom_round_up(counts[i], 8);
    unsigned char *raw = (unsigned char *)calloc(total, sizeof(double));
    if (!raw) return NULL;
    double *cursor = (double *)(void *)(raw + ((64 - ((uintptr_t)raw & 63u)) & 63u));
    for (int i = 0; i < n; i++) {
        *ptrs[i] = counts[i] ? cursor : NULL;
        cursor += rom_round_up(counts[i], 8);
    }
    return raw;
}

uint32_t rom_model_kind(const RomModel *m) {
    return m ? m->kind : 0u;
}

const char *rom_linear_model_name(const RomModel *m) {
    if (!m || !rom_is_linear(m)) return NULL;
    const RomSection *id = rom_model_section(m, "LINMODEL");
    if (!id) return "linear";
    return id->data[0] == ROM_LINEAR_BALANCED ? "balanced" : "exact POD";
}

/* ------------------------------------------------------------------------ */
/* state                                                                     */
/* ------------------------------------------------------------------------ */

RomState *rom_state_new(const RomModel *model) {
    if (!model) return NULL;
    RomState *s = (RomState *)calloc(1, sizeof(RomState));
    if (!s) return NULL;
    if (rom_is_linear(model)) {
        /* a, b; the forced part X; (t0, input rate); the exponential's scratch; the cached maps (one G0, G1
         * column per input: f and the ports) */
        const size_t inputs = rom_linear_inputs(model) > 1 ? rom_linear_inputs(model) : 1;
        const size_t k = model->k, n = k + 2 * inputs, kk = k * k, ki = k * inputs;
        const size_t kr_alloc = model->kr_pad ? model->kr_pad : 1;    /* never NULL: a state with k_e = 0 */
        const size_t counts[5 + 3 * ROM_EXACT_CACHE] = {model->kv_pad, kr_alloc, k, 2, 4 * n * n + 2 * k,
                                                        kk, ki, ki, kk, ki, ki};
        double **ptrs[5 + 3 * ROM_EXACT_CACHE] = {&s->av, &s->ar, &s->X, &s->aux, &s->work,
                                                  &s->cache[0].Phi, &s->cache[0].G0, &s->cache[0].G1,
                                                  &s->cache[1].Phi, &s->cache[1].G0, &s->cache[1].G1};
        s->storage_ = rom_alloc_arrays(counts, ptrs, 5 + 3 * ROM_EXACT_CACHE);
    } else {
        /* a^v, a^rho; M^T, F; the rates; the pair products; (t0, input rate) */
        const size_t counts[8] = {model->kv_pad, model->kr_pad, model->nm, model->kv_pad, model->kv_pad,
                                  model->kr_pad, model->n_pairs, 2};
        double **ptrs[8] = {&s->av, &s->ar, &s->Mt, &s->F, &s->dv, &s->dr, &s->S, &s->aux};
        s->storage_ = rom_alloc_arrays(counts, ptrs, 8);
    }
    if (!s->storage_) {
        free(s);
        return NULL;
    }
    s->model = model;
    rom_state_reset(s, 0.0);
    return s;
}

void rom_state_free(RomState *state) {
    if (!state) return;
    free(state->storage_);
    free(state);
}

/* The initial reduced state from the model's and initial_state_scale.  Frozen: a^v = scale a_v0, a^rho = a_rho0
 * (the rest density's coordinates); linear: z = scale z0 (z = 0 is rest: v = 0, e = 0); with the Schur form the
 * forced part X starts at 0 and the free response is scale e^{At} z0.  scale = 1 gives the model's own numbers
 * bit for bit (1 x a = a). */
static void apply_initial_state(RomState *s) {
    const RomModel *m = s->model;
    const double scale = s->initial_state_scale;
    memset(s->av, 0, m->kv_pad * sizeof(double));
    memset(s->ar, 0, m->kr_pad * sizeof(double));
    for (size_t i = 0; i < m->k_v; i++) s->av[i] = scale * m->a_v0[i];
    if (rom_is_linear(m)) {
        for (size_t i = 0; i < m->k_rho; i++) s->ar[i] = scale * m->a_rho0[i];
        if (m->Q) {
            memset(s->X, 0, m->k * sizeof(double));            /* forced part; the free response is e^{At} z0 */
        } else {
            for (size_t i = 0; i < m->k; i++) s->X[i] = scale * m->z0[i];
        }
    } else {
        memcpy(s->ar, m->a_rho0, m->k_rho * sizeof(double));
    }
}

void rom_state_reset(RomState *s, double t_start) {
    if (!s) return;
    const RomModel *m = s->model;
    s->initial_state_scale = 1.0;
    apply_initial_state(s);
    if (s->Mt) memset(s->Mt, 0, (size_t)m->nm * sizeof(double));
    if (s->F) memset(s->F, 0, m->kv_pad * sizeof(double));
    s->aux[0] = t_start;      /* both kinds: the start time and the input rate (0: f held) */
    s->aux[1] = 0.0;
    s->n = 0;
    s->time = t_start;
    s->f = 0.0;
    s->dt = m->dt;
    s->n_freeze = (int32_t)m->n_freeze_default;
    const RomSection *params = rom_model_section(m, "PARAMS");
    s->c = params ? params->data[1] : 0.0;
    s->d = params ? params->data[4 + 1] : 0.0;
    for (size_t j = 0; j < ROM_MAX_PORTS; j++) s->port_force[j] = s->port_rate[j] = 0.0;
    s->port_driven = 0.0;
    s->area = 1.0;                                             /* [m^2] */
}

RomStatus rom_set_start_time(RomState *s, double t_start, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!isfinite(t_start)) return rom_fail(message, message_size, "start time %g is not finite", t_start);
    if (s->n != 0) return rom_fail(message, message_size, "the start time can be set only before the first step");
    s->time = t_start;
    if (s->aux) s->aux[0] = t_start;
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
    if (s->aux) s->aux[1] = rate;
    return ROM_OK;
}

RomStatus rom_set_dt(RomState *s, double dt, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!(isfinite(dt) && dt > 0)) {
        return rom_fail(message, message_size, "parameter dt = %g s is out of range (allowed: a finite number > 0)",
                        dt);
    }
    s->dt = dt;
    return ROM_OK;
}

RomStatus rom_set_n_freeze(RomState *s, int64_t n_freeze, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (n_freeze < 1 || n_freeze > INT32_MAX) {
        return rom_fail(message, message_size, "parameter n_freeze = %lld is out of range (allowed: an integer >= 1)",
                        (long long)n_freeze);
    }
    s->n_freeze = (int32_t)n_freeze;
    return ROM_OK;
}

RomStatus rom_set_initial_state_scale(RomState *s, double scale, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!isfinite(scale)) {
        return rom_fail(message, message_size, "parameter initial_state_scale = %g is out of range (allowed: a "
                        "finite real number; 1 the scene's initial state, 0 at rest)", scale);
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
    return s ? s->n_expm : -1;
}

/* ------------------------------------------------------------------------ */
/* stepping, outputs                                                         */
/* ------------------------------------------------------------------------ */

RomStatus rom_do_step(RomState *s, double t_comm, double h, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!isfinite(t_comm)) {
        return rom_fail(message, message_size, "currentCommunicationPoint = %g is not finite", t_comm);
    }
    if (fabs(t_comm - s->time) > ROM_TIME_TOLERANCE * fmax(1.0, fabs(s->time))) {
        return rom_fail(message, message_size,
                        "currentCommunicationPoint = %.17g s does not match the FMU's time %.17g s", t_comm, s->time);
    }
    if (!(isfinite(h) && h > 0)) {
        return rom_fail(message, message_size,
                        "communicationStepSize = %g s at t = %.9g s is out of range (allowed: a finite number > 0)",
                        h, t_comm);
    }
    for (uint32_t j = 0; j < s->model->n_ports; j++) {              /* a port force acts over this step */
        if (s->port_force[j] != 0.0 || s->port_rate[j] != 0.0) s->port_driven = 1.0;
    }
    const RomStatus status = rom_is_linear(s->model) ? rom_exact_step(s, t_comm, h, message, message_size)
                                                     : rom_frozen_step(s, t_comm, h, message, message_size);
    if (status != ROM_OK) return status;
    s->time = t_comm + h;
    if (s->aux && s->aux[1] != 0.0) s->f = s->f + s->aux[1] * h;    /* the input continues linearly */
    for (uint32_t j = 0; j < s->model->n_ports; j++) {              /* and the port forces */
        if (s->port_rate[j] != 0.0) s->port_force[j] = s->port_force[j] + s->port_rate[j] * h;
    }
    return rom_check_outputs(s, message, message_size);
}

int rom_step_exceeds(const RomState *s, double h) {
    if (!s || rom_is_linear(s->model) || !(isfinite(h) && h > 0)) return 0;
    const double ratio = h / s->dt;
    return ratio < 1.0 && !(fabs(ratio - 1.0) <= ROM_STEP_ROUNDING);
}

RomStatus rom_advance(RomState *s, int64_t n_steps, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (n_steps < 0) return rom_fail(message, message_size, "negative step count %lld", (long long)n_steps);
    return rom_is_linear(s->model) ? rom_exact_advance(s, n_steps, message, message_size)
                                   : rom_frozen_advance(s, n_steps, message, message_size);
}

double rom_v_probe(const RomState *s, uint32_t j) {
    if (!s || j >= s->model->n_probes) return NAN;
    if (rom_is_linear(s->model)) return rom_exact_output(s, s->model->Pv + (size_t)j * s->model->k);
    const size_t kv = s->model->k_v;
    const double *row = s->model->Pv + (size_t)j * kv;
    double v = 0.0;
    for (size_t q = 0; q < kv; q++) v += row[q] * s->av[q];
    return v;
}

double rom_rho_probe(const RomState *s, uint32_t j) {
    if (!s || j >= s->model->n_probes) return NAN;
    return rom_is_linear(s->model) ? rom_exact_rho_probe(s, j) : rom_frozen_rho_probe(s, j);
}

int rom_max_output_derivative_order(const RomModel *m) {
    return m && rom_is_linear(m) ? 1 : 0;
}

/* the checks shared by the output rates: a linear model, a probe index, a finite result */
static RomStatus probe_rate(const RomState *s, uint32_t j, double *rate, double (*compute)(const RomState *, uint32_t),
                            const char *what, char *message, size_t message_size) {
    if (!s || !rate) return rom_fail(message, message_size, "no state or no result pointer");
    if (!rom_is_linear(s->model)) {
        return rom_fail(message, message_size, "the frozen model provides no output derivatives "
                        "(maxOutputDerivativeOrder = 0: its trajectory is a discrete map of internal steps)");
    }
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
    return probe_rate(s, j, rate, rom_exact_v_rate, "v", message, message_size);
}

RomStatus rom_rho_probe_rate(const RomState *s, uint32_t j, double *rate, char *message, size_t message_size) {
    return probe_rate(s, j, rate, rom_exact_rho_rate, "rho", message, message_size);
}

RomStatus rom_check_outputs(const RomState *s, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    for (uint32_t j = 0; j < s->model->n_probes; j++) {
        if (rom_is_linear(s->model)) {
            const double J = rom_exact_probe_J(s, j);
            if (!(J > 0)) {
                return rom_fail(message, message_size, "specific volume J = 1 + e = %g <= 0 at probe %u (x/L = %g) "
                                "at t = %.9g s: compression beyond the model's range", J, j + 1,
                                s->model->probe_x[j], s->time);
            }
        }
        const double rho = rom_rho_probe(s, j);
        if (!(rho > 0) || !isfinite(rho)) {
            return rom_fail(message, message_size, "density at probe %u (x/L = %g) is %g (must be > 0) at t = %.9g s",
                            j + 1, s->model->probe_x[j], rho, s->time);
        }
    }
    return ROM_OK;
}

/* ------------------------------------------------------------------------ */
/* parametric models                                                         */
/* ------------------------------------------------------------------------ */

int rom_varies(const RomModel *m, int which) {
    const RomSection *params = rom_model_section(m, "PARAMS");
    if (!params || (which != ROM_PARAM_C && which != ROM_PARAM_D)) return 0;
    return params->data[4 * which] != 0.0;
}

RomStatus rom_set_param(RomState *s, int which, double value, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!rom_varies(s->model, which)) return rom_fail(message, message_size, "the model has no parameter %d", which);
    const double *row = rom_model_section(s->model, "PARAMS")->data + 4 * which;
    const char *name = which == ROM_PARAM_C ? "c" : "d";
    if (!(isfinite(value) && value >= row[2] && value <= row[3])) {
        return rom_fail(message, message_size, "%s = %g is outside the trained range [%g, %g]", name, value, row[2],
                        row[3]);
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
    if (!rom_model_section(m, "PARAMS")) return ROM_OK;
    const double c = s->c, d = s->d;
    if (rom_is_linear(m)) {          /* A = A_0 + c A_c + d A_d, entry by entry (harness.rom.parametric) */
        const double *A0 = rom_model_section(m, "A0")->data, *Ac = rom_model_section(m, "AC")->data;
        const double *Ad = rom_model_section(m, "AD")->data;
        const size_t kk = (size_t)m->k * m->k;
        for (size_t i = 0; i < kk; i++) m->A[i] = A0[i] + c * Ac[i] + d * Ad[i];
        for (int slot = 0; slot < ROM_EXACT_CACHE; slot++) s->cache[slot].h = 0.0;
    } else {                         /* K = c K_c, b = c b_c, D = d D_d (eqs. 2.21, 2.22, 2.24) */
        const size_t kv = m->k_v, kr = m->k_rho, kvp = m->kv_pad;
        const double *Kc = rom_model_section(m, "KC")->data, *bc = rom_model_section(m, "BC")->data;
        for (size_t p = 0; p < kv; p++) {
            for (size_t q = 0; q < kr; q++) m->Kt[q * kvp + p] = c * Kc[p * kr + q];
            m->b[p] = c * bc[p];
        }
        if (m->Dt) {
            const double *Dd = rom_model_section(m, "DD")->data;
            for (size_t p = 0; p < kv; p++) {
                for (size_t q = 0; q < kv; q++) m->Dt[q * kvp + p] = d * Dd[p * kv + q];
            }
        }
    }
    return ROM_OK;
}

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
    RomStatus status = check_port(s, j, message, message_size);
    if (status != ROM_OK) return status;
    if (!isfinite(force)) {
        return rom_fail(message, message_size, "input F_port_%u = %g N at t = %.9g s is not finite (allowed: a finite "
                        "force in N)", j + 1, force, s->time);
    }
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
    RomStatus status = check_port(s, j, message, message_size);
    if (status != ROM_OK) return status;
    if (!isfinite(rate)) {
        return rom_fail(message, message_size, "input derivative of F_port_%u, dF_port_%u/dt = %g N s^-1 at t = %.9g "
                        "s, is not finite (allowed: a finite rate)", j + 1, j + 1, rate, s->time);
    }
    s->port_rate[j] = rate;
    return ROM_OK;
}

double rom_v_port(const RomState *s, uint32_t j) {
    if (!s || j >= s->model->n_ports) return NAN;
    const size_t kv = s->model->k_v;
    const double *row = s->model->port_C + (size_t)j * kv;
    double v = 0.0;
    for (size_t q = 0; q < kv; q++) v += row[q] * s->av[q];
    return v;
}
