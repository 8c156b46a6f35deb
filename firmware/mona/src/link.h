/* The link frame (docs/link.md, "Frame"): the format mona_controller.link.frame decodes.
 *   0xA5 | len | robot id | seq (2) | boot nonce (2) | type | payload (len) | CRC-16 (2)
 * little-endian; CRC-16/CCITT-FALSE over len .. the payload's last byte. */
#ifndef MONA_LINK_H
#define MONA_LINK_H
#include <stdint.h>

#define LINK_START 0xA5
#define LINK_HEADER 8
#define LINK_MAX_PAYLOAD 32
#define LINK_BROADCAST 0xFF
#define LINK_COMMAND 0x01
#define LINK_TELEMETRY 0x81
#define LINK_COMMAND_SIZE 5
#define LINK_TELEMETRY_SIZE 20
#define LINK_CLEANER 0x01     /* command flag */
#define LINK_STOPPED 0x01     /* telemetry flags */
#define LINK_CLEANING 0x02

typedef struct {
    uint8_t robot;
    uint16_t seq, nonce;
    int16_t left, right;
    uint8_t flags;
} link_command_t;

typedef struct {
    uint16_t ir[5];
    uint16_t left_ticks, right_ticks, battery_mv, ack;
    uint8_t flags, rx_rejected;
} link_telemetry_t;

uint16_t link_crc(const uint8_t *data, uint8_t n);
/* Feeds one received byte; 1 when it completes a valid command frame (copied to *out). */
uint8_t link_receive(uint8_t byte, link_command_t *out);
/* 1 while the bytes already held complete another command frame (after a resync one byte
 * can complete two): call it after each command link_receive returned, until 0. */
uint8_t link_next(link_command_t *out);
uint8_t link_rejected(void);  /* frames rejected (bad CRC, length or type), wrapping */
/* Encodes a telemetry frame into buf (LINK_HEADER + LINK_TELEMETRY_SIZE + 2 bytes). */
uint8_t link_telemetry(uint8_t *buf, uint8_t robot, uint16_t seq, uint16_t nonce,
                       const link_telemetry_t *t);
#endif
