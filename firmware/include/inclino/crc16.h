/*
 * crc16.h - CRC-16/CCITT-FALSE: polynomial 0x1021, initial value 0xFFFF,
 * no reflection, no final XOR (check value of "123456789" = 0x29B1).
 * The host computes the same CRC with Python's binascii.crc_hqx(data, 0xFFFF).
 */
#ifndef INCLINO_CRC16_H
#define INCLINO_CRC16_H

#include <stdint.h>

#define CRC16_INIT 0xFFFFu

/* crc16_update - continue a CRC over n bytes (bitwise, no table: 0 bytes of
 * RAM, 8 shift steps per byte).  Start with CRC16_INIT. */
uint16_t crc16_update(uint16_t crc, const uint8_t *data, uint16_t n);

#endif /* INCLINO_CRC16_H */
