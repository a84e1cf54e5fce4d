/* Flash backend for a real LM3S6965: the flash memory controller (FMC).
 *
 * UNTESTED. Written from the LM3S6965 datasheet ("Flash Memory" chapter,
 * "Flash Memory Programming"), never run: QEMU's lm3s6965evb does not emulate
 * flash writes, and no board was available. Build it with
 * -DODOLINK_LM3S_FLASH=fmc and check it on hardware before trusting it.
 *
 * The core stalls while the controller erases or programs (the code runs
 * from the same flash), so no RAM function is needed. USECRL (set in
 * bsp_tick.c to the clock in MHz - 1) must match the system clock, or the
 * program and erase pulses have the wrong length. */
#include <string.h>

#include "flash_hw.h"
#include "lm3s6965.h"

int flash_hw_init(void) {
  FLASH_FCMISC = FLASH_FCRIS_ARIS; /* clear a stale access-violation flag */
  return 1;
}

int flash_hw_erase_page(uint32_t page_addr) {
  FLASH_FCMISC = FLASH_FCRIS_ARIS;
  FLASH_FMA = page_addr;
  FLASH_FMC = FLASH_FMC_WRKEY | FLASH_FMC_ERASE;
  while (FLASH_FMC & FLASH_FMC_ERASE) {
  }
  return !(FLASH_FCRIS & FLASH_FCRIS_ARIS);
}

int flash_hw_program_word(uint32_t addr, uint32_t word) {
  FLASH_FCMISC = FLASH_FCRIS_ARIS;
  FLASH_FMA = addr;
  FLASH_FMD = word;
  FLASH_FMC = FLASH_FMC_WRKEY | FLASH_FMC_WRITE;
  while (FLASH_FMC & FLASH_FMC_WRITE) {
  }
  return !(FLASH_FCRIS & FLASH_FCRIS_ARIS);
}

int flash_hw_read(uint32_t addr, uint8_t* out, uint32_t len) {
  memcpy(out, (const void*)(uintptr_t)addr, len); /* flash is memory-mapped */
  return 1;
}
