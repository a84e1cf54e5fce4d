/* ARM semihosting (a debugger or QEMU with -semihosting-config enable=on
 * executes these host calls for the target). Only what the flash backend
 * needs. Without a host that answers, BKPT 0xAB faults: never call these on
 * a board running on its own. */
#ifndef ODOLINK_LM3S6965_SEMIHOST_H_
#define ODOLINK_LM3S6965_SEMIHOST_H_

#include <stdint.h>

enum {
  SEMIHOST_MODE_RPLUS_B = 3, /* "r+b": read/write, must exist */
  SEMIHOST_MODE_WPLUS_B = 7  /* "w+b": read/write, created or truncated */
};

/* Returns a handle, or -1. */
int32_t semihost_open(const char* name, uint32_t mode);
/* Absolute position; 0 on success. */
int32_t semihost_seek(int32_t handle, uint32_t pos);
/* Both return 1 only if all `len` bytes were transferred. */
int semihost_write(int32_t handle, const void* data, uint32_t len);
int semihost_read(int32_t handle, void* data, uint32_t len);
/* File length, or -1. */
int32_t semihost_flen(int32_t handle);
/* The command line QEMU hands the program (-semihosting-config arg=...),
 * NUL-terminated into `buf`; 1 on success. */
int semihost_get_cmdline(char* buf, uint32_t cap);

#endif /* ODOLINK_LM3S6965_SEMIHOST_H_ */
