/*
 * The training envelope (harness/fmu/training/envelope.py writes it): what the basis was
 * trained on, stored in three tagged sections, and the run-time check of the
 * state and the input against it widened by a margin.
 *
 *   ENVELOPE [1][ROM_ENVELOPE_COLUMNS]: force amplitude max|f| [m s^-2], force band [Hz],
 *            max strain |rho0/rho - 1| (particles), max probe strain, failure strain,
 *            margin (>= 1), checks (bit mask ROM_ENVELOPE_CHECK_*), force mean [m s^-2]
 *   ENVRANGE [2][k_v + k_rho]: min (row 0) and max (row 1) of each reduced coordinate
 *            over the training run (a^v then a^rho; the exact model: z)
 *   ENVPROBE [2][n_probes]: rho0 at the probes [kg m^-3]; max |v| at the probes in training [m s^-1]
 *   ENVPORT  [1][2] (only with ports): the numbers of trailing coordinates of a^v and of a^rho that are
 *            the ports' directions (exact input directions appended to the POD modes, which the
 *            training run without port forces leaves at ~0): not checked, not in a block's H
 *
 * The check (the kinds whose table says envelope = 1, the frozen model; a linear
 * model is exact in its state and stores checks = 0), in this order, the first breach reported (once a port force has
 * acted, state->port_driven, only failure and force: the training run had no
 * port force, so its ranges do not bound a port-driven state):
 *   failure:     a probe strain above the failure strain (eq. 2.17's linearization fails)
 *   coordinates: |a_i - c_i| > h_i + (margin - 1) H, [c_i - h_i, c_i + h_i] the trained range of
 *                coordinate i, H the largest h of its block (a^v or a^rho); the port coordinates
 *                (ENVPORT) left out
 *   force:       |f| > margin x the trained max |f|
 *   strain:      a probe strain above margin x the largest trained probe strain
 * harness/fmu/training/envelope.py check() repeats it.
 */
#include "rom_internal.h"

#include <stdio.h>

/* the scalars of ENVELOPE: its named columns (rom_layout.h, from harness/fmu/layout.py) */
enum {
    ENV_FORCE_AMPLITUDE = ROM_ENVELOPE_FORCE_AMPLITUDE,
    ENV_FORCE_BAND = ROM_ENVELOPE_FORCE_BAND,
    ENV_MAX_STRAIN = ROM_ENVELOPE_MAX_STRAIN,
    ENV_MAX_PROBE_STRAIN = ROM_ENVELOPE_MAX_PROBE_STRAIN,
    ENV_FAILURE_STRAIN = ROM_ENVELOPE_FAILURE_STRAIN,
    ENV_MARGIN = ROM_ENVELOPE_MARGIN,
    ENV_CHECKS = ROM_ENVELOPE_CHECKS,
    ENV_FORCE_MEAN = ROM_ENVELOPE_FORCE_MEAN
};

RomStatus rom_envelope_check_scalars(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    if (s->rows != 1 || s->cols != ROM_ENVELOPE_COLUMNS) {
        return rom_fail(message, message_size, "resources: section 'ENVELOPE' is %u x %u, expected 1 x %u", s->rows,
                        s->cols, ROM_ENVELOPE_COLUMNS);
    }
    const double *e = s->data;
    const double checks = e[ENV_CHECKS];
    if (!(checks >= 0 && checks <= ROM_ENVELOPE_CHECK_ALL && checks == floor(checks))) {
        return rom_fail(message, message_size, "resources: section 'ENVELOPE': checks = %g is not a mask of bits "
                        "0 to 3", checks);
    }
    if (!(e[ENV_MARGIN] >= 1.0)) {
        return rom_fail(message, message_size, "resources: section 'ENVELOPE': margin = %g (allowed: >= 1)",
                        e[ENV_MARGIN]);
    }
    for (int i = ENV_FORCE_AMPLITUDE; i <= ENV_FAILURE_STRAIN; i++) {
        if (e[i] < 0) {
            return rom_fail(message, message_size, "resources: section 'ENVELOPE': value %d is %g (allowed: >= 0)",
                            i, e[i]);
        }
    }
    if (checks != 0 && !m->ops->envelope) {
        return rom_fail(message, message_size, "resources: section 'ENVELOPE': run-time checks on a linear model "
                        "(it is exact in its state: checks must be 0)");
    }
    const RomSection *range = rom_section(m, "ENVRANGE");
    const RomSection *probe = rom_section(m, "ENVPROBE");
    if (!range || !probe) {
        return rom_fail(message, message_size, "resources: section 'ENVELOPE' needs the sections 'ENVRANGE' and "
                        "'ENVPROBE'");
    }
    return ROM_OK;
}

