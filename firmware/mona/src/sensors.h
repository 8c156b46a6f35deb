/* IR and battery through the ADC (AVcc reference), encoder edges on INT0/INT1. */
#ifndef MONA_SENSORS_H
#define MONA_SENSORS_H
#include <stdint.h>

#define IR_COUNT 5
#ifndef AVCC_MV
#define AVCC_MV 3300
#endif
#ifndef BATTERY_DIVIDER
#define BATTERY_DIVIDER 2  /* battery / ADC pin: unverified on hardware (docs/link.md) */
#endif

void sensors_init(void);
void sensors_ir(uint16_t ir[IR_COUNT]);  /* raw 10-bit, right to left; 1023 = nothing seen */
uint16_t sensors_battery_mv(void);
void sensors_ticks(uint16_t *left, uint16_t *right);  /* wrapping edge counts */
#endif
