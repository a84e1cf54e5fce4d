/* Parameter storage on a flash page pair.
 *
 * olf's storage is two slots of OLF_STORAGE_SLOT_SIZE bytes at offsets 0 and
 * OLF_STORAGE_SLOT_SIZE. Flash erases a whole 1 KB page at a time, so each
 * slot gets a page of its own: erasing slot B's page while writing a new
 * record can never touch the record in slot A. That is what makes olf's
 * write-new-then-switch scheme safe against a power cut here.
 *
 *   slot A: page at FLASH_PARAMS_BASE          (0x3F800), bytes 0..127 used
 *   slot B: page at FLASH_PARAMS_BASE + 1 KB   (0x3FC00), bytes 0..127 used
 *
 * The driver below enforces what flash allows, whatever the backend: only
 * whole pages are erased, programming is by aligned 32-bit word, a word may
 * only clear bits (anything else needs an erase first and is refused), and
 * every erase and every word is read back. */
#include <string.h>

#include "bsp.h"
#include "flash_hw.h"
#include "lm3s6965.h"

static int g_backend_ok;

int bsp_flash_backend_init(void);
int bsp_flash_backend_init(void) {
  g_backend_ok = FLASH_PARAMS_SIZE >= 2u * LM3S_FLASH_PAGE_SIZE && flash_hw_init();
  return g_backend_ok;
}

static int in_region(uint32_t addr, uint32_t len) {
  return addr >= FLASH_PARAMS_BASE && len <= FLASH_PARAMS_SIZE &&
         addr - FLASH_PARAMS_BASE <= FLASH_PARAMS_SIZE - len;
}

/* ---- Flash driver ---- */

static int flash_read(uint32_t addr, uint8_t* out, uint32_t len) {
  if (!in_region(addr, len)) return 0;
  return flash_hw_read(addr, out, len);
}

static int flash_erase_page(uint32_t page_addr) {
  uint8_t check[64];
  uint32_t at, i;
  if (page_addr % LM3S_FLASH_PAGE_SIZE != 0 || !in_region(page_addr, LM3S_FLASH_PAGE_SIZE)) {
    return 0;
  }
  if (!flash_hw_erase_page(page_addr)) return 0;
  for (at = 0; at < LM3S_FLASH_PAGE_SIZE; at += sizeof check) {
    if (!flash_hw_read(page_addr + at, check, sizeof check)) return 0;
    for (i = 0; i < sizeof check; ++i) {
      if (check[i] != 0xFFu) return 0;
    }
  }
  return 1;
}

static uint32_t load_le32(const uint8_t* b) {
  return (uint32_t)b[0] | ((uint32_t)b[1] << 8) | ((uint32_t)b[2] << 16) | ((uint32_t)b[3] << 24);
}

/* Programs `len` bytes at a word-aligned address; a trailing partial word is
 * padded with 0xFF (leaves those bytes erased). `data` may be unaligned. */
static int flash_program(uint32_t addr, const uint8_t* data, uint32_t len) {
  uint32_t done;
  if (addr % 4u != 0 || !in_region(addr, (len + 3u) & ~3u)) return 0;
  for (done = 0; done < len; done += 4u) {
    uint8_t bytes[4] = {0xFFu, 0xFFu, 0xFFu, 0xFFu};
    uint8_t cell[4];
    uint32_t word, old;
    memcpy(bytes, data + done, len - done < 4u ? len - done : 4u);
    word = load_le32(bytes);
    if (!flash_hw_read(addr + done, cell, 4)) return 0;
    old = load_le32(cell);
    if (word & ~old) return 0; /* would have to set a 0 bit back to 1: erase first */
    if (!flash_hw_program_word(addr + done, word)) return 0;
    if (!flash_hw_read(addr + done, cell, 4) || load_le32(cell) != word) return 0;
  }
  return 1;
}

/* ---- olf_storage_t on the page pair ---- */

/* Maps an olf storage range onto its slot's page; 0 if it straddles slots. */
static int slot_address(uint32_t offset, uint32_t len, uint32_t* page, uint32_t* addr) {
  const uint32_t slot = offset / OLF_STORAGE_SLOT_SIZE;
  const uint32_t inner = offset % OLF_STORAGE_SLOT_SIZE;
  if (slot > 1u || len > OLF_STORAGE_SLOT_SIZE - inner) return 0;
  *page = FLASH_PARAMS_BASE + slot * LM3S_FLASH_PAGE_SIZE;
  *addr = *page + inner;
  return 1;
}

static int storage_read(void* user, uint32_t offset, uint8_t* data, uint32_t len) {
  uint32_t page, addr;
  (void)user;
  if (!g_backend_ok || !slot_address(offset, len, &page, &addr)) return 0;
  return flash_read(addr, data, len);
}

/* olf writes a whole record into one slot: erase that slot's page, then
 * program the record. A cut between the two leaves the slot erased (invalid
 * record), the other slot untouched. */
static int storage_write(void* user, uint32_t offset, const uint8_t* data, uint32_t len) {
  uint32_t page, addr;
  (void)user;
  if (!g_backend_ok || !slot_address(offset, len, &page, &addr)) return 0;
  if (addr % 4u != 0) return 0; /* word-aligned programming only */
  return flash_erase_page(page) && flash_program(addr, data, len);
}

olf_storage_t bsp_storage(void) {
  olf_storage_t s;
  /* Kept even when the backend failed: reads then fail (the robot boots on
   * its defaults) and every commit is refused with OLF_ERR_STORAGE, rather
   * than commits that silently do not persist. */
  s.read = storage_read;
  s.write = storage_write;
  s.user = NULL;
  return s;
}