RomStatus rom_envelope_check_range(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    const uint32_t k = m->k_v + m->k_rho;
    if (s->rows != 2 || s->cols != k) {
        return rom_fail(message, message_size, "resources: section 'ENVRANGE' is %u x %u, expected 2 x %u "
                        "(k_v + k_rho)", s->rows, s->cols, k);
    }
    for (uint32_t i = 0; i < k; i++) {
        if (!(s->data[i] <= s->data[k + i])) {
            return rom_fail(message, message_size, "resources: section 'ENVRANGE': coordinate %u has min %g > "
                            "max %g", i + 1, s->data[i], s->data[k + i]);
        }
    }
    return ROM_OK;
}

RomStatus rom_envelope_check_probe(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    if (s->rows != 2 || s->cols != m->n_probes) {
        return rom_fail(message, message_size, "resources: section 'ENVPROBE' is %u x %u, expected 2 x %u "
                        "(n_probes)", s->rows, s->cols, m->n_probes);
    }
    for (uint32_t j = 0; j < m->n_probes; j++) {
        if (!(s->data[j] > 0)) {
            return rom_fail(message, message_size, "resources: section 'ENVPROBE': rho0 = %g at probe %u (allowed: "
                            "> 0)", s->data[j], j + 1);
        }
    }
    return ROM_OK;
}

RomStatus rom_envelope_check_ports(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    if (s->rows != 1 || s->cols != 2) {
        return rom_fail(message, message_size, "resources: section 'ENVPORT' is %u x %u, expected 1 x 2", s->rows,
                        s->cols);
    }
    const double limits[2] = {(double)m->k_v, (double)m->k_rho};
    for (int b = 0; b < 2; b++) {
        const double n = s->data[b];
        if (!(n >= 0 && n < limits[b] && n == floor(n))) {
            return rom_fail(message, message_size, "resources: section 'ENVPORT': %g port coordinates in block %d "
                            "(allowed: an integer from 0 to %g)", n, b + 1, limits[b] - 1);
        }
    }
    if (!rom_section(m, "ENVRANGE")) {
        return rom_fail(message, message_size, "resources: section 'ENVPORT' needs the section 'ENVRANGE'");
    }
    return ROM_OK;
}

/* coordinate i of the frozen state: a^v then a^rho */
static double coordinate(const RomState *state, uint32_t i) {
    const uint32_t kv = state->model->k_v;
    return i < kv ? state->av[i] : state->ar[i - kv];
}

/* the largest half-width of the block [first, last) */
static double block_half(const double *lo, const double *hi, uint32_t first, uint32_t last) {
    double h = 0.0;
    for (uint32_t i = first; i < last; i++) h = fmax(h, 0.5 * (hi[i] - lo[i]));
    return h;
}

