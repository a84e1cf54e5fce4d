/*
 * odolink wire protocol constants, shared by the robot-side C library (olf_*)
 * and the odocal host client. This header is the single source of truth for
 * numbers on the wire; docs/protocol.md explains them with real bytes.
 *
 * Units on the wire carry their unit in the name: millimetres (`_mm`),
 * radians (`_rad`), milliseconds (`_ms`). Pose frames follow REP-103: the
 * odometry frame is the robot's start pose, x forward, y left, heading
 * counter-clockwise positive.
 *
 * All multi-byte integers are little-endian, floats are IEEE-754 binary64
 * little-endian, except the frame CRC-16 which is appended big-endian (the
 * order CRC-16/CCITT-FALSE is conventionally transmitted in).
 *
 * Pure C99, no includes beyond <stdint.h>.
 */
#ifndef ODOLINK_OLF_WIRE_H_
#define ODOLINK_OLF_WIRE_H_

#include <stdint.h>

/* Bumped on any incompatible change of the frame layout or of a message. */
#define OLF_PROTOCOL_VERSION 1u

/* Frame (before CRC and COBS): version u8, type u8, seq u16, body_len u8,
 * body. The explicit length matters: without it a duplicated trailing zero
 * passes CRC-16/CCITT-FALSE whenever the CRC's low byte is 0x00 (1 frame in
 * 256), because CRC(m, crc_hi) == crc_lo << 8 for a CRC without xorout. */
#define OLF_HEADER_SIZE 5u
#define OLF_CRC_SIZE 2u
/* Largest header + body; a frame longer than this is dropped as garbage. The
 * largest message the protocol defines is STATUS's reply, 52 bytes
 * (OLF_LARGEST_MESSAGE, checked against the code by the host tests); 64 keeps
 * a small margin and the robot's buffers small (an ATmega328P has 2 KiB). */
#define OLF_MAX_PAYLOAD 64u
#define OLF_LARGEST_MESSAGE 52u
/* Largest COBS-encoded frame without its 0x00 delimiter:
 * n + ceil(n / 254) + 1 for n = payload + CRC, rounded up. */
#define OLF_MAX_ENCODED (OLF_MAX_PAYLOAD + OLF_CRC_SIZE + 2u)
#define OLF_MAX_NAME 32u

/* Requests, host to robot. Every request is answered by ACK or NACK carrying
 * the same sequence number. */
enum olf_msg_type {
  OLF_MSG_HELLO = 0x01,          /* -> ACK: version, table, name           */
  OLF_MSG_PARAM_GET = 0x03,      /* name -> ACK: type, value (active set)   */
  OLF_MSG_PARAM_SET = 0x04,      /* name, type, value -> atomic commit of   */
                                 /* the active set with one value changed   */
  OLF_MSG_STAGE_BEGIN = 0x05,    /* clear the staging area                  */
  OLF_MSG_STAGE_PUT = 0x06,      /* name, type, value into the staging area */
  OLF_MSG_PARAMS_READ = 0x07,    /* which set -> ACK: mask, crc, values     */
  OLF_MSG_COMMIT = 0x08,         /* set crc32 -> persist + apply staged set */
  OLF_MSG_ROLLBACK = 0x09,       /* previous set becomes active again       */
  OLF_MSG_RUN_START = 0x0A,      /* procedure, direction, amount, count     */
  OLF_MSG_STOP = 0x0B,           /* immediate stop                          */
  OLF_MSG_TELEMETRY_RATE = 0x0C, /* rate_hz u16, 0 = off                    */
  OLF_MSG_STATUS = 0x0D,         /* -> ACK: state, run ids, last result     */

  /* Replies, robot to host. */
  OLF_MSG_ACK = 0x40,  /* body: request type, then the request's result  */
  OLF_MSG_NACK = 0x41, /* body: request type, error code (enum olf_error) */

  /* Unsolicited events, robot to host; seq is the robot's event counter. */
  OLF_MSG_TELEMETRY = 0x80,
  OLF_MSG_RUN_COMPLETE = 0x81
};

enum olf_error {
  OLF_ERR_NONE = 0,
  OLF_ERR_BAD_VERSION = 1,       /* body also carries the robot's version   */
  OLF_ERR_UNKNOWN_TYPE = 2,
  OLF_ERR_MALFORMED = 3,         /* body too short or too long for the type */
  OLF_ERR_UNKNOWN_PARAM = 4,
  OLF_ERR_TYPE_MISMATCH = 5,
  OLF_ERR_OUT_OF_RANGE = 6,
  OLF_ERR_STAGE_INCOMPLETE = 7,  /* commit before every parameter staged    */
  OLF_ERR_CHECKSUM = 8,          /* commit checksum != staged set checksum  */
  OLF_ERR_STORAGE = 9,           /* persisting failed; active set unchanged */
  OLF_ERR_BUSY = 10,             /* a run is in progress                    */
  OLF_ERR_NO_PREVIOUS = 11,      /* rollback with no previous set           */
  OLF_ERR_REJECTED = 12,         /* the robot's motion code refused the run */
  OLF_ERR_BAD_PROCEDURE = 13
};

enum olf_param_type { OLF_TYPE_F64 = 1, OLF_TYPE_U32 = 2 };

/* Which set OLF_MSG_PARAMS_READ reads. */
enum olf_param_set_id { OLF_SET_ACTIVE = 0, OLF_SET_STAGED = 1, OLF_SET_PREVIOUS = 2 };

enum olf_procedure {
  OLF_PROC_UMBMARK = 1,      /* amount_mm = side, direction cw/ccw        */
  OLF_PROC_STRAIGHT = 2,     /* amount_mm = distance                      */
  OLF_PROC_SPIN = 3,         /* count = turns, direction                  */
  OLF_PROC_OUT_AND_BACK = 4  /* amount_mm = distance, count = repeats     */
};
enum olf_direction { OLF_DIR_CW = 0, OLF_DIR_CCW = 1 };

enum olf_run_state { OLF_STATE_IDLE = 0, OLF_STATE_RUNNING = 1 };
enum olf_run_status { OLF_RUN_COMPLETED = 0, OLF_RUN_STOPPED = 1, OLF_RUN_FAILED = 2 };

#endif /* ODOLINK_OLF_WIRE_H_ */
