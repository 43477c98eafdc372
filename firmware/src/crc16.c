/* crc16.c - CRC-16/CCITT-FALSE; contract in crc16.h. */
#include "inclino/crc16.h"

uint16_t crc16_update(uint16_t crc, const uint8_t *data, uint16_t n)
{
    uint16_t i;
    uint8_t b;
    for (i = 0u; i < n; i++) {
        crc = (uint16_t)(crc ^ (uint16_t)((uint16_t)data[i] << 8));
        for (b = 0u; b < 8u; b++) {
            if ((crc & 0x8000u) != 0u) {
                crc = (uint16_t)((uint16_t)(crc << 1) ^ 0x1021u);
            } else {
                crc = (uint16_t)(crc << 1);
            }
        }
    }
    return crc;
}
