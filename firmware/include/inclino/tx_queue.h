/*
 * tx_queue.h - the SCI transmit queue of both main loops (app_main.c,
 * boot_main.c): a ring of bytes the command layer's answers go into whole
 * and that hal_sci_putc() empties as the transmitter takes them.
 *
 * Whole answers or nothing: an answer that does not fit in the free space is
 * dropped entirely (never half a frame) and its length added to the drop
 * count, so the host sees a missing answer, never a corrupt one.  No
 * dynamic memory: the caller owns the storage.
 */
#ifndef INCLINO_TX_QUEUE_H
#define INCLINO_TX_QUEUE_H

#include <stdint.h>

typedef struct {
    uint8_t *buf;     /* cap bytes, owned by the caller */
    uint16_t cap;     /* size of buf, 1..65535 */
    uint16_t head;    /* index of the oldest queued byte */
    uint16_t len;     /* queued bytes, 0..cap */
    uint32_t dropped; /* bytes of answers that did not fit */
} tx_queue_t;

/* tx_queue_init - an empty queue over buf[0..cap-1]; drop count 0. */
void tx_queue_init(tx_queue_t *q, uint8_t *buf, uint16_t cap);

/* tx_queue_put - queue data[0..n-1] whole, or drop all n bytes (counted)
 *   when fewer than n bytes are free. */
void tx_queue_put(tx_queue_t *q, const uint8_t *data, uint16_t n);

/* tx_queue_drain - hand queued bytes to hal_sci_putc() in order until the
 *   queue is empty or the transmitter refuses one (that byte stays queued).
 *   Never blocks. */
void tx_queue_drain(tx_queue_t *q);

#endif /* INCLINO_TX_QUEUE_H */