int rom_envelope_check(const RomState *state, char *message, size_t message_size) {
    if (!state || !state->model) return 0;
    if (!message) message_size = 0;
    const RomModel *m = state->model;
    const RomSection *env = rom_section(m, "ENVELOPE");
    const RomSection *range = rom_section(m, "ENVRANGE");
    const RomSection *probe = rom_section(m, "ENVPROBE");
    if (!env || !range || !probe || !m->ops->envelope) return 0;
    const double *e = env->data;
    unsigned checks = (unsigned)e[ENV_CHECKS];
    if (state->port_driven != 0.0) {
        /* a port force has acted: the state holds a response the training run never saw (by design), so it is
         * no longer judged by that run's ranges; |f| and the failure strain stay */
        checks &= ~(unsigned)(ROM_ENVELOPE_CHECK_COORDINATES | ROM_ENVELOPE_CHECK_STRAIN);
    }
    const double margin = e[ENV_MARGIN];
    const double t = state->time;
    if (checks & (ROM_ENVELOPE_CHECK_FAILURE | ROM_ENVELOPE_CHECK_STRAIN)) {
        for (uint32_t j = 0; j < m->n_probes; j++) {
            const double strain = fabs(probe->data[j] / m->ops->rho_probe(state, j) - 1.0);
            if ((checks & ROM_ENVELOPE_CHECK_FAILURE) && strain > e[ENV_FAILURE_STRAIN]) {
                snprintf(message, message_size, "outside the training envelope at t = %.9g s: strain |rho0/rho - 1| "
                         "= %.3g at probe %u (x/L = %g) is above %.3g, where the density linearization (eq. 2.17) of "
                         "the frozen model is measured to fail (trained range [0, %.3g] at the probes)", t, strain,
                         j + 1, m->probe_x[j], e[ENV_FAILURE_STRAIN], e[ENV_MAX_PROBE_STRAIN]);
                return 1;
            }
        }
    }
    if (checks & ROM_ENVELOPE_CHECK_COORDINATES) {
        const uint32_t k = m->k_v + m->k_rho;
        const double *lo = range->data, *hi = range->data + k;
        const uint32_t blocks[3] = {0, m->k_v, k};
        const RomSection *ports = rom_section(m, "ENVPORT");        /* trailing port coordinates: skipped */
        const uint32_t skip[2] = {ports ? (uint32_t)ports->data[ROM_ENVPORT_PORT_V] : 0u,
                                ports ? (uint32_t)ports->data[ROM_ENVPORT_PORT_RHO] : 0u};
        for (int b = 0; b < 2; b++) {
            const uint32_t last = blocks[b + 1] - skip[b];
            const double widen = (margin - 1.0) * block_half(lo, hi, blocks[b], last);
            for (uint32_t i = blocks[b]; i < last; i++) {
                const double centre = 0.5 * (lo[i] + hi[i]), half = 0.5 * (hi[i] - lo[i]);
                const double a = coordinate(state, i);
                if (fabs(a - centre) > half + widen) {
                    snprintf(message, message_size, "outside the training envelope at t = %.9g s: reduced coordinate "
                             "%s_%u = %.6g is outside its trained range [%.6g, %.6g] widened by the margin %g (to "
                             "[%.6g, %.6g])", t, b == 0 ? "a_v" : "a_rho", i - blocks[b] + 1, a, lo[i], hi[i], margin,
                             lo[i] - widen, hi[i] + widen);
                    return 1;
                }
            }
        }
    }
    if ((checks & ROM_ENVELOPE_CHECK_FORCE) && fabs(state->f) > margin * e[ENV_FORCE_AMPLITUDE]) {
        snprintf(message, message_size, "outside the training envelope at t = %.9g s: input |f| = %.6g m s^-2 is "
                 "above %g x the trained amplitude (trained range [-%.6g, %.6g] m s^-2)", t, fabs(state->f), margin,
                 e[ENV_FORCE_AMPLITUDE], e[ENV_FORCE_AMPLITUDE]);
        return 1;
    }
    if (checks & ROM_ENVELOPE_CHECK_STRAIN) {
        for (uint32_t j = 0; j < m->n_probes; j++) {
            const double strain = fabs(probe->data[j] / m->ops->rho_probe(state, j) - 1.0);
            if (strain > margin * e[ENV_MAX_PROBE_STRAIN]) {
                snprintf(message, message_size, "outside the training envelope at t = %.9g s: strain |rho0/rho - 1| "
                         "= %.3g at probe %u (x/L = %g) is above %g x the largest trained probe strain (trained "
                         "range [0, %.3g])", t, strain, j + 1, m->probe_x[j], margin, e[ENV_MAX_PROBE_STRAIN]);
                return 1;
            }
        }
    }
    return 0;
}
