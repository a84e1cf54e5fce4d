/* Helpers shared between the olf translation units; not part of the API. */
#ifndef ODOLINK_OLF_INTERNAL_H_
#define ODOLINK_OLF_INTERNAL_H_

#include <stddef.h>
#include <stdint.h>

#include "odolink/olf.h"

/* olf_number.c: little-endian integers; binary64 as parameters (bit exact)
 * and as the target's double (runs and telemetry). */
void olf_put_u16(uint8_t* out, uint16_t v);
void olf_put_u32(uint8_t* out, uint32_t v);
void olf_put_f64(uint8_t* out, olf_f64_t v);
void olf_put_double(uint8_t* out, double v);
uint16_t olf_get_u16(const uint8_t* in);
uint32_t olf_get_u32(const uint8_t* in);
olf_f64_t olf_get_f64(const uint8_t* in);
double olf_get_double(const uint8_t* in);
/* min <= value <= max, exactly (NaN never). */
int olf_f64_in_range(olf_f64_t value, double min_value, double max_value);

/* CRC-32 in pieces: olf_crc32(a + b) == olf_crc32_finish(update(update(start, a), b)). */
uint32_t olf_crc32_update(uint32_t state, const uint8_t* data, size_t len);
#define OLF_CRC32_START 0xFFFFFFFFu
#define olf_crc32_finish(state) ((state) ^ 0xFFFFFFFFu)

size_t olf_param_size(uint8_t type);
/* Writes parameter `index` of `params` in wire form; returns its size. */
size_t olf_param_put(const olf_params_t* params, unsigned index, uint8_t* out);
/* Range-checks and stores a wire value; 0 if out of range (nothing stored). */
int olf_param_from_wire(unsigned index, const uint8_t* in, olf_params_t* params);

void olf_record_build(uint32_t generation, const olf_params_t* active, const olf_params_t* previous,
                      int has_previous, uint8_t* out);
int olf_record_parse(const uint8_t* in, uint32_t* generation, olf_params_t* active,
                     olf_params_t* previous, int* has_previous);

#endif /* ODOLINK_OLF_INTERNAL_H_ */
