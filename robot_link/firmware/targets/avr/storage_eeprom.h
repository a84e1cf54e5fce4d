/* The library's two-slot parameter storage on the ATmega's internal EEPROM,
 * at EEPROM offsets 0 .. OLF_STORAGE_SIZE-1. */
#ifndef ODOLINK_AVR_STORAGE_EEPROM_H_
#define ODOLINK_AVR_STORAGE_EEPROM_H_

#include "odolink/olf.h"

/* The olf_storage_t to put in olf_config_t.storage. */
olf_storage_t storage_eeprom(void);

#endif /* ODOLINK_AVR_STORAGE_EEPROM_H_ */
