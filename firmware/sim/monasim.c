/* monasim: the Mona firmware image (mona.elf) in simavr, driven line by line from stdin.
 *
 * Commands (one a line; times in microseconds of simulated time):
 *   send HEX          queue bytes for the UART's receiver, paced at BAUD (8N1)
 *   run US            run the AVR for US microseconds
 *   adc CH MV         set ADC input CH to MV millivolts (AVcc = 3300 mV)
 *   enc L|R N US      toggle the left/right encoder input N times, one edge every US
 *   reset             reset the AVR (flash and EEPROM kept, as a power cycle keeps them)
 *   quit
 * Events on stdout (CYCLE = simulated clock cycles since start, 8 per microsecond):
 *   W CYCLE PWM_L DIR_L PWM_R DIR_R CLEANER   the wheel outputs changed (registers and pins)
 *   U CYCLE HEX                               a byte the firmware transmitted
 *   R CYCLE                                   the last queued byte reached the receiver
 *   T CYCLE                                   a command is done
 * Or, with --pty SECONDS: run in real time for SECONDS, the UART bridged to a pseudo-terminal
 * (simavr's uart_pty part; "P <path>" on stdout names it), W events as above; stdin unused.
 * The wheel outputs are read from Timer1's OCR1A/OCR1B (with COM1x1 connecting them to the
 * pins, and the pins' DDR set as outputs) and PORTD's direction bits: register level, not a
 * measured waveform. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <avr_adc.h>
#include <avr_ioport.h>
#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_elf.h>
#include <sim_irq.h>
#include <uart_pty.h>

#define F_CPU 8000000UL
#define BAUD 57600UL
#define CYCLES_PER_US (F_CPU / 1000000UL)
/* simavr times a byte as 11 bits (it counts a parity bit even without parity): pace the
 * host a little slower than that, so its receive FIFO never overflows */
#define BYTE_CYCLES (F_CPU * 11 / BAUD)

/* ATmega328P data-space addresses (datasheet, "Register Summary") */
#define PORTB 0x25
#define DDRB 0x24
#define PORTD 0x2B
#define TCCR1A 0x80
#define OCR1AL 0x88
#define OCR1BL 0x8A

static avr_t *avr;
static avr_cycle_count_t offset;  /* cycles run before the last reset */
static uint8_t queue[4096];
static size_t queued, delivered;
static avr_irq_t *uart_in;
static int enc_left, enc_right, enc_period, enc_level[2] = {1, 1};
static int last[5] = {-1, -1, -1, -1, -1};

static unsigned long long now(void)
{
    return (unsigned long long)(offset + avr->cycle);
}

static void uart_out(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)param;
    printf("U %llu %02x\n", now(), value & 0xFF);
}

static avr_cycle_count_t feed(avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)a; (void)param;
    if (delivered >= queued)
        return 0;
    avr_raise_irq(uart_in, queue[delivered++]);
    if (delivered == queued) {
        printf("R %llu\n", now());
        queued = delivered = 0;
        return 0;
    }
    return when + BYTE_CYCLES;
}

/* Drives the encoder pins (PD2, PD3) to enc_level, and tells simavr they are driven from
 * outside: else a write to PORTD (the direction bits) re-applies the pull-ups to them, a
 * false edge for the firmware's interrupts. */
static void drive_encoders(avr_t *a)
{
    avr_ioport_external_t external = {
        .name = 'D', .mask = 0x0C,
        .value = (unsigned long)((enc_level[0] << 2) | (enc_level[1] << 3))};
    avr_ioctl(a, AVR_IOCTL_IOPORT_SET_EXTERNAL('D'), &external);
    for (int side = 0; side < 2; side++)
        avr_raise_irq(avr_io_getirq(a, AVR_IOCTL_IOPORT_GETIRQ('D'), 2 + side),
                      (uint32_t)enc_level[side]);
}

static avr_cycle_count_t edge(avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)param;
    int more = 0;
    int *counts[2] = {&enc_left, &enc_right};
    for (int side = 0; side < 2; side++) {
        if (*counts[side] > 0) {
            enc_level[side] ^= 1;
            drive_encoders(a);
            more |= --*counts[side] > 0;
        }
    }
    return more ? when + (avr_cycle_count_t)enc_period * CYCLES_PER_US : 0;
}

static void watch_outputs(void)
{
    uint8_t *d = avr->data;
    int connected_a = (d[TCCR1A] & 0x80) && (d[DDRB] & 0x02);
    int connected_b = (d[TCCR1A] & 0x20) && (d[DDRB] & 0x04);
    int state[5] = {connected_a ? d[OCR1AL] : 0, (d[PORTD] >> 6) & 1,
                    connected_b ? d[OCR1BL] : 0, (d[PORTD] >> 5) & 1, (d[PORTB] >> 5) & 1};
    if (memcmp(state, last, sizeof state)) {
        memcpy(last, state, sizeof state);
        printf("W %llu %d %d %d %d %d\n", now(), state[0], state[1], state[2], state[3],
               state[4]);
    }
}

static void no_sleep(avr_t *a, avr_cycle_count_t howlong)
{
    (void)a; (void)howlong;  /* simulated time only: never wait for the wall clock */
}

