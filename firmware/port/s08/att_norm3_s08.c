/*
 * att_norm3_s08.c - att_norm3 for the S08/HC08 (the port's block
 * normalisation).
 *
 * Same contract and the same result bits as the portable att_norm3 in
 * firmware/src/attitude.c (attitude.h): out = v * 2^s with the largest
 * |out_i| in [2^29, 2^30], s in [-2, 29] (0 and out = 0 for v = 0); left
 * shifts exact, right shifts (s = -1, -2) rounded half up as fx_asr32_rnd.
 * As in the C, s comes from the leading bit of the OR of the magnitudes
 * (the leading bit of the largest one): s = -2 when it is bit 31, -1 for
 * bit 30, else 29 - (its position).  The shifts move whole bytes first,
 * then bits; SDCC's code for the same takes about 2 500 bus cycles a call,
 * this about 700 for a typical vector.
 *
 * Built only by SDCC for hc08/s08 with --stack-auto, the core compiled with
 * -DATT_PORT_NORM3 (host/inclino/s08/toolchain.py).  Reentrant calling convention:
 * v in X (high byte) and A, out at 3..4,s on entry; s returned in A.  It
 * keeps its work in ten direct-page bytes of this module, so it must not be
 * called from an interrupt handler while the main program may be in it.
 */
#include <stdint.h>

#include "inclino/attitude.h"

#if defined(__SDCC_s08) || defined(__SDCC_hc08)

#ifndef __SDCC_STACK_AUTO
#error "the S08 port's assembly expects the reentrant (--stack-auto) calling convention"
#endif

/* direct-page work: the OR of the magnitudes, one component, the shift in
 * whole bytes and in bits (or the right shift), a component count */
static __data uint8_t att_n_m[4];
static __data uint8_t att_n_t[4];
static __data uint8_t att_n_k;
static __data uint8_t att_n_b;
static __data uint8_t att_n_c;

