/*
 * fx_mul32_s08.h - what fx_mul32_s08.c shares with the port's other
 * assembly (corr_temp_s08.c): the direct-page operands and result bytes of
 * its 32 x 32 core.
 *
 * The core, fx_m_core (an assembly label, called with jsr), computes
 * fx_mul32_q31(a, b) (fx_ops.h: same bits, same saturation) of the int32 a
 * in fx_m_a and b in fx_m_b (most significant byte first); the result is in
 * ___SDCC_hc08_ret3, ___SDCC_hc08_ret2, fx_m_s[0], fx_m_s[1] (most to least
 * significant byte), C set when it saturated.  fx_m_a and fx_m_b are kept;
 * A, X and the core's other work bytes are not.  About 400 bus cycles.
 * SDCC for hc08/s08 only.
 */
#ifndef INCLINO_FX_MUL32_S08_H
#define INCLINO_FX_MUL32_S08_H

#include <stdint.h>

#if defined(__SDCC_s08) || defined(__SDCC_hc08)
extern __data uint8_t fx_m_a[4];
extern __data uint8_t fx_m_b[4];
extern __data uint8_t fx_m_s[2];
#endif

#endif /* INCLINO_FX_MUL32_S08_H */
