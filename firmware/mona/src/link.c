#include "link.h"

#include <string.h>
#include <util/crc16.h>

#define FRAME_MAX (LINK_HEADER + LINK_MAX_PAYLOAD + 2)

static uint8_t frame[FRAME_MAX];
static uint8_t have, rejected;

/* avr-libc's _crc_xmodem_update is poly 0x1021 MSB-first; from 0xFFFF it is CCITT-FALSE.
 * (Its _crc_ccitt_update is the reflected 0x8408 variant: not ours.) */
uint16_t link_crc(const uint8_t *data, uint8_t n)
{
    uint16_t crc = 0xFFFF;
    while (n--)
        crc = _crc_xmodem_update(crc, *data++);
    return crc;
}

static uint16_t get16(const uint8_t *p)
{
    return (uint16_t)(p[0] | ((uint16_t)p[1] << 8));
}

static void put16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

/* Drops the first byte and everything up to the next start byte: resynchronise inside the
 * bytes already held, so a frame starting within a rejected one is not lost. */
static void resync(void)
{
    uint8_t i = 1;
    while (i < have && frame[i] != LINK_START)
        i++;
    have -= i;
    memmove(frame, frame + i, have);
}

/* Drops a frame that was handled, keeping the bytes after it (found by a resync: they may
 * hold the next frame) */
static void consume(uint8_t total)
{
    have -= total;
    memmove(frame, frame + total, have);
}

static void reject(void)
{
    rejected++;
    resync();
}

/* 1 if the bytes held are a valid command frame, 0 if more are needed or some were dropped */
static uint8_t settle(link_command_t *out)
{
    while (have) {
        if (frame[0] != LINK_START) {
            resync();
            continue;
        }
        if (have < 2)
            return 0;
        uint8_t len = frame[1];
        if (len > LINK_MAX_PAYLOAD) {
            reject();
            continue;
        }
        uint8_t total = (uint8_t)(LINK_HEADER + len + 2);
        if (have < total)
            return 0;
        if (link_crc(frame + 1, (uint8_t)(total - 3)) != get16(frame + total - 2)) {
            reject();
            continue;
        }
        uint8_t kind = frame[7];
        if (kind != LINK_COMMAND || len != LINK_COMMAND_SIZE) {
            if (kind != LINK_TELEMETRY)  /* another robot's telemetry on a shared bus: fine */
                rejected++;
            consume(total);
            continue;
        }
        out->robot = frame[2];
        out->seq = get16(frame + 3);
        out->nonce = get16(frame + 5);
        out->left = (int16_t)get16(frame + 8);
        out->right = (int16_t)get16(frame + 10);
        out->flags = frame[12];
        consume(total);
        return 1;
    }
    return 0;
}

uint8_t link_receive(uint8_t byte, link_command_t *out)
{
    if (have == 0 && byte != LINK_START)
        return 0;  /* between frames */
    frame[have++] = byte;
    return settle(out);
}

uint8_t link_next(link_command_t *out)
{
    return settle(out);
}

uint8_t link_rejected(void)
{
    return rejected;
}

uint8_t link_telemetry(uint8_t *buf, uint8_t robot, uint16_t seq, uint16_t nonce,
                       const link_telemetry_t *t)
{
    uint8_t *p = buf;
    *p++ = LINK_START;
    *p++ = LINK_TELEMETRY_SIZE;
    *p++ = robot;
    put16(p, seq); p += 2;
    put16(p, nonce); p += 2;
    *p++ = LINK_TELEMETRY;
    for (uint8_t i = 0; i < 5; i++) {
        put16(p, t->ir[i]); p += 2;
    }
    put16(p, t->left_ticks); p += 2;
    put16(p, t->right_ticks); p += 2;
    put16(p, t->battery_mv); p += 2;
    put16(p, t->ack); p += 2;
    *p++ = t->flags;
    *p++ = t->rx_rejected;
    uint8_t n = (uint8_t)(p - buf);
    put16(p, link_crc(buf + 1, (uint8_t)(n - 1)));
    return (uint8_t)(n + 2);
}