#pragma save
#pragma less_pedantic
int8_t att_norm3(const int32_t v[3], int32_t out[3]) __naked
{
    v, out; /* referenced in the assembly */
    /* clang-format off */
    __asm
    psha                        ; v at 1..2,s; out at 5..6,s
    pshx
    clra
    sta     *_att_n_m
    sta     *(_att_n_m + 1)
    sta     *(_att_n_m + 2)
    sta     *(_att_n_m + 3)
    lda     #3
    sta     *_att_n_c
    ldhx    1,s
1$:
    lda     ,x                  ; m |= |v[i]|
    bmi     2$
    ora     *_att_n_m
    sta     *_att_n_m
    lda     1,x
    ora     *(_att_n_m + 1)
    sta     *(_att_n_m + 1)
    lda     2,x
    ora     *(_att_n_m + 2)
    sta     *(_att_n_m + 2)
    lda     3,x
    ora     *(_att_n_m + 3)
    sta     *(_att_n_m + 3)
    bra     3$
2$:
    clra                        ; 0 - v (ora, sta and clra keep C)
    sub     3,x
    ora     *(_att_n_m + 3)
    sta     *(_att_n_m + 3)
    clra
    sbc     2,x
    ora     *(_att_n_m + 2)
    sta     *(_att_n_m + 2)
    clra
    sbc     1,x
    ora     *(_att_n_m + 1)
    sta     *(_att_n_m + 1)
    clra
    sbc     ,x
    ora     *_att_n_m
    sta     *_att_n_m
3$:
    aix     #4
    dbnz    *_att_n_c,1$
    lda     *_att_n_m
    ora     *(_att_n_m + 1)
    ora     *(_att_n_m + 2)
    ora     *(_att_n_m + 3)
    bne     4$
    clra                        ; v = 0: out = 0, s = 0
    ldx     #12
    pshx                        ; a byte count; out at 6..7,s
    ldhx    6,s
30$:
    sta     ,x
    aix     #1
    dbnz    1,s,30$
    ais     #3
    rts
4$:
    lda     *_att_n_m
    cmp     #0x40
    blo     10$
    ; ---- m >= 2^30: s = -1, or -2 when m >= 2^31; out = round(v / 2^-s)
    ldx     #1
    tsta
    bpl     5$
    incx
5$:
    stx     *_att_n_b
    lda     #3
    sta     *_att_n_c
6$:
    jsr     att_n_load
    ldx     *_att_n_b
7$:
    asr     *_att_n_t           ; floor(v / 2), the bit out in C
    ror     *(_att_n_t + 1)
    ror     *(_att_n_t + 2)
    ror     *(_att_n_t + 3)
    dbnzx   7$
    lda     *(_att_n_t + 3)     ; + the last bit shifted out: half up
    adc     #0
    sta     *(_att_n_t + 3)
    lda     *(_att_n_t + 2)
    adc     #0
    sta     *(_att_n_t + 2)
    lda     *(_att_n_t + 1)
    adc     #0
    sta     *(_att_n_t + 1)
    lda     *_att_n_t
    adc     #0
    sta     *_att_n_t
    jsr     att_n_store
    dbnz    *_att_n_c,6$
    lda     *_att_n_b
    nega
    ais     #2
    rts
    ; ---- m < 2^30: s >= 0, whole bytes while m < 2^21, then bits
10$:
    clr     *_att_n_k
    clr     *_att_n_b
11$:
    lda     *_att_n_m
    bne     12$
    lda     *(_att_n_m + 1)
    cmp     #0x20
    bhs     12$
    sta     *_att_n_m
    lda     *(_att_n_m + 2)
    sta     *(_att_n_m + 1)
    lda     *(_att_n_m + 3)
    sta     *(_att_n_m + 2)
    clr     *(_att_n_m + 3)
    inc     *_att_n_k
    bra     11$
12$:
    lda     *_att_n_m           ; m >= 2^21: the top two bytes decide
13$:
    cmp     #0x20
    bhs     14$
    lsl     *(_att_n_m + 1)
    rola
    inc     *_att_n_b
    bra     13$
14$:
    lda     #3
    sta     *_att_n_c
15$:
    jsr     att_n_load
    ldx     *_att_n_k           ; whole bytes
    beq     17$
16$:
    lda     *(_att_n_t + 1)
    sta     *_att_n_t
    lda     *(_att_n_t + 2)
    sta     *(_att_n_t + 1)
    lda     *(_att_n_t + 3)
    sta     *(_att_n_t + 2)
    clr     *(_att_n_t + 3)
    dbnzx   16$
17$:
    ldx     *_att_n_b           ; bits
    beq     19$
18$:
    lsl     *(_att_n_t + 3)
    rol     *(_att_n_t + 2)
    rol     *(_att_n_t + 1)
    rol     *_att_n_t
    dbnzx   18$
19$:
    jsr     att_n_store
    dbnz    *_att_n_c,15$
    lda     *_att_n_k           ; s = 8 k + b
    lsla
    lsla
    lsla
    add     *_att_n_b
    ais     #2
    rts

    ; att_n_t = the next v[i] (the pointer at 3..4,s here, 1..2,s in the
    ; function)
att_n_load:
    ldhx    3,s
    lda     ,x
    sta     *_att_n_t
    lda     1,x
    sta     *(_att_n_t + 1)
    lda     2,x
    sta     *(_att_n_t + 2)
    lda     3,x
    sta     *(_att_n_t + 3)
    aix     #4
    sthx    3,s
    rts
    ; the next out[i] = att_n_t (the pointer at 7..8,s here)
att_n_store:
    ldhx    7,s
    lda     *_att_n_t
    sta     ,x
    lda     *(_att_n_t + 1)
    sta     1,x
    lda     *(_att_n_t + 2)
    sta     2,x
    lda     *(_att_n_t + 3)
    sta     3,x
    aix     #4
    sthx    7,s
    rts
    __endasm;
    /* clang-format on */
}
#pragma restore

#else

/* Other compilers use the portable att_norm3 of firmware/src/attitude.c. */
typedef int att_norm3_s08_unused_t;

#endif
