/* correct.c - triad correction; contracts in correct.h. */
#include "inclino/correct.h"
#include "inclino/fx_ops.h"

uint8_t corr_triad(const int32_t x[3], const corr_triad_t *c, int32_t out[3])
{
    int32_t d[3];
    uint8_t sat = 0u;

    d[0] = fx_sub32_sat(x[0], c->bias[0], &sat);
    d[1] = fx_sub32_sat(x[1], c->bias[1], &sat);
    d[2] = fx_sub32_sat(x[2], c->bias[2], &sat);
    out[0] = fx_dot3_q31(&c->m[0], d, &sat);
    out[1] = fx_dot3_q31(&c->m[3], d, &sat);
    out[2] = fx_dot3_q31(&c->m[6], d, &sat);
    return sat;
}

int32_t corr_in_acc(int32_t raw_q6)
{
    return raw_q6 * (int32_t)((uint32_t)1u << CORR_ACC_IN_SHIFT);
}

int32_t corr_in_mag(int32_t raw_q6)
{
    return raw_q6 * (int32_t)((uint32_t)1u << CORR_MAG_IN_SHIFT);
}

void corr_identity(corr_triad_t *c)
{
    uint8_t i;
    for (i = 0u; i < 9u; i++) {
        c->m[i] = (i % 4u == 0u) ? CORR_M_ONE : 0;
    }
    for (i = 0u; i < 3u; i++) {
        c->bias[i] = 0;
    }
}
