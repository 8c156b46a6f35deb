/* A millisecond clock from Timer2 (Timer1 makes the PWM, Timer0 is left alone). */
#ifndef MONA_CLOCK_H
#define MONA_CLOCK_H
#include <stdint.h>
void clock_init(void);
uint16_t clock_ms(void);  /* wraps every 65.5 s: compare differences only */
#endif
