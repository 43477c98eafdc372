/* tx_queue.c - the SCI transmit queue; contract in tx_queue.h. */
#include "inclino/tx_queue.h"
#include "inclino/hal.h"

void tx_queue_init(tx_queue_t *q, uint8_t *buf, uint16_t cap)
{
    q->buf = buf;
    q->cap = cap;
    q->head = 0u;
    q->len = 0u;
    q->dropped = 0u;
}

void tx_queue_put(tx_queue_t *q, const uint8_t *data, uint16_t n)
{
    uint16_t i;
    if ((uint16_t)(q->cap - q->len) < n) {
        q->dropped += n; /* whole answers or nothing: never half a frame */
        return;
    }
    for (i = 0u; i < n; i++) {
        q->buf[(uint16_t)(q->head + q->len) % q->cap] = data[i];
        q->len++;
    }
}

void tx_queue_drain(tx_queue_t *q)
{
    while (q->len != 0u && hal_sci_putc(q->buf[q->head]) != 0u) {
        q->head = (uint16_t)((q->head + 1u) % q->cap);
        q->len--;
    }
}