static void run(unsigned long us)
{
    avr_cycle_count_t end = avr->cycle + (avr_cycle_count_t)us * CYCLES_PER_US;
    while (avr->cycle < end) {
        int state = avr_run(avr);
        watch_outputs();
        if (state == cpu_Done || state == cpu_Crashed) {
            printf("E %llu crashed\n", now());
            break;
        }
    }
}

static void start_timers(void)
{
    if (delivered < queued)
        avr_cycle_timer_register(avr, 1, feed, NULL);
    if (enc_left > 0 || enc_right > 0)
        avr_cycle_timer_register(avr, 1, edge, NULL);
}

static double wall_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

/* Real time, the UART on a pty: the AVR runs no faster than the wall clock (it would run
 * about 12 times faster), checked every simulated millisecond. */
static int run_pty(double seconds)
{
    static uart_pty_t pty;
    uart_pty_init(avr, &pty);
    uart_pty_connect(&pty, '0');
    printf("P %s\n", pty.port[0].slavename);
    double start = wall_seconds();
    avr_cycle_count_t step = F_CPU / 1000;
    while ((double)avr->cycle < seconds * F_CPU) {
        avr_cycle_count_t end = avr->cycle + step;
        while (avr->cycle < end) {
            int state = avr_run(avr);
            watch_outputs();
            if (state == cpu_Done || state == cpu_Crashed) {
                printf("E %llu crashed\n", now());
                uart_pty_stop(&pty);
                return 1;
            }
        }
        double ahead = (double)avr->cycle / F_CPU - (wall_seconds() - start);
        if (ahead > 0) {
            struct timespec nap = {0, (long)(ahead * 1e9)};
            nanosleep(&nap, NULL);
        }
    }
    uart_pty_stop(&pty);
    printf("T %llu\n", now());
    return 0;
}

int main(int argc, char **argv)
{
    double pty_seconds = 0;
    if (argc == 4 && !strcmp(argv[2], "--pty"))
        pty_seconds = atof(argv[3]);
    else if (argc != 2) {
        fprintf(stderr, "usage: %s mona.elf [--pty SECONDS] < commands\n", argv[0]);
        return 2;
    }
    elf_firmware_t firmware;
    memset(&firmware, 0, sizeof firmware);
    if (elf_read_firmware(argv[1], &firmware)) {
        fprintf(stderr, "monasim: cannot read %s\n", argv[1]);
        return 1;
    }
    avr = avr_make_mcu_by_name("atmega328p");
    if (!avr) {
        fprintf(stderr, "monasim: simavr has no atmega328p\n");
        return 1;
    }
    avr_init(avr);
    firmware.frequency = F_CPU;
    avr_load_firmware(avr, &firmware);
    avr->frequency = F_CPU;
    avr->vcc = avr->avcc = avr->aref = 3300;
    avr->sleep = no_sleep;
    uint32_t flags = 0;  /* no console echo of the firmware's bytes */
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            uart_out, NULL);
    drive_encoders(avr);  /* idle high, as the pull-ups leave them */
    for (int ch = 0; ch < 8; ch++)  /* nothing seen by the IR: the pin at AVcc */
        avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + ch), 3300);

    setvbuf(stdout, NULL, _IOLBF, 0);
    if (pty_seconds > 0)
        return run_pty(pty_seconds);
    char line[16384];
    while (fgets(line, sizeof line, stdin)) {
        char word[16] = "";
        sscanf(line, "%15s", word);
        if (!strcmp(word, "send")) {
            char *hex = line + 4;
            while (*hex == ' ')
                hex++;
            unsigned byte;
            int was_idle = delivered >= queued;
            while (sscanf(hex, "%2x", &byte) == 1 && queued < sizeof queue) {
                queue[queued++] = (uint8_t)byte;
                hex += 2;
            }
            if (was_idle)
                start_timers();
        } else if (!strcmp(word, "run")) {
            unsigned long us = strtoul(line + 3, NULL, 10);
            run(us);
        } else if (!strcmp(word, "adc")) {
            int ch, mv;
            if (sscanf(line + 3, "%d %d", &ch, &mv) == 2)
                avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + ch),
                              (uint32_t)mv);
        } else if (!strcmp(word, "enc")) {
            char side;
            int n, us;
            if (sscanf(line + 3, " %c %d %d", &side, &n, &us) == 3) {
                int idle = enc_left <= 0 && enc_right <= 0;
                *(side == 'L' ? &enc_left : &enc_right) += n;
                enc_period = us;
                if (idle)
                    avr_cycle_timer_register(avr, 1, edge, NULL);
            }
        } else if (!strcmp(word, "reset")) {
            avr_cycle_count_t before = avr->cycle;
            avr_reset(avr);
            offset += before - avr->cycle;
            start_timers();  /* a reset drops simavr's cycle timers */
        } else if (!strcmp(word, "quit")) {
            break;
        } else if (word[0]) {
            fprintf(stderr, "monasim: unknown command %s", line);
            return 2;
        }
        printf("T %llu\n", now());
    }
    return 0;
}
