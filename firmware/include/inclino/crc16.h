/*
 * crc16.h - CRC-16/CCITT-FALSE: polynomial 0x1021, initial value 0xFFFF,
 * no reflection, no final XOR (check value of "123456789" = 0x29B1).
 * The host computes the same CRC with Python's binascii.crc_hqx(data, 0xFFFF).
 *
 * Table-driven (docs/mcu.md): one lookup in each of two 256-byte tables per
 * byte, 512 bytes of flash, no RAM.  The result bits are those of the bitwise
 * definition (8 shift-and-XOR steps per byte) for every input.
 */
#ifndef INCLINO_CRC16_H
#define INCLINO_CRC16_H

#include <stdint.h>

#define CRC16_INIT 0xFFFFu

/* The table, high and low byte of each entry (crc16.c). */
extern const uint8_t crc16_tab_hi[256];
extern const uint8_t crc16_tab_lo[256];

/* crc16_byte - continue a CRC over one byte: with i = (crc >> 8) ^ b, the new
 * register is (crc << 8) ^ table[i], i.e. high byte (crc & 0xFF) ^ hi[i] and
 * low byte lo[i].  Inline so that the frame parser pays no call per byte. */
static inline uint16_t crc16_byte(uint16_t crc, uint8_t b)
{
    uint8_t i = (uint8_t)((uint8_t)(crc >> 8) ^ b);
    return (uint16_t)(((uint16_t)(uint8_t)((uint8_t)crc ^ crc16_tab_hi[i]) << 8) |
                      crc16_tab_lo[i]);
}

/* crc16_update - continue a CRC over n bytes (crc16_byte on each).  Start
 * with CRC16_INIT. */
uint16_t crc16_update(uint16_t crc, const uint8_t *data, uint16_t n);

#endif /* INCLINO_CRC16_H */
