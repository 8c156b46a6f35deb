/* The boot nonce: a counter in EEPROM, incremented at every boot. */
#ifndef MONA_NONCE_H
#define MONA_NONCE_H
#include <stdint.h>
uint16_t nonce_boot(void);  /* call once at boot: this boot's nonce */
#endif
