/*
 * id_record.h - the probe's identity record (factory-written, PROBE_ID_ADDR,
 * layout beside PROBE_ID_MAGIC in probe.h): the one
 * reader, used by the application (probe.c) and the bootloader (boot.c).
 */
#ifndef INCLINO_ID_RECORD_H
#define INCLINO_ID_RECORD_H

#include <stdint.h>

/*
 * id_record_read - read the record through the HAL and check its magic and
 *   CRC-16.  Returns 1 with *serial and *hw_rev from the record, or 0 (the
 *   record unreadable, absent or damaged) with both set to 0.
 */
uint8_t id_record_read(uint32_t *serial, uint16_t *hw_rev);

#endif /* INCLINO_ID_RECORD_H */
