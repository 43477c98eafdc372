/* correct.c - triad correction; contracts in correct.h. */
#include "inclino/correct.h"
#include "inclino/fx_ops.h"

uint8_t corr_triad(const int32_t x[3], const corr_triad_t *c, int32_t out[3])
{
    int32_t d[3];
    uint8_t sat = 0u;
    uint8_t i, j;

    for (j = 0u; j < 3u; j++) {
        d[j] = fx_sub32_sat(x[j], c->bias[j], &sat);
    }
    for (i = 0u; i < 3u; i++) {
        const int32_t *row = &c->m[i + i + i]; /* no multiply: a library call on the S08 */
        int32_t acc = fx_mul32_q31(row[0], d[0], &sat);
        for (j = 1u; j < 3u; j++) {
            acc = fx_add32_sat(acc, fx_mul32_q31(row[j], d[j], &sat), &sat);
        }
        out[i] = acc;
    }
    return sat;
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
