/* id_record.c - the identity record's reader; contract in id_record.h. */
#include "inclino/id_record.h"
#include "inclino/be_bytes.h"
#include "inclino/crc16.h"
#include "inclino/hal.h"
#include "inclino/probe.h"

uint8_t id_record_read(uint32_t *serial, uint16_t *hw_rev)
{
    uint8_t b[PROBE_ID_SIZE];
    *serial = 0u;
    *hw_rev = 0u;
    if (hal_flash_read(PROBE_ID_ADDR, b, PROBE_ID_SIZE) != HAL_FLASH_OK ||
        be_get_u32(b) != PROBE_ID_MAGIC ||
        crc16_update(CRC16_INIT, b, 14u) != be_get_u16(b + 14)) {
        return 0u;
    }
    *serial = be_get_u32(b + 4);
    *hw_rev = be_get_u16(b + 8);
    return 1u;
}
