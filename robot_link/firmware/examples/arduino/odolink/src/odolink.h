/* Arduino entry header of the odolink library: the IDE finds a library by a
 * header at the top of its src/ folder, so sketches include <odolink.h>. The
 * library's files sit next to this one: olf_*.c, olf_internal.h and
 * odolink/olf.h, odolink/olf_wire.h (copied from robot_link/firmware). */
#ifndef ODOLINK_ARDUINO_H_
#define ODOLINK_ARDUINO_H_

#include "odolink/olf.h"

#endif /* ODOLINK_ARDUINO_H_ */
