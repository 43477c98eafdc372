/*
 * simif.h - byte I/O of the S08 test harness.
 *
 * On the S08 under SDCC the bytes go through ucsim's simulator interface
 * ("simif"), one memory-mapped byte port enabled with
 *   shc08 -I if=rom[0xff00],in=IN,out=OUT
 * Protocol (ucsim simif.html): write 'r' then read the next byte of IN; write
 * 'w' then the byte to append it to OUT; write 's' to stop the simulation and
 * read the answer back (without that read the interface stays busy and later
 * stops are ignored).  0xff00 is far from the stack, which SDCC's S08
 * start-up puts at 0x7fff and grows down.
 *
 * Any other compiler (the host check builds everything under firmware/ with
 * gcc) gets stdin/stdout instead, so the harness also runs on the host with
 * the same byte streams.
 */
#ifndef INCLINO_PORT_S08_SIMIF_H
#define INCLINO_PORT_S08_SIMIF_H

#include <stdint.h>

#ifdef __SDCC

#define SIMIF_ADDR 0xff00u
#define SIMIF (*(volatile uint8_t *)SIMIF_ADDR)

static inline uint8_t sif_rd8(void)
{
    SIMIF = (uint8_t)'r';
    return SIMIF;
}

static inline void sif_wr8(uint8_t v)
{
    SIMIF = (uint8_t)'w';
    SIMIF = v;
}

/* Stop the simulation; the simulator resumes here on its next `run`. */
static inline void sif_stop(void)
{
    volatile uint8_t answer;
    SIMIF = (uint8_t)'s';
    answer = SIMIF;
    (void)answer;
}

#else /* host build: stdin / stdout */

#include <stdio.h>
#include <stdlib.h>

static inline uint8_t sif_rd8(void)
{
    int c = getchar();
    if (c == EOF) {
        exit(2);
    }
    return (uint8_t)c;
}

static inline void sif_wr8(uint8_t v)
{
    (void)putchar(v);
}

static inline void sif_stop(void)
{
    (void)fflush(stdout);
}

#endif /* __SDCC */

/* Big-endian multi-byte values (the wire order, whatever the target's). */
static inline uint16_t sif_rd16(void)
{
    uint16_t v = sif_rd8();
    return (uint16_t)((uint16_t)(v << 8) | sif_rd8());
}

static inline uint32_t sif_rd32(void)
{
    uint32_t v = sif_rd16();
    return (v << 16) | sif_rd16();
}

static inline void sif_wr16(uint16_t v)
{
    sif_wr8((uint8_t)(v >> 8));
    sif_wr8((uint8_t)(v & 0xFFu));
}

static inline void sif_wr32(uint32_t v)
{
    sif_wr16((uint16_t)(v >> 16));
    sif_wr16((uint16_t)(v & 0xFFFFu));
}

#endif /* INCLINO_PORT_S08_SIMIF_H */
