/* The UART with interrupt-driven ring buffers both ways, 8N1. */
#ifndef MONA_UART_H
#define MONA_UART_H
#include <stdint.h>
void uart_init(void);
int16_t uart_read(void);               /* the next byte received, or -1 */
void uart_write(const uint8_t *data, uint8_t n);  /* waits only when the buffer is full */
uint8_t uart_overruns(void);           /* bytes lost to a full receive buffer or the UART */
#endif
