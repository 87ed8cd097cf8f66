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
        const size_t counts[5 + 3 * ROM_EXACT_CACHE] = {model->kv_pad, model->kr_pad, k, 2, 4 * n * n + 2 * k,
                                                        kk, ki, ki, kk, ki, ki};
        double **ptrs[5 + 3 * ROM_EXACT_CACHE] = {&s->av, &s->ar, &s->X, &s->aux, &s->work,
                                                  &s->cache[0].Phi, &s->cache[0].G0, &s->cache[0].G1,
                                                  &s->cache[1].Phi, &s->cache[1].G0, &s->cache[1].G1};
        s->storage_ = rom_alloc_arrays(counts, ptrs, 5 + 3 * ROM_EXACT_CACHE);
    } else {
        /* a^v, a^rho; M^T, F; the rates; the pair products */
        const size_t counts[7] = {model->kv_pad, model->kr_pad, model->nm, model->kv_pad, model->kv_pad,
                                  model->kr_pad, model->n_pairs};
        double **ptrs[7] = {&s->av, &s->ar, &s->Mt, &s->F, &s->dv, &s->dr, &s->S};
        s->storage_ = rom_alloc_arrays(counts, ptrs, 7);
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

void rom_state_reset(RomState *s, double t_start) {
    if (!s) return;
    const RomModel *m = s->model;
    memset(s->av, 0, m->kv_pad * sizeof(double));
    memset(s->ar, 0, m->kr_pad * sizeof(double));
    memcpy(s->av, m->a_v0, m->k_v * sizeof(double));
    memcpy(s->ar, m->a_rho0, m->k_rho * sizeof(double));
    if (s->Mt) memset(s->Mt, 0, (size_t)m->nm * sizeof(double));
    if (s->F) memset(s->F, 0, m->kv_pad * sizeof(double));
    if (rom_is_linear(m)) {
        if (m->Q) {
            memset(s->X, 0, m->k * sizeof(double));            /* forced part; the free response is e^{At} z0 */
        } else {
            memcpy(s->X, m->z0, m->k * sizeof(double));
        }
        s->aux[0] = t_start;
        s->aux[1] = 0.0;
    }
    s->n = 0;
    s->time = t_start;
    s->f = 0.0;
    s->dt = m->dt;
    s->n_freeze = (int32_t)m->n_freeze_default;
    for (size_t j = 0; j < 2 * (1 + ROM_MAX_PORTS); j++) s->port[j] = 0.0;
    s->port[0] = 1.0;                                          /* area [m^2] */
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

int rom_interpolates_inputs(const RomModel *m) {
    return m && rom_is_linear(m);
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
    const RomStatus status = rom_is_linear(s->model) ? rom_exact_step(s, t_comm, h, message, message_size)
                                                     : rom_frozen_step(s, t_comm, h, message, message_size);
    if (status != ROM_OK) return status;
    s->time = t_comm + h;
    if (s->aux && s->aux[1] != 0.0) s->f = s->f + s->aux[1] * h;    /* the input continues linearly */
    for (uint32_t j = 0; j < s->model->n_ports; j++) {              /* and the port forces */
        const double rate = s->port[2 + ROM_MAX_PORTS + j];
        if (rate != 0.0) s->port[1 + j] = s->port[1 + j] + rate * h;
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
/* mechanical ports                                                          */
/* ------------------------------------------------------------------------ */

uint32_t rom_n_ports(const RomModel *m) {
    return m ? m->n_ports : 0u;
}

RomStatus rom_set_port_force(RomState *s, uint32_t j, double force, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (j >= s->model->n_ports) {
        return rom_fail(message, message_size, "port %u does not exist (allowed: 1 to %u)", j + 1, s->model->n_ports);
    }
    if (!isfinite(force)) {
        return rom_fail(message, message_size, "input F_port_%u = %g N at t = %.9g s is not finite (allowed: a finite "
                        "force in N)", j + 1, force, s->time);
    }
    s->port[1 + j] = force;
    return ROM_OK;
}

double rom_port_force(const RomState *s, uint32_t j) {
    if (!s || j >= s->model->n_ports) return NAN;
    return s->port[1 + j];
}

RomStatus rom_set_area(RomState *s, double area, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!(isfinite(area) && area > 0)) {
        return rom_fail(message, message_size, "parameter area = %g m^2 is out of range (allowed: a finite number "
                        "> 0)", area);
    }
    s->port[0] = area;
    return ROM_OK;
}

RomStatus rom_set_port_rate(RomState *s, uint32_t j, double rate, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (j >= s->model->n_ports) {
        return rom_fail(message, message_size, "port %u does not exist (allowed: 1 to %u)", j + 1, s->model->n_ports);
    }
    if (!isfinite(rate)) {
        return rom_fail(message, message_size, "input rate dF_port_%u/dt = %g at t = %.9g s is not finite", j + 1,
                        rate, s->time);
    }
    if (rate != 0.0 && !rom_is_linear(s->model)) {
        return rom_fail(message, message_size, "the frozen model does not interpolate inputs");
    }
    s->port[2 + ROM_MAX_PORTS + j] = rate;
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
